//! Commands streamed into the session a line at a time (a grbl sender's
//! G-code): appended to the run under way while its feed is open
//! ([`motet_net::NetRun::push_commands`]), so the planner's lookahead runs
//! across lines and the machine does not stop between them; queued for the
//! next run when the run has planned to rest (no line came in time), which
//! starts from rest as soon as there is something to run.
//!
//! The queue is counted in blocks, as grbl's planner is: one block per line
//! that made commands, freed when the machine has run it.

use super::{Activity, Session, State};
use crate::events::Level;
use crate::session::ActionError;
use motet_planner::{Command, Located, SourceLoc};
use std::collections::VecDeque;

/// Blocks (lines with motion or tool commands) the queue holds: lines
/// accepted and not yet run by the machine.
pub const STREAM_BLOCKS: usize = 128;

/// A first line waits this long for more before its run starts, µs, so the
/// planner starts with lookahead (as grbl does with its planner buffer).
const START_AFTER_US: u64 = 30_000;

/// The streamed commands.
#[derive(Default)]
pub(crate) struct Stream {
    /// Accepted, not yet given to a run.
    waiting: VecDeque<Located<Command>>,
    /// The current stream run's commands (prelude included), its index = the
    /// run's command index: where a hold continues from.
    run: Vec<Located<Command>>,
    /// The command a held stream continues from.
    held_at: Option<usize>,
    /// Blocks accepted so far; a command's `loc.line` is its block.
    blocks: u32,
    /// When the last block was accepted, µs.
    last_at: u64,
    /// Stream runs started (each from rest).
    runs: u64,
}

/// What the stream is doing, for a status report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamStatus {
    /// Blocks free in the queue, of [`STREAM_BLOCKS`].
    pub blocks_free: usize,
    /// Runs started from rest for the stream since the session began.
    pub runs: u64,
}

impl Session {
    /// Blocks the stream may still take.
    pub fn stream_status(&self) -> StreamStatus {
        StreamStatus {
            blocks_free: STREAM_BLOCKS.saturating_sub(self.blocks_in_flight()),
            runs: self.stream.runs,
        }
    }

    /// Lines accepted and not yet run: from the block the machine runs (or
    /// where a held stream continues) to the newest.
    fn blocks_in_flight(&self) -> usize {
        let s = &self.stream;
        let oldest = match (&self.activity, self.state) {
            (Activity::Stream, State::Running | State::Holding | State::Stopping) => {
                let run = self.nodes.run();
                let at = run.command_at(self.now as f64).unwrap_or(0);
                s.run.get(at).map(|c| c.loc.line)
            }
            (Activity::Stream, State::Paused) => {
                s.held_at.and_then(|at| s.run.get(at)).map(|c| c.loc.line)
            }
            _ => None,
        }
        .or_else(|| s.waiting.front().map(|c| c.loc.line));
        oldest.map_or(0, |o| (s.blocks + 1).saturating_sub(o) as usize)
    }

    /// Whether the machine runs a jog.
    pub fn jogging(&self) -> bool {
        matches!(self.activity, Activity::Other("jog"))
            && matches!(
                self.state,
                State::Running | State::Holding | State::Stopping
            )
    }

    /// Whether streamed commands are queued, running or held.
    pub fn streaming(&self) -> bool {
        matches!(self.activity, Activity::Stream) || !self.stream.waiting.is_empty()
    }

    /// Accepts one line's commands (machine coordinates) into the stream:
    /// refused, taking nothing, when the queue is full, the machine is busy
    /// with something else, or a move leaves the machine's travel.
    pub fn stream_push(
        &mut self,
        commands: Vec<Located<Command>>,
        from: motet_trajectory::Point,
    ) -> Result<(), ActionError> {
        let busy_otherwise = match self.state {
            State::Idle => false,
            State::Running | State::Holding | State::Paused => {
                !matches!(self.activity, Activity::Stream)
            }
            State::Stopping | State::Stopped | State::Alarm => true,
        };
        if busy_otherwise {
            return Err(ActionError::WrongState {
                action: "stream G-code",
                state: self.state,
            });
        }
        let mut at = from;
        for c in &commands {
            if let Command::Move(m) = c.item {
                motet_host::check_move(&self.machine, &at, &m.target)?;
                at = m.target;
            }
        }
        if commands.is_empty() {
            return Ok(());
        }
        if self.blocks_in_flight() >= STREAM_BLOCKS {
            return Err(ActionError::OutOfRange {
                what: "queued blocks",
                value: STREAM_BLOCKS as f64,
                range: format!("at most {STREAM_BLOCKS}"),
            });
        }
        self.stream.blocks += 1;
        self.stream.last_at = self.now;
        let block = self.stream.blocks;
        let commands: Vec<_> = commands
            .into_iter()
            .map(|c| Located {
                loc: SourceLoc {
                    line: block,
                    column: c.loc.column,
                },
                item: c.item,
            })
            .collect();
        let into_run = matches!(self.activity, Activity::Stream)
            && self.state == State::Running
            && self.stream.waiting.is_empty();
        if into_run && self.nodes.run_mut().push_commands(commands.clone()) {
            self.heaters_track_more(&commands, self.stream.run.len());
            self.stream.run.extend(commands);
        } else {
            self.stream.waiting.extend(commands);
        }
        Ok(())
    }

