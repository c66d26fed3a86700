//! A small hand-written G-code lexer for one line at a time.
//!
//! Why not the `gcode` crate (0.7.0)? Its spans carry a byte offset and a line
//! but no column, it has no notion of the `*checksum` suffix that Marlin-style
//! senders append, it models code numbers as fixed-point `u32` with `assert!`s on
//! the way in, and it recovers from bad input by reporting diagnostics and
//! carrying on, where we want to stop at the first bad word with its
//! line:column. The subset we need (letter + number words, `;` and `( )`
//! comments, `N` numbers, `*` checksums) is a hundred lines of byte matching,
//! allocation-free and fast.

/// A lexing error: byte offset into the line and a message.
#[derive(Debug)]
pub(crate) struct LexError {
    pub at: usize,
    pub msg: String,
}

/// One word: an upper-case ASCII letter, the byte offset of the letter in the
/// line, and the (possibly empty) text of its value.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Word<'a> {
    pub letter: u8,
    pub at: usize,
    pub text: &'a str,
}

pub(crate) struct Lexer<'a> {
    line: &'a str,
    pos: usize,
    /// Set once a checksum has been read: only comments and blanks may follow.
    done: bool,
}

fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

fn is_value_byte(b: u8) -> bool {
    b.is_ascii_digit() || b == b'.' || b == b'-' || b == b'+'
}

impl<'a> Lexer<'a> {
    pub(crate) fn new(line: &'a str) -> Self {
        Lexer {
            line,
            pos: 0,
            done: false,
        }
    }

    fn err<T>(at: usize, msg: String) -> Result<T, LexError> {
        Err(LexError { at, msg })
    }

    /// Describe the (possibly multi-byte) character at byte offset `at`.
    fn char_at(&self, at: usize) -> char {
        self.line
            .get(at..)
            .and_then(|s| s.chars().next())
            .unwrap_or('?')
    }

    /// The next word, or `None` at the end of the line.
    #[inline(always)]
    pub(crate) fn next_word(&mut self) -> Result<Option<Word<'a>>, LexError> {
        let bytes = self.line.as_bytes();
        loop {
            let Some(&b) = bytes.get(self.pos) else {
                return Ok(None);
            };
            match b {
                b' ' | b'\t' | b'\r' => self.pos += 1,
                b';' => {
                    self.pos = bytes.len();
                    return Ok(None);
                }
                b'(' => match bytes[self.pos..].iter().position(|&c| c == b')') {
                    Some(n) => self.pos += n + 1,
                    None => return Self::err(self.pos, "unclosed '(' comment".into()),
                },
                b'*' if !self.done => {
                    self.checksum()?;
                }
                _ if self.done => {
                    return Self::err(self.pos, "only a comment may follow the checksum".into());
                }
                _ if b.is_ascii_alphabetic() => {
                    let at = self.pos;
                    self.pos += 1;
                    while bytes.get(self.pos).is_some_and(|&c| is_blank(c)) {
                        self.pos += 1;
                    }
                    let start = self.pos;
                    while bytes.get(self.pos).is_some_and(|&c| is_value_byte(c)) {
                        self.pos += 1;
                    }
                    let end = self.pos;
                    if let Some(&c) = bytes.get(self.pos) {
                        if !(c.is_ascii_alphabetic()
                            || is_blank(c)
                            || matches!(c, b';' | b'(' | b'*' | b'\r'))
                        {
                            let ch = self.char_at(self.pos);
                            return Self::err(self.pos, format!("unexpected character '{ch}'"));
                        }
                    }
                    let text = self.line.get(start..end).unwrap_or("");
                    return Ok(Some(Word {
                        letter: b.to_ascii_uppercase(),
                        at,
                        text,
                    }));
                }
                _ if is_value_byte(b) => {
                    return Self::err(self.pos, "number without a letter".into());
                }
                _ => {
                    let ch = self.char_at(self.pos);
                    return Self::err(self.pos, format!("unexpected character '{ch}'"));
                }
            }
        }
    }

    /// Read `*nnn` at the current position and verify it against the XOR of
    /// every byte before the `*`.
    fn checksum(&mut self) -> Result<(), LexError> {
        let bytes = self.line.as_bytes();
        let star = self.pos;
        let computed = bytes[..star].iter().fold(0u8, |a, &b| a ^ b);
        let mut end = star + 1;
        while bytes.get(end).is_some_and(|c| c.is_ascii_digit()) {
            end += 1;
        }
        if end == star + 1 {
            return Self::err(star, "'*' without a checksum number".into());
        }
        let digits = self.line.get(star + 1..end).unwrap_or("");
        let given: Option<u32> = if digits.len() <= 3 {
            digits.parse().ok()
        } else {
            None
        };
        if given != Some(u32::from(computed)) {
            return Self::err(
                star,
                format!("checksum mismatch: line says {digits}, computed {computed}"),
            );
        }
        self.pos = end;
        self.done = true;
        Ok(())
    }

    /// Skip the rest of the line (the arguments of a code we ignore), still
    /// verifying a trailing `*checksum` if there is one. The arguments may be
    /// free text (M117), so only a final `*digits` counts as a checksum.
    pub(crate) fn skip_rest(&mut self) -> Result<(), LexError> {
        let bytes = self.line.as_bytes();
        let rest_end = bytes[self.pos..]
            .iter()
            .position(|&c| c == b';')
            .map_or(bytes.len(), |n| self.pos + n);
        let body = &bytes[self.pos..rest_end];
        let trimmed = body.len()
            - body
                .iter()
                .rev()
                .take_while(|&&c| is_blank(c) || c == b'\r')
                .count();
        let body = &body[..trimmed];
        if let Some(star) = body.iter().rposition(|&c| c == b'*') {
            let tail = &body[star + 1..];
            if !tail.is_empty() && tail.iter().all(u8::is_ascii_digit) {
                self.pos += star;
                self.checksum()?;
            }
        }
        self.pos = bytes.len();
        Ok(())
    }
}

