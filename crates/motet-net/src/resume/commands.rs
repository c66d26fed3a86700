//! The commands of a resumed run: travel back, the tools restored, the rest
//! of the job.

use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_trajectory::Point;

/// The commands that finish `commands` from command `command`, with the
/// machine at rest at `from` and the job continuing at `to`.
pub fn resume_at(
    commands: &[Located<Command>],
    from: Point,
    to: Point,
    command: usize,
) -> ResumeAt {
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
    ResumeAt {
        from,
        to,
        command,
        commands: out,
    }
}

/// [`resume_at`]'s result.
#[derive(Clone, Debug, PartialEq)]
pub struct ResumeAt {
    /// Where the machine rests.
    pub from: Point,
    /// Where the job continues; the travel there, if any, is the first
    /// command.
    pub to: Point,
    /// The job command it continues at, at most the job's length.
    pub command: usize,
    /// Travel to `to` (unless already there), each tool's last setting
    /// before `command`, then the job from `command` on.
    pub commands: Vec<Located<Command>>,
}