    /// On the clock: starts a run for waiting commands once the machine is
    /// at rest and idle (a first line waits a moment for more).
    pub(super) fn stream_tick(&mut self) {
        let idle = self.state == State::Idle && matches!(self.activity, Activity::None);
        if !idle || self.stream.waiting.is_empty() {
            return;
        }
        let full = self.blocks_in_flight() >= STREAM_BLOCKS;
        if !full && self.now < self.stream.last_at + START_AFTER_US {
            return;
        }
        let commands: Vec<_> = self.stream.waiting.drain(..).collect();
        self.begin_stream(commands);
    }

    fn begin_stream(&mut self, commands: Vec<Located<Command>>) {
        self.stream.run = commands.clone();
        self.stream.held_at = None;
        self.stream.runs += 1;
        let n = self.stream.runs;
        self.events.push(
            self.now,
            Level::Info,
            format!("stream run {n} started from rest"),
        );
        self.heaters_track_run(&commands);
        self.nodes.begin(&self.machine, commands, self.rest);
        self.nodes.run_mut().keep_feed_open();
        self.activity = Activity::Stream;
        self.state = State::Running;
        self.stopping = None;
        self.reason = None;
        self.tick(self.now);
    }

    /// A stream run ended at rest: the next one starts when commands wait.
    pub(super) fn stream_run_done(&mut self) {
        self.stream.run.clear();
    }

    /// A held stream run is at rest on its path: where it continues.
    /// Changes every streamed command not yet planned with `f` (grbl's
    /// overrides, applied live): those in the running stream's run not yet
    /// planned, those a held stream will continue with, and those waiting.
    /// What is planned runs as planned (the next ~30 ms and the planner's
    /// lookahead).
    pub fn stream_adjust(&mut self, f: &mut dyn FnMut(&mut Command)) {
        let running = matches!(self.activity, Activity::Stream) && self.state == State::Running;
        let from = if running {
            let (from, pending) = self.nodes.run_mut().pending_commands_mut();
            for c in pending {
                f(&mut c.item);
            }
            from
        } else {
            self.stream.held_at.unwrap_or(self.stream.run.len())
        };
        let from = from.min(self.stream.run.len());
        for c in &mut self.stream.run[from..] {
            f(&mut c.item);
        }
        for c in &mut self.stream.waiting {
            f(&mut c.item);
        }
    }

    pub(super) fn stream_held(&mut self, next_command: usize) {
        self.stream.held_at = Some(next_command.min(self.stream.run.len()));
    }

    /// Feed hold on the stream: brakes on the path; commands keep coming
    /// into the queue while it is held.
    pub fn stream_hold(&mut self) -> Result<(), ActionError> {
        match (self.state, &self.activity) {
            // Lines queued, their run not started yet: it does not start.
            (State::Idle, Activity::None) if !self.stream.waiting.is_empty() => {
                self.stream.run.clear();
                self.stream.held_at = Some(0);
                self.activity = Activity::Stream;
                self.state = State::Paused;
                self.events
                    .push(self.now, Level::Info, "held before moving".into());
                Ok(())
            }
            (State::Running, Activity::Stream) => {
                if self.stop(super::Stopping::Hold, "feed hold") {
                    self.state = State::Holding;
                }
                Ok(())
            }
            (state, _) => Err(ActionError::WrongState {
                action: "hold the stream",
                state,
            }),
        }
    }

    /// Continues a held stream exactly where it rests: the commands it had
    /// not finished, then those that came while it was held.
    pub fn stream_resume(&mut self) -> Result<(), ActionError> {
        let (State::Paused, Activity::Stream, Some(at)) =
            (self.state, &self.activity, self.stream.held_at)
        else {
            return Err(ActionError::WrongState {
                action: "resume the stream",
                state: self.state,
            });
        };
        let res = motet_net::resume::resume_at(&self.stream.run, self.rest, self.rest, at);
        let mut commands = res.commands;
        commands.extend(self.stream.waiting.drain(..));
        self.events
            .push(self.now, Level::Info, "stream resumed".into());
        self.activity = Activity::None;
        self.begin_stream(commands);
        Ok(())
    }

    /// Drops every streamed command not yet run (a soft reset); the caller
    /// stops the machine.
    pub fn stream_clear(&mut self) {
        self.stream.waiting.clear();
        self.stream.held_at = None;
        if matches!(self.activity, Activity::Stream) && self.state == State::Paused {
            self.activity = Activity::None;
            self.state = State::Idle;
        }
    }

    /// Where the machine rests, or the end of the last streamed command when
    /// commands are queued: where the next line starts.
    pub fn rest(&self) -> motet_trajectory::Point {
        self.rest
    }
}