/// Parse a G-code number: optional sign, digits, optional `.` and digits,
/// with at least one digit (`1`, `-1.5`, `.5`, `+2`, `1.`).
#[inline]
pub(crate) fn number(text: &str) -> Option<f64> {
    const POW10: [f64; 16] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
    ];
    let b = text.as_bytes();
    let (neg, rest) = match b.first() {
        Some(b'-') => (true, &b[1..]),
        Some(b'+') => (false, &b[1..]),
        _ => (false, b),
    };
    // Fast path (Clinger): at most 15 digits, so the digits as an integer and
    // the power of ten are both exact and one division rounds correctly.
    let mut mant: u64 = 0;
    let mut digits = 0usize;
    let mut frac: Option<usize> = None;
    for &c in rest {
        match c {
            b'0'..=b'9' => {
                mant = mant.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
                digits += 1;
                if let Some(f) = frac.as_mut() {
                    *f += 1;
                }
            }
            b'.' if frac.is_none() => frac = Some(0),
            _ => return None,
        }
    }
    if digits == 0 {
        return None;
    }
    if digits <= 15 {
        let v = mant as f64 / POW10[frac.unwrap_or(0)];
        return Some(if neg { -v } else { v });
    }
    let v: f64 = text.parse().ok()?;
    v.is_finite().then_some(v)
}

/// A G/M/T code number times ten: `1` -> 10, `38.2` -> 382, `01` -> 10.
/// `None` for signs, more than one decimal digit or absurdly large numbers.
pub(crate) fn code10(text: &str) -> Option<u32> {
    let (int, frac) = match text.split_once('.') {
        Some((i, f)) => (i, f),
        None => (text, ""),
    };
    if int.is_empty() || !int.bytes().all(|c| c.is_ascii_digit()) || frac.len() > 1 {
        return None;
    }
    let int = int.trim_start_matches('0');
    if int.len() > 6 {
        return None;
    }
    let major: u32 = if int.is_empty() { 0 } else { int.parse().ok()? };
    let minor: u32 = match frac.bytes().next() {
        None => 0,
        Some(c) if c.is_ascii_digit() => u32::from(c - b'0'),
        Some(_) => return None,
    };
    Some(major * 10 + minor)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers() {
        for (t, v) in [
            ("1", 1.0),
            ("-1.5", -1.5),
            (".5", 0.5),
            ("+2", 2.0),
            ("1.", 1.0),
        ] {
            assert_eq!(number(t), Some(v), "{t}");
        }
        for t in [
            "0",
            "-0",
            "0.1",
            "123.456",
            "-98.744",
            "99999.99999",
            "1.0000000000001",
            "0.30000000000000004",
            "123456789012345",
            "1234567890123456",
            "-.0001",
            "00000000000000000001.5",
            "1e5",
            "1E5",
        ] {
            let want: Option<f64> = if t.contains(['e', 'E']) {
                None
            } else {
                t.parse().ok()
            };
            assert_eq!(number(t).map(f64::to_bits), want.map(f64::to_bits), "{t}");
        }
        for t in ["", ".", "-", "+-1", "1.2.3", "1-2", "--1"] {
            assert_eq!(number(t), None, "{t}");
        }
    }

    #[test]
    fn codes() {
        assert_eq!(code10("1"), Some(10));
        assert_eq!(code10("01"), Some(10));
        assert_eq!(code10("38.2"), Some(382));
        assert_eq!(code10("1."), Some(10));
        assert_eq!(code10("-1"), None);
        assert_eq!(code10("1.25"), None);
        assert_eq!(code10("99999999999999"), None);
    }
}
