//! X3G files: the commands a bot would take over the wire, one after the
//! other with no framing (what `gpx` writes and a bot plays from its SD
//! card). Each command's length comes from its number.

use crate::command::{check_len, Command, CommandError};

/// A command stream that could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("X3G byte {offset}: {error}")]
pub struct StreamError {
    /// Where the command starts in the stream.
    pub offset: usize,
    /// What is wrong with it.
    pub error: CommandError,
}

/// Reads every command of a stream; the first unreadable one is an error
/// naming its offset.
pub fn read_commands(bytes: &[u8]) -> Result<Vec<Command>, StreamError> {
    let mut out = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let c = bytes[at];
        let body = &bytes[at + 1..];
        let len = check_len(c, body).map_err(|error| StreamError { offset: at, error })?;
        if len > body.len() {
            return Err(StreamError {
                offset: at,
                error: CommandError::Length {
                    code: c,
                    name: crate::command::describe(c).map_or("?", |d| d.1),
                    got: body.len(),
                    want: len,
                },
            });
        }
        let cmd = Command::decode(&bytes[at..at + 1 + len])
            .map_err(|error| StreamError { offset: at, error })?;
        out.push(cmd);
        at += 1 + len;
    }
    Ok(out)
}
