//! One EBB command line: a one- or two-letter name (any case), then
//! comma-separated parameters, as the board's parser reads it. Parameters
//! are checked against each command's arity and ranges here, so a handler
//! only sees values it can act on.

use super::reply::EbbError;

/// A command line split into its name and raw parameters.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Line {
    /// The command's name, upper case (`SM`, `V`).
    pub name: String,
    /// Its parameters as sent, without the commas.
    pub params: Vec<String>,
}

/// Splits `text` (without its `\r`) into name and parameters; a name that is
/// not one or two letters is an unknown command.
pub fn split(text: &str) -> Result<Line, EbbError> {
    let (head, rest) = match text.find(',') {
        Some(i) => (&text[..i], Some(&text[i + 1..])),
        None => (text, None),
    };
    let name = head.to_ascii_uppercase();
    let letters = name.chars().all(|c| c.is_ascii_alphanumeric());
    if name.is_empty() || name.len() > 2 || !letters {
        // The board reads a name's first two characters and no more.
        return Err(EbbError::Unknown(name.chars().take(2).collect()));
    }
    let params = match rest {
        Some(r) => r.split(',').map(str::to_string).collect(),
        None => Vec::new(),
    };
    Ok(Line { name, params })
}

impl Line {
    /// Checks the count of parameters: fewer than `required` is
    /// `!4 Missing parameter(s)`, more than `required + optional` is
    /// `!7 Extra parameter`.
    pub fn arity(&self, required: usize, optional: usize) -> Result<(), EbbError> {
        let n = self.params.len();
        if n < required {
            return Err(EbbError::Missing);
        }
        if n > required + optional {
            return Err(EbbError::Extra);
        }
        Ok(())
    }

    /// Parameter `i` as an integer within `min..=max`; absent: `None`.
    pub fn int(&self, i: usize, min: i64, max: i64) -> Result<Option<i64>, EbbError> {
        let Some(p) = self.params.get(i) else {
            return Ok(None);
        };
        let v = integer(p)?;
        if v < min || v > max {
            return Err(EbbError::Invalid);
        }
        Ok(Some(v))
    }

    /// Parameter `i`, which the arity check made present.
    pub fn req(&self, i: usize, min: i64, max: i64) -> Result<i64, EbbError> {
        self.int(i, min, max)?.ok_or(EbbError::Missing)
    }

    /// Parameter `i` as a port letter `A`..=`E` (the `PI`/`PO`/`PD` port).
    pub fn port(&self, i: usize) -> Result<char, EbbError> {
        let p = self.params.get(i).ok_or(EbbError::Missing)?;
        let mut cs = p.chars();
        match (cs.next().map(|c| c.to_ascii_uppercase()), cs.next()) {
            (Some(c @ 'A'..='E'), None) => Ok(c),
            (Some(_), Some(c)) => Err(EbbError::NeedComma(c)),
            _ => Err(EbbError::Invalid),
        }
    }
}

/// A decimal integer with an optional sign, as the board reads one: digits
/// followed by anything but the end is `!5 Need comma next`; no digits, or
/// more than fit in 64 bits, is `!6 Invalid parameter value`.
fn integer(p: &str) -> Result<i64, EbbError> {
    let body = p.strip_prefix(['-', '+']).unwrap_or(p);
    let digits = body.bytes().take_while(u8::is_ascii_digit).count();
    if digits == 0 {
        return Err(EbbError::Invalid);
    }
    if let Some(c) = body[digits..].chars().next() {
        return Err(EbbError::NeedComma(c));
    }
    p.parse::<i64>().map_err(|_| EbbError::Invalid)
}
