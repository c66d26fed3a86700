//! Marlin's line framing: `N<number> <command>*<checksum>`, the checksum
//! the XOR of every byte before `*`. A numbered line must carry the number
//! after the last one accepted (`M110 N<n>` sets it) and a good checksum;
//! otherwise it is refused with the error Marlin prints and a `Resend:` of
//! the line expected, and nothing of it runs. Lines without a number are
//! taken as they are (a checksum on one is still checked). Comments (`;`
//! to the end) and blank lines are dropped without a reply, as Marlin does.

/// Longest command taken, characters (Marlin's MAX_CMD_SIZE is 96; hosts
/// stay well under this).
pub const MAX_LINE: usize = 256;

/// Why a line was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// Not the number after the last line accepted.
    #[error("Line Number is not Last Line Number+1, Last Line: {last}")]
    LineNumber {
        /// The last line accepted.
        last: u32,
    },
    /// A numbered line without `*checksum`.
    #[error("No Checksum with line number, Last Line: {last}")]
    NoChecksum {
        /// The last line accepted.
        last: u32,
    },
    /// The checksum does not match the line (or is not a number).
    #[error("checksum mismatch, Last Line: {last}")]
    Checksum {
        /// The last line accepted.
        last: u32,
    },
    /// Longer than [`MAX_LINE`]: not resent (it would be as long again).
    #[error("line too long ({len} characters, at most {MAX_LINE})")]
    TooLong {
        /// Its length.
        len: usize,
    },
}

impl FrameError {
    /// Whether the host should send the line again (`Resend:`).
    pub fn resend(&self) -> bool {
        !matches!(self, FrameError::TooLong { .. })
    }
}

/// The checksum of `bytes`: their XOR.
pub fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |a, b| a ^ b)
}

/// Line numbers: the last one accepted.
#[derive(Clone, Debug, Default)]
pub struct Framer {
    /// The last line number accepted.
    pub last: u32,
}

impl Framer {
    /// The command in `raw` (one line without its end), `None` for a blank
    /// or comment line, or why it is refused. An accepted numbered line
    /// moves [`Framer::last`] on; `M110 N<n>` sets it to `n`.
    pub fn frame(&mut self, raw: &str) -> Result<Option<String>, FrameError> {
        let line = raw.split(';').next().unwrap_or("").trim();
        if line.is_empty() {
            return Ok(None);
        }
        if line.len() > MAX_LINE {
            return Err(FrameError::TooLong { len: line.len() });
        }
        let last = self.last;
        let (body, sum) = match line.rfind('*') {
            Some(i) => (&line[..i], Some(line[i + 1..].trim())),
            None => (line, None),
        };
        let numbered = number(body);
        let command = match numbered {
            Some((n, rest)) => {
                let m110 = is_m110(rest);
                if !m110 && Some(n) != last.checked_add(1) {
                    return Err(FrameError::LineNumber { last });
                }
                let Some(sum) = sum else {
                    return Err(FrameError::NoChecksum { last });
                };
                if sum.parse::<u8>().ok() != Some(checksum(body.as_bytes())) {
                    return Err(FrameError::Checksum { last });
                }
                self.last = if m110 {
                    m110_number(rest).unwrap_or(n)
                } else {
                    n
                };
                rest
            }
            None => {
                if let Some(sum) = sum {
                    if sum.parse::<u8>().ok() != Some(checksum(body.as_bytes())) {
                        return Err(FrameError::Checksum { last });
                    }
                }
                if is_m110(body) {
                    self.last = m110_number(body).unwrap_or(0);
                }
                body
            }
        };
        let command = command.trim();
        Ok((!command.is_empty()).then(|| command.to_string()))
    }
}

/// `N<digits>` at the start of `body`: the number and the rest.
fn number(body: &str) -> Option<(u32, &str)> {
    let rest = body.strip_prefix(['N', 'n'])?;
    let end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    let n = rest[..end].parse().ok()?;
    Some((n, &rest[end..]))
}

/// The code word of a command, upper case (`M110`, `G1`).
pub fn code(command: &str) -> String {
    let t = command.trim_start();
    let end = t
        .char_indices()
        .skip(1)
        .find(|(_, c)| !(c.is_ascii_digit() || *c == '.'))
        .map_or(t.len(), |(i, _)| i);
    t[..end].to_ascii_uppercase()
}

fn is_m110(command: &str) -> bool {
    code(command) == "M110"
}

/// The `N` argument of an `M110` command.
fn m110_number(command: &str) -> Option<u32> {
    let i = command.find(['N', 'n'])?;
    let digits: String = command[i + 1..]
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    digits.parse().ok()
}
