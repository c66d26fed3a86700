//! Replies as the EBB (firmware 3.0) sends them, in both of its syntaxes:
//! legacy (the default: `OK\r\n` after commands, data lines before it) and
//! future (`CU,10,1`: every reply starts with the command's name and ends
//! with `\n`). Errors are the board's own `!N Err: ...` lines.

/// Which of the board's reply syntaxes is on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Syntax {
    /// The power-on default: `OK\r\n` acknowledgements.
    #[default]
    Legacy,
    /// After `CU,10,1`: the command's name echoed, `\n` endings.
    Future,
}

/// How a legacy data line ends, per command (the board is not uniform).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ending {
    /// `\r\n`, then nothing (`V`, `QG`, `PI`).
    Norm,
    /// `\r\n` then `OK\r\n` (`QB`, `QC`, `QE`, `QL`, `QT`).
    NormOk,
    /// `\n\r` then `OK\r\n` (`QP`, `QR`, `QS`, `ES`).
    RevOk,
    /// `\n\r`, then nothing (`QM`).
    Rev,
}

/// An error the board reports for a command; nothing of the command is
/// done.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EbbError {
    /// A step rate the board cannot make.
    #[error("!1 Err: Invalid step rate")]
    StepRate,
    /// A command line longer than the board's 255-byte buffer.
    #[error("!3 Err: RX Buffer overrun")]
    RxOverrun,
    /// Fewer parameters than the command needs.
    #[error("!4 Err: Missing parameter(s)")]
    Missing,
    /// A character after a number where a comma or the end belongs.
    #[error("!5 Err: Need comma next, found: '{0}'")]
    NeedComma(char),
    /// A parameter too large, too small or not a number; also a move the
    /// machine cannot make (beyond its travel) or cannot take now.
    #[error("!6 Err: Invalid parameter value")]
    Invalid,
    /// More parameters than the command takes.
    #[error("!7 Err: Extra parameter")]
    Extra,
    /// A command name the board does not know.
    #[error("!8 Err: Unknown command '{}:{}'", .0, hex(.0))]
    Unknown(String),
}

fn hex(name: &str) -> String {
    name.bytes().map(|b| format!("{b:02X}")).collect()
}

impl Syntax {
    /// The acknowledgement of a command that returns no data.
    pub fn ok(self, name: &str) -> String {
        match self {
            Syntax::Legacy => "OK\r\n".into(),
            Syntax::Future => format!("{name}\n"),
        }
    }

    /// A query's data line. `named`: the legacy line starts with the name
    /// too (`PI,1`, `QM,...`), as the board prints it.
    pub fn data(self, name: &str, data: &str, ending: Ending, named: bool) -> String {
        match self {
            Syntax::Future => format!("{name},{data}\n"),
            Syntax::Legacy => {
                let head = if named {
                    format!("{name},{data}")
                } else {
                    data.to_string()
                };
                let tail = match ending {
                    Ending::Norm => "\r\n",
                    Ending::NormOk => "\r\nOK\r\n",
                    Ending::RevOk => "\n\rOK\r\n",
                    Ending::Rev => "\n\r",
                };
                format!("{head}{tail}")
            }
        }
    }

    /// An error line: the board prints the command's name and a comma
    /// first in the future syntax.
    pub fn error(self, name: &str, e: &EbbError) -> String {
        match self {
            Syntax::Legacy => format!("{e}\r\n"),
            Syntax::Future if name.is_empty() => format!("{e}\n"),
            Syntax::Future => format!("{name},{e}\n"),
        }
    }
}
