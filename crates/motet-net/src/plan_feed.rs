//! The trajectory of a networked run as the nodes get it: the job's commands
//! planned one at a time and quantized as the segment stream carries them,
//! each item tagged with the command it came from.
//!
//! A run and `motet resume` go through this one path. The planner is pure
//! and deterministic, so the same commands, machine, start point, start time
//! and shortest move time give the same segments bit for bit: resuming
//! re-plans the stopped run and compares the result with its journal.

use crate::journal::{JournalHeader, JournalHold, JournalPace};
use crate::source::{Sourced, SourcedPlanner};
use motet_host::{Distributor, Machine};
use motet_planner::{Command, Limits, Located, PlanError, Planned, Planner, SourceLoc};
use motet_trajectory::{Point, Segment};
use std::collections::VecDeque;

/// The machine's limits as a run plans with them.
pub fn run_limits(machine: &Machine, min_move_s: f64) -> Limits {
    let mut l = machine.limits();
    l.min_move_s = min_move_s;
    l
}

/// Where a run's commands come from when they are read as the run goes
/// (a job file read a second time, once it was checked and planned through
/// in full), so that a job of any length runs in the same memory.
pub trait CommandSource: Send {
    /// The next command, `None` at the end. An error (saying where) ends
    /// the run as a planning error would: nothing already sealed is lost.
    fn next_command(&mut self) -> Option<Result<Located<Command>, String>>;
}

/// Why a feed could not give its next item.
#[derive(Debug)]
pub enum FeedError {
    /// The planner refused the command at `loc`.
    Plan(SourceLoc, PlanError),
    /// The command source failed (see [`CommandSource`]).
    Source(String),
}

impl PlanFeed {
    /// [`PlanFeed::next`] for a feed given all its commands (no source):
    /// only the planner can refuse.
    pub fn next_given(
        &mut self,
        dist: &mut Distributor,
    ) -> Result<Option<Sourced>, (SourceLoc, PlanError)> {
        match self.next(dist) {
            Ok(item) => Ok(item),
            Err(FeedError::Plan(loc, e)) => Err((loc, e)),
            // A feed without a source never reads.
            Err(FeedError::Source(_)) => Ok(None),
        }
    }
}

/// Commands fed to the planner as its output is taken; a command is let go
/// once the planner has it.
///
/// An open feed ([`PlanFeed::keep_open`]) takes more commands while it runs
/// ([`PlanFeed::push`]): when it has planned every command it has, it
/// gives nothing more (the planner keeps its lookahead) until more come or
/// it is closed ([`PlanFeed::close`]), which plans what is held to rest. A
/// feed with a source ([`PlanFeed::reading`]) takes each command from it
/// when the planner needs one, after those it was given.
pub struct PlanFeed {
    /// Commands not yet given to the planner; the first is `next_command`.
    commands: VecDeque<Located<Command>>,
    next_command: usize,
    source: Option<Box<dyn CommandSource>>,
    /// The job's length, when the commands come from a source.
    total: Option<usize>,
    planner: SourcedPlanner,
    finished: bool,
    exhausted: bool,
    open: bool,
    /// Slowdowns still to apply, each before its command is planned (a
    /// journaled run planned again).
    paces: VecDeque<(usize, f64)>,
    /// Holds still to plan, each right after its (waiting) command (a
    /// journaled run planned again).
    holds: VecDeque<JournalHold>,
}

impl PlanFeed {
    /// A trajectory from rest at `start` at host time `t0` (µs).
    pub fn new(limits: Limits, start: Point, t0: f64, commands: Vec<Located<Command>>) -> PlanFeed {
        PlanFeed {
            commands: commands.into(),
            next_command: 0,
            source: None,
            total: None,
            planner: SourcedPlanner::new(Planner::new(limits, start, t0)),
            finished: false,
            exhausted: false,
            open: false,
            paces: VecDeque::new(),
            holds: VecDeque::new(),
        }
    }

    /// Takes the commands after those it has from `source`, `total` in all
    /// (for progress), as the planner needs them.
    pub fn reading(mut self, source: Box<dyn CommandSource>, total: usize) -> PlanFeed {
        self.source = Some(source);
        self.total = Some(total);
        self
    }

    /// The slowdowns a run's journal recorded ([`PlanFeed::slow`]), applied
    /// again at the same commands.
    pub fn with_paces(mut self, paces: &[JournalPace]) -> PlanFeed {
        self.paces = paces.iter().map(|p| (p.command, p.min_move_s)).collect();
        self
    }

    /// The holds a run's journal recorded ([`PlanFeed::hold`]), planned
    /// again after the same commands.
    pub fn with_holds(mut self, holds: &[JournalHold]) -> PlanFeed {
        self.holds = holds.iter().copied().collect();
        self
    }

