//! Which job command each planned segment came from, so that a stopped job
//! can be resumed at the command whose segment it stopped in.

use motet_planner::{Command, PlanError, Planned, Planner};
use std::collections::VecDeque;

/// A planned item and the index of the command it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sourced {
    /// The planner's output.
    pub item: Planned,
    /// Index of the job command it came from.
    pub command: usize,
}

/// A [`Planner`] that tags its output with command indices.
///
/// The planner emits moves in the order they were queued, and queues a move
/// exactly when it changes the planner's tail (zero-length moves are dropped);
/// dwell segments are emitted while the command that causes them (a dwell, a
/// tool that settles) is pushed.
pub struct SourcedPlanner {
    planner: Planner,
    moves: VecDeque<usize>,
    current: usize,
}

impl SourcedPlanner {
    /// Tags the output of `planner`, which must have nothing queued yet.
    pub fn new(planner: Planner) -> SourcedPlanner {
        SourcedPlanner {
            planner,
            moves: VecDeque::new(),
            current: 0,
        }
    }

    /// Plans command `index` of the job.
    pub fn push(&mut self, index: usize, cmd: &Command) -> Result<(), PlanError> {
        let before = self.planner.tail();
        self.current = index;
        self.planner.push(cmd)?;
        if self.planner.tail() != before {
            self.moves.push_back(index);
        }
        Ok(())
    }

    /// Moves pushed from now on take at least `min_move_s` seconds.
    pub fn set_min_move_s(&mut self, min_move_s: f64) {
        self.planner.set_min_move_s(min_move_s);
    }

    /// The shortest move time moves are planned with now, seconds.
    pub fn min_move_s(&self) -> f64 {
        self.planner.limits().min_move_s
    }

    /// The job has ended: the planner plans its tail to rest.
    pub fn finish(&mut self) {
        self.planner.finish();
    }

    /// The next planned item that is final, with its command.
    pub fn pop(&mut self) -> Option<Sourced> {
        let item = self.planner.pop()?;
        let command = match &item {
            Planned::Segment(s) if s.profile.length() > 0.0 => {
                self.moves.pop_front().unwrap_or(self.current)
            }
            _ => self.current,
        };
        Some(Sourced { item, command })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_planner::{Move, MoveKind};

    #[test]
    fn segments_name_their_commands() {
        let machine = motet_host::Machine::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/plotter.toml"
        )))
        .unwrap();
        let mv = |x: f64, y: f64| {
            let mut target = machine.start;
            target[0] = x;
            target[1] = y;
            Command::Move(Move {
                target,
                feed: 50.0,
                kind: MoveKind::Feed,
            })
        };
        // (command, segments it should own)
        let cmds = [
            mv(10.0, 0.0),
            mv(10.0, 0.0), // zero length: no segment
            mv(10.0, 10.0),
            Command::Dwell { seconds: 0.5 },
            mv(0.0, 10.0),
            mv(0.0, 0.0),
        ];
        let mut p = SourcedPlanner::new(Planner::new(machine.limits(), machine.start, 0.0));
        let mut got = Vec::new();
        for (i, c) in cmds.iter().enumerate() {
            p.push(i, c).unwrap();
            while let Some(s) = p.pop() {
                if let Planned::Segment(seg) = s.item {
                    got.push((s.command, seg.profile.length() > 0.0));
                }
            }
        }
        p.finish();
        while let Some(s) = p.pop() {
            if let Planned::Segment(seg) = s.item {
                got.push((s.command, seg.profile.length() > 0.0));
            }
        }
        assert_eq!(
            got,
            vec![(0, true), (2, true), (3, false), (4, true), (5, true)]
        );
    }
}
