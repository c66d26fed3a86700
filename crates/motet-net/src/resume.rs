//! Continuing a stopped job: from the journal and where the nodes came to
//! rest, the commands that finish the job with nothing lost or done twice.
//!
//! When sealing stops, the nodes run the committed window to its end but slow
//! down from the tail's first segment on, with every tool output off. The job
//! is therefore complete up to the start of that segment (`R`), and the
//! machine rests at the window's end (`P`). The resumed job travels from `P`
//! back to `R` with tools off, restores every tool to the value the job had
//! given it before that segment's command, and runs the job from that
//! command on.

use crate::journal::Journal;
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_trajectory::Point;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ResumeError {
    #[error("the journal has no window ending at segment {0}: the nodes and the journal disagree")]
    NoSeal(u32),
    #[error("the journal has no segment {0}")]
    NoSegment(u32),
    #[error("segment {segment} came from command {command}, but the job has {len} commands: is it the same job?")]
    NotThisJob {
        segment: u32,
        command: usize,
        len: usize,
    },
}

/// What to run to finish a stopped job.
#[derive(Clone, Debug, PartialEq)]
pub struct Resumption {
    /// Where the machine rests now.
    pub from: Point,
    /// Where the job continues (the start of the first slowed segment).
    pub to: Point,
    /// The command the job continues at.
    pub command: usize,
    pub commands: Vec<Located<Command>>,
}

/// The commands that finish `commands` after a stop whose committed window
/// ended before segment `window_end`.
pub fn resume(
    commands: &[Located<Command>],
    journal: &Journal,
    window_end: u32,
    start: Point,
) -> Result<Resumption, ResumeError> {
    if window_end == 0 {
        return Ok(Resumption {
            from: start,
            to: start,
            command: 0,
            commands: commands.to_vec(),
        });
    }
    let seal = journal
        .seal_ending(window_end)
        .ok_or(ResumeError::NoSeal(window_end))?;
    let last = journal
        .segment(window_end - 1)
        .ok_or(ResumeError::NoSegment(window_end - 1))?;
    let from = last.end;
    let (to, command) = if seal.tail < window_end {
        let s = journal
            .segment(seal.tail)
            .ok_or(ResumeError::NoSegment(seal.tail))?;
        (s.start, s.command)
    } else {
        // The window ended at rest with no tail: continue after its last
        // segment's command.
        (from, last.command + 1)
    };
    if command > commands.len() {
        return Err(ResumeError::NotThisJob {
            segment: seal.tail,
            command,
            len: commands.len(),
        });
    }
    Ok(resume_at(commands, from, to, command))
}

/// The commands that finish `commands` from command `command`, with the
/// machine at rest at `from` and the job continuing at `to`.
pub fn resume_at(
    commands: &[Located<Command>],
    from: Point,
    to: Point,
    command: usize,
) -> Resumption {
    let command = command.min(commands.len());
    let here = commands
        .get(command)
        .map(|c| c.loc)
        .or_else(|| commands.last().map(|c| c.loc))
        .unwrap_or(SourceLoc { line: 0, column: 0 });
    let mut out = Vec::new();
    if to != from {
        out.push(Located {
            loc: here,
            item: Command::Move(Move {
                target: to,
                feed: f64::INFINITY,
                kind: MoveKind::Rapid,
            }),
        });
    }
    // The tools as the job left them before `command`.
    let mut tools: Vec<Option<Located<Command>>> = Vec::new();
    for c in &commands[..command] {
        let t = match c.item {
            Command::Tool { tool, .. } | Command::ToolPerSpeed { tool, .. } => tool as usize,
            _ => continue,
        };
        if tools.len() <= t {
            tools.resize(t + 1, None);
        }
        tools[t] = Some(c.clone());
    }
    out.extend(tools.into_iter().flatten());
    out.extend_from_slice(&commands[command..]);
    Resumption {
        from,
        to,
        command,
        commands: out,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::journal::{JournalSeal, JournalSegment};

    fn at(x: f64) -> Point {
        [x, 0.0, 0.0, 0.0, 0.0, 0.0]
    }

    fn job() -> Vec<Located<Command>> {
        let loc = |line| SourceLoc { line, column: 1 };
        let mv = |x| {
            Command::Move(Move {
                target: at(x),
                feed: 10.0,
                kind: MoveKind::Feed,
            })
        };
        vec![
            Located {
                loc: loc(1),
                item: Command::Tool {
                    tool: 0,
                    value: 1.0,
                },
            },
            Located {
                loc: loc(2),
                item: mv(1.0),
            },
            Located {
                loc: loc(3),
                item: mv(2.0),
            },
            Located {
                loc: loc(4),
                item: Command::Tool {
                    tool: 0,
                    value: 0.5,
                },
            },
            Located {
                loc: loc(5),
                item: mv(3.0),
            },
            Located {
                loc: loc(6),
                item: mv(4.0),
            },
        ]
    }

    fn journal() -> Journal {
        let seg = |i: u32, c: usize| JournalSegment {
            index: i,
            command: c,
            start: at(i as f64),
            end: at(i as f64 + 1.0),
        };
        Journal {
            segments: vec![seg(0, 1), seg(1, 2), seg(2, 4), seg(3, 5)],
            seals: vec![
                JournalSeal { end: 2, tail: 2 },
                JournalSeal { end: 4, tail: 2 },
            ],
        }
    }

    #[test]
    fn resumes_at_the_first_slowed_segment() {
        let r = resume(&job(), &journal(), 4, at(0.0)).unwrap();
        assert_eq!((r.from, r.to, r.command), (at(4.0), at(2.0), 4));
        // Travel back, the tool as command 3 left it, then commands 4 and 5.
        assert!(
            matches!(r.commands[0].item, Command::Move(m) if m.target == at(2.0) && m.kind == MoveKind::Rapid)
        );
        assert_eq!(
            r.commands[1].item,
            Command::Tool {
                tool: 0,
                value: 0.5
            }
        );
        assert_eq!(&r.commands[2..], &job()[4..]);
    }

    #[test]
    fn a_window_at_rest_continues_after_it() {
        let r = resume(&job(), &journal(), 2, at(0.0)).unwrap();
        assert_eq!((r.from, r.to, r.command), (at(2.0), at(2.0), 3));
        assert_eq!(
            r.commands[0].item,
            Command::Tool {
                tool: 0,
                value: 1.0
            }
        );
        assert_eq!(&r.commands[1..], &job()[3..]);
    }

    #[test]
    fn nothing_committed_runs_everything() {
        let r = resume(&job(), &journal(), 0, at(0.0)).unwrap();
        assert_eq!(r.commands, job());
    }

    #[test]
    fn disagreements_are_errors() {
        assert_eq!(
            resume(&job(), &journal(), 3, at(0.0)),
            Err(ResumeError::NoSeal(3))
        );
        let short = &job()[..2];
        assert!(matches!(
            resume(short, &journal(), 4, at(0.0)),
            Err(ResumeError::NotThisJob { .. })
        ));
    }
}