    /// Holds the trajectory at rest for `seconds` more after the last
    /// command given to the planner (a wait for a heater, which the
    /// planner has planned to rest): a dwell, planned now. Returns the
    /// record to journal.
    pub fn hold(&mut self, seconds: f64) -> Result<JournalHold, PlanError> {
        let command = self.next_command.saturating_sub(1);
        self.planner.push(command, &Command::Dwell { seconds })?;
        Ok(JournalHold { command, seconds })
    }

    /// Plans the commands not yet given to the planner with moves of at
    /// least `min_move_s` seconds (what is planned stays as planned).
    /// Returns the first command it applies to, for the journal.
    pub fn slow(&mut self, min_move_s: f64) -> usize {
        self.planner.set_min_move_s(min_move_s);
        self.next_command
    }

    /// The shortest move time the next commands are planned with, seconds.
    pub fn min_move_s(&self) -> f64 {
        self.planner.min_move_s()
    }

    /// Keeps the feed open for [`PlanFeed::push`] until [`PlanFeed::close`].
    pub fn keep_open(&mut self) {
        self.open = !self.finished;
    }

    /// Appends commands to an open feed; their indices follow the ones
    /// before. Returns false (and takes nothing) once the feed is closed.
    pub fn push(&mut self, commands: impl IntoIterator<Item = Located<Command>>) -> bool {
        if !self.open {
            return false;
        }
        self.commands.extend(commands);
        true
    }

    /// No more commands come: what the planner holds is planned to rest.
    pub fn close(&mut self) {
        self.open = false;
    }

    /// Open, with every command given to the planner: what it holds waits
    /// for more commands or the close.
    pub fn starved(&self) -> bool {
        self.open && self.commands.is_empty() && self.source.is_none()
    }

    /// The commands not yet given to the planner (of those read), to
    /// adjust before they are planned (an override changing their feed).
    pub fn pending_mut(&mut self) -> &mut [Located<Command>] {
        self.commands.make_contiguous()
    }

    /// Commands planned so far and in all.
    pub fn progress(&self) -> (usize, usize) {
        let known = self.next_command + self.commands.len();
        (
            self.next_command,
            self.total.map_or(known, |t| t.max(known)),
        )
    }

    /// Commands held (given, read, not yet planned).
    pub fn held(&self) -> usize {
        self.commands.len()
    }

    /// The planner has given everything.
    pub fn exhausted(&self) -> bool {
        self.exhausted
    }

    /// The next item, quantized by `dist` as the nodes will run it.
    pub fn next(&mut self, dist: &mut Distributor) -> Result<Option<Sourced>, FeedError> {
        loop {
            if let Some(mut s) = self.planner.pop() {
                // The nodes run the quantized trajectory: it is the record.
                s.item = dist.quantize(&s.item);
                return Ok(Some(s));
            }
            while let Some(&(from, s)) = self.paces.front() {
                if from > self.next_command {
                    break;
                }
                self.planner.set_min_move_s(s);
                self.paces.pop_front();
            }
            if let Some(c) = self.commands.pop_front() {
                self.planner
                    .push(self.next_command, &c.item)
                    .map_err(|e| FeedError::Plan(c.loc, e))?;
                while let Some(h) = self
                    .holds
                    .front()
                    .filter(|h| h.command == self.next_command)
                {
                    let dwell = Command::Dwell { seconds: h.seconds };
                    self.planner
                        .push(h.command, &dwell)
                        .map_err(|e| FeedError::Plan(c.loc, e))?;
                    self.holds.pop_front();
                }
                self.next_command += 1;
            } else if let Some(source) = self.source.as_mut() {
                match source.next_command() {
                    Some(Ok(c)) => self.commands.push_back(c),
                    Some(Err(message)) => {
                        self.source = None;
                        return Err(FeedError::Source(message));
                    }
                    None => self.source = None,
                }
            } else if self.open {
                return Ok(None);
            } else if !self.finished {
                self.planner.finish();
                self.finished = true;
            } else {
                self.exhausted = true;
                return Ok(None);
            }
        }
    }
}

/// A run's first `count` segments (fewer if the job has fewer), each with
/// its command, planned again from what its journal header records and
/// the slowdowns and holds it journaled.
pub fn replan(
    machine: &Machine,
    commands: Vec<Located<Command>>,
    header: &JournalHeader,
    (paces, holds): (&[JournalPace], &[JournalHold]),
    count: usize,
) -> Result<Vec<(usize, Segment)>, (SourceLoc, PlanError)> {
    let mut dist = Distributor::new(machine);
    // As a run does when it configures the nodes: the stream starts here.
    dist.stream_setup(machine, &header.start);
    let limits = run_limits(machine, header.min_move_s);
    let mut feed = PlanFeed::new(limits, header.start, header.t0, commands)
        .with_paces(paces)
        .with_holds(holds);
    let mut out = Vec::new();
    while out.len() < count {
        match feed.next_given(&mut dist)? {
            Some(Sourced {
                item: Planned::Segment(s),
                command,
            }) => out.push((command, s)),
            Some(_) => {}
            None => break,
        }
    }
    Ok(out)
}
