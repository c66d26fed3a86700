//! One machine owned by a server: what it is doing (its [`State`]), the job
//! it runs, and the actions a person or a program takes on it. Driven by
//! [`Session::tick`] on the server's clock; every action is checked against
//! the state first, so an action in the wrong state changes nothing.
//!
//! Every motion is one run on the nodes ([`crate::engine::Nodes`]): a job, the
//! rest of a job after a hold, a jog, a tool change. A hold, a cancel and an
//! emergency stop all stop sealing: every node brakes on its contingency
//! tail and comes to rest on the path, and the session learns where. A held
//! job continues from there with the commands it had not finished
//! ([`motet_net::resume::resume_at`], as `motet resume` does).

use crate::engine::Nodes;
use crate::events::{EventLog, Level};
use crate::jobs::StoredJob;
use motet_host::{clamp_move, Machine, MoveError};
use motet_net::{Phase, StopInfo};
use motet_planner::{ranges, Command, Located, Move, MoveKind, SourceLoc};
use motet_trajectory::Point;
use serde::Serialize;
use std::sync::Arc;

mod machine_edit;
mod stream;
pub use stream::{StreamStatus, STREAM_BLOCKS};

/// What the machine is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum State {
    /// At rest, ready.
    Idle,
    /// Moving: a job, a jog or a tool change.
    Running,
    /// A feed hold: braking on the path.
    Holding,
    /// A held job at rest on its path; it can resume or be cancelled.
    Paused,
    /// A cancel or an emergency stop: braking on the path.
    Stopping,
    /// Stopped by an emergency stop, at rest; ready for a new action.
    Stopped,
    /// Something went wrong (a node lost, a run that could not start):
    /// where the machine is may not be known. Cleared by [`Session::unlock`].
    Alarm,
}

impl std::fmt::Display for State {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            State::Idle => "idle",
            State::Running => "running",
            State::Holding => "holding",
            State::Paused => "paused",
            State::Stopping => "stopping",
            State::Stopped => "stopped",
            State::Alarm => "in alarm",
        })
    }
}

/// Why an action was refused. Nothing changed.
#[derive(Debug, thiserror::Error)]
pub enum ActionError {
    /// The action does not fit what the machine is doing.
    #[error("cannot {action} while the machine is {state}")]
    WrongState {
        /// The action asked for.
        action: &'static str,
        /// What the machine is doing.
        state: State,
    },
    /// Another client has control; take it first.
    #[error("another client controls the machine: take control first")]
    NotController,
    /// An axis the machine does not have.
    #[error("no axis `{name}` (the machine's axes: {axes})")]
    UnknownAxis {
        /// The name asked for.
        name: String,
        /// The machine's axes.
        axes: String,
    },
    /// A tool the machine does not have.
    #[error("no tool `{name}` (the machine's tools: {tools})")]
    UnknownTool {
        /// The name asked for.
        name: String,
        /// The machine's tools.
        tools: String,
    },
    /// A value out of its range (a feed, a tool value, a coordinate).
    #[error("{what} = {value} is out of range ({range})")]
    OutOfRange {
        /// Which value.
        what: &'static str,
        /// The value given.
        value: f64,
        /// What it may be.
        range: String,
    },
    /// The target is beyond the machine's travel or reach.
    #[error("{0}")]
    Unreachable(#[from] MoveError),
    /// No job with this id.
    #[error("no job {0}")]
    UnknownJob(u64),
    /// No node of this name.
    #[error("no node `{name}` (the machine's nodes: {nodes})")]
    UnknownNode {
        /// The name asked for.
        name: String,
        /// The machine's nodes.
        nodes: String,
    },
}

/// Who asks: a client id (any string the client chose) for control.
pub type Client<'a> = Option<&'a str>;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stopping {
    Hold,
    Cancel,
    EStop,
}

/// A job on the machine, and how the current run's commands map onto it.
struct JobRun {
    job: Arc<StoredJob>,
    /// The run's command `prelude + i` is the job's command `base + i`; the
    /// run's first `prelude` commands (travel back, tools restored) are not
    /// the job's.
    base: usize,
    prelude: usize,
    /// Where a held job continues (its command), once at rest.
    held_at: Option<usize>,
    /// When it started, µs (server time).
    started_us: u64,
    /// The job command the run ends after: the job's end, or a pause for
    /// the person (M0, a pen change), where the job waits at rest for
    /// resume.
    end: usize,
}

/// The end of the part of `commands` that starts at `from`: just after the
/// first pause for the person (M0, a pen change; optional stops are run
/// through), or the end.
fn part_end(commands: &[Located<Command>], from: usize) -> usize {
    commands
        .iter()
        .enumerate()
        .skip(from)
        .find(|(_, c)| matches!(c.item, Command::Pause { optional: false }))
        .map_or(commands.len(), |(i, _)| i + 1)
}

/// What the current run is.
enum Activity {
    None,
    Job(JobRun),
    /// Commands streamed a line at a time ([`stream`]).
    Stream,
    Other(&'static str),
}

/// The job on the machine, for the person.
#[derive(Clone, Debug, Serialize)]
pub struct JobProgress {
    /// The job's id.
    pub id: u64,
    /// Its file name, as uploaded.
    pub name: String,
    /// Fraction of its commands done, 0..=1.
    pub progress: f64,
    /// Planned time left, seconds.
    pub left_s: f64,
}

/// Everything a screen shows of the machine, at one moment.
#[derive(Clone, Debug, Serialize)]
pub struct Status {
    /// Server time, µs since it started: the trajectory's clock.
    pub t_us: u64,
    /// What the machine is doing.
    pub state: State,
    /// The nodes' links are being set up and their clocks measured (a few
    /// seconds after the server starts): motion asked for waits.
    pub connecting: bool,
    /// Where the tool is, axis by axis, in the machine's axis order.
    pub position: Vec<f64>,
    /// Path speed, units/s.
    pub speed: f64,
    /// The job on the machine, if any.
    pub job: Option<JobProgress>,
    /// Why the machine stopped or is in alarm.
    pub reason: Option<String>,
    /// The client in control, if any.
    pub controller: Option<String>,
    /// Sequence number of the newest event.
    pub event_seq: u64,
}

/// Jobs kept in the history.
pub const KEPT_HISTORY: usize = 100;

/// How a job ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JobOutcome {
    /// The job's id.
    pub id: u64,
    /// Its file name.
    pub name: String,
    /// When it started, µs (server time).
    pub started_us: u64,
    /// When it ended.
    pub ended_us: u64,
    /// `finished`, `cancelled`, `emergency stop`, or the alarm's reason.
    pub outcome: String,
}

/// The machine a server owns (see the module documentation).
pub struct Session {
    machine: Arc<Machine>,
    nodes: Box<dyn Nodes>,
    state: State,
    activity: Activity,
    stopping: Option<Stopping>,
    /// Where the machine rests while no run moves it.
    rest: Point,
    reason: Option<String>,
    controller: Option<String>,
    now: u64,
    stream: stream::Stream,
    /// What happened, newest last, bounded.
    pub events: EventLog,
    history: std::collections::VecDeque<JobOutcome>,
}

impl Session {
    /// The machine at rest at its start position on `nodes`.
    pub fn new(machine: Arc<Machine>, nodes: Box<dyn Nodes>) -> Session {
        let rest = machine.start;
        let mut events = EventLog::default();
        events.push(
            0,
            Level::Info,
            format!("machine {} on {} nodes", machine.name, nodes.kind()),
        );
        Session {
            machine,
            nodes,
            state: State::Idle,
            activity: Activity::None,
            stopping: None,
            rest,
            reason: None,
            controller: None,
            now: 0,
            stream: stream::Stream::default(),
            events,
            history: std::collections::VecDeque::new(),
        }
    }

    /// The machine.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The nodes.
    pub fn nodes(&self) -> &dyn Nodes {
        self.nodes.as_ref()
    }

    /// What the machine is doing.
    pub fn state(&self) -> State {
        self.state
    }

    /// The nodes' links are being set up and their clocks measured.
    pub fn status_connecting(&self) -> bool {
        matches!(self.nodes.run().phase(), Phase::Starting)
    }

    /// The job on the machine (running, held or paused), if any.
    pub fn job_id(&self) -> Option<u64> {
        match &self.activity {
            Activity::Job(j) => Some(j.job.id),
            _ => None,
        }
    }

    /// Polls the nodes at `now` (µs since the server started, never going
    /// back) and follows the run; returns when to tick again at the latest.
    pub fn tick(&mut self, now: u64) -> u64 {
        self.now = self.now.max(now);
        match self.nodes.advance(self.now) {
            Ok(next) => {
                self.follow();
                self.stream_tick();
                next
            }
            Err(e) => {
                // A run that cannot go on says so once, not at every tick.
                let reason = format!("run: {e}");
                if self.state != State::Alarm || self.reason.as_deref() != Some(&reason) {
                    self.alarm(reason);
                }
                self.now + 50_000
            }
        }
    }

    fn follow(&mut self) {
        let moving = matches!(
            self.state,
            State::Running | State::Holding | State::Stopping
        );
        if !moving {
            return;
        }
        match self.nodes.run().phase().clone() {
            Phase::Done => {
                if let Some(p) = self.nodes.run().position_at(f64::INFINITY) {
                    self.rest = p;
                }
                if let Activity::Job(j) = &mut self.activity {
                    if j.end < j.job.commands.len() {
                        // A pause in the job: it waits, at rest, for resume.
                        let line = j.job.commands[j.end - 1].loc.line;
                        j.held_at = Some(j.end);
                        self.state = State::Paused;
                        self.events.push(
                            self.now,
                            Level::Warn,
                            format!(
                                "the job pauses (line {line}): change the tool or pen, then resume"
                            ),
                        );
                        return;
                    }
                }
                let what = match &self.activity {
                    Activity::Job(j) => format!("job {} ({}) finished", j.job.id, j.job.name),
                    Activity::Other(what) => format!("{what} finished"),
                    Activity::Stream => {
                        self.stream_run_done();
                        "streamed commands run, at rest".into()
                    }
                    Activity::None => "run finished".into(),
                };
                self.end_activity("finished");
                self.events.push(self.now, Level::Info, what);
                self.state = State::Idle;
                self.stopping = None;
            }
            Phase::Stopped(info) => self.stopped(info),
            _ => {}
        }
    }

    fn stopped(&mut self, info: StopInfo) {
        self.rest = info.point;
        let stopping = self.stopping.take();
        if !info.all_at_rest() {
            self.end_activity("lost: the machine may have moved");
            return self.alarm(info.reason.clone());
        }
        match stopping {
            Some(Stopping::Hold) => {
                if let Activity::Job(j) = &mut self.activity {
                    let done = info.next_command.saturating_sub(j.prelude);
                    j.held_at = Some((j.base + done).min(j.job.commands.len()));
                }
                if let Activity::Stream = self.activity {
                    self.stream_held(info.next_command);
                }
                self.state = State::Paused;
                self.events
                    .push(self.now, Level::Info, "held at rest on the path".into());
            }
            Some(Stopping::Cancel) => {
                self.end_activity("cancelled");
                self.state = State::Idle;
                self.events.push(
                    self.now,
                    Level::Info,
                    "cancelled, at rest on the path".into(),
                );
            }
            Some(Stopping::EStop) => {
                self.end_activity("emergency stop");
                self.state = State::Stopped;
                self.reason = Some("emergency stop".into());
                self.events.push(
                    self.now,
                    Level::Warn,
                    "emergency stop: every node at rest on the path".into(),
                );
            }
            None => {
                self.end_activity("stopped by the run");
                self.alarm(info.reason);
            }
        }
    }

    /// The current run's activity is over; a job's outcome goes into the
    /// history.
    fn end_activity(&mut self, outcome: &str) {
        if let Activity::Job(j) = std::mem::replace(&mut self.activity, Activity::None) {
            if self.history.len() == KEPT_HISTORY {
                self.history.pop_front();
            }
            self.history.push_back(JobOutcome {
                id: j.job.id,
                name: j.job.name.clone(),
                started_us: j.started_us,
                ended_us: self.now,
                outcome: outcome.to_string(),
            });
        }
    }

    /// The jobs that ended, oldest first (the newest [`KEPT_HISTORY`]).
    pub fn history(&self) -> impl Iterator<Item = &JobOutcome> {
        self.history.iter()
    }

    fn alarm(&mut self, reason: String) {
        self.end_activity(&format!("alarm: {reason}"));
        self.events
            .push(self.now, Level::Error, format!("alarm: {reason}"));
        self.reason = Some(reason);
        self.state = State::Alarm;
        self.stopping = None;
    }

    /// Checks that `client` may move the machine: anyone while nobody
    /// controls it or nothing runs; only the controller while a job is on
    /// the machine.
    fn may_drive(&self, client: Client) -> Result<(), ActionError> {
        let busy = !matches!(self.state, State::Idle | State::Stopped | State::Alarm);
        match (&self.controller, client) {
            (Some(c), Some(me)) if busy && c != me => Err(ActionError::NotController),
            (Some(_), None) if busy => Err(ActionError::NotController),
            _ => Ok(()),
        }
    }

    fn ready(&self, action: &'static str) -> Result<(), ActionError> {
        match self.state {
            State::Idle | State::Stopped => Ok(()),
            state => Err(ActionError::WrongState { action, state }),
        }
    }

    fn begin(&mut self, commands: Vec<Located<Command>>, activity: Activity, client: Client) {
        self.nodes.begin(&self.machine, commands, self.rest);
        self.activity = activity;
        self.state = State::Running;
        self.stopping = None;
        self.reason = None;
        if let Some(c) = client {
            self.controller = Some(c.to_string());
        }
        // The run starts connecting now, not at the next tick.
        self.tick(self.now);
    }

    /// Starts a job at rest. Its first move is checked from where the
    /// machine is.
    pub fn start(&mut self, job: Arc<StoredJob>, client: Client) -> Result<(), ActionError> {
        self.ready("start a job")?;
        self.may_drive(client)?;
        if let Some(first) = job.commands.iter().find_map(|c| match c.item {
            Command::Move(m) => Some(m.target),
            _ => None,
        }) {
            motet_host::check_move(&self.machine, &self.rest, &first)?;
        }
        self.events.push(
            self.now,
            Level::Info,
            format!("job {} ({}) started", job.id, job.name),
        );
        let end = part_end(&job.commands, 0);
        let commands = job.commands[..end].to_vec();
        let run = JobRun {
            job,
            base: 0,
            prelude: 0,
            held_at: None,
            end,
            started_us: self.now,
        };
        self.begin(commands, Activity::Job(run), client);
        Ok(())
    }

    /// Feed hold: the machine brakes on its path and rests there.
    pub fn pause(&mut self, client: Client) -> Result<(), ActionError> {
        self.may_drive(client)?;
        match (&self.state, &self.activity) {
            (State::Running, Activity::Job(_)) => {
                if self.stop(Stopping::Hold, "feed hold") {
                    self.state = State::Holding;
                }
                Ok(())
            }
            (State::Running, Activity::Stream) | (State::Idle, Activity::None)
                if self.streaming() =>
            {
                self.stream_hold()
            }
            (state, _) => Err(ActionError::WrongState {
                action: "pause",
                state: *state,
            }),
        }
    }

    /// Continues a held job from where it rests.
    pub fn resume(&mut self, client: Client) -> Result<(), ActionError> {
        self.may_drive(client)?;
        let state = self.state;
        if let Activity::Stream = self.activity {
            return self.stream_resume();
        }
        let Activity::Job(j) = &self.activity else {
            return Err(ActionError::WrongState {
                action: "resume",
                state,
            });
        };
        let (Some(at), State::Paused) = (j.held_at, state) else {
            return Err(ActionError::WrongState {
                action: "resume",
                state,
            });
        };
        let mut res = motet_net::resume::resume_at(&j.job.commands, self.rest, self.rest, at);
        let prelude = res.commands.len() - (j.job.commands.len() - res.command);
        // Up to the next pause in the job.
        let end = part_end(&j.job.commands, res.command);
        res.commands.truncate(prelude + (end - res.command));
        let run = JobRun {
            job: j.job.clone(),
            base: res.command,
            prelude,
            held_at: None,
            end,
            started_us: j.started_us,
        };
        self.events.push(self.now, Level::Info, "resumed".into());
        self.begin(res.commands, Activity::Job(run), client);
        Ok(())
    }

    /// Cancels the job (or jog): the machine brakes on its path and rests.
    pub fn cancel(&mut self, client: Client) -> Result<(), ActionError> {
        self.may_drive(client)?;
        // Streamed commands not yet run go with what runs.
        if matches!(self.state, State::Running | State::Holding) {
            self.stream_clear();
        }
        match self.state {
            State::Running | State::Holding => {
                if self.stop(Stopping::Cancel, "cancel") {
                    self.state = State::Stopping;
                }
                Ok(())
            }
            State::Paused => {
                self.stream_clear();
                self.end_activity("cancelled");
                self.state = State::Idle;
                self.events.push(self.now, Level::Info, "cancelled".into());
                Ok(())
            }
            state => Err(ActionError::WrongState {
                action: "cancel",
                state,
            }),
        }
    }

    /// Emergency stop, from any client: every node brakes on the tail it
    /// already holds (nothing more is sealed) and rests on the path.
    pub fn estop(&mut self) {
        self.events
            .push(self.now, Level::Warn, "emergency stop requested".into());
        self.stream_clear();
        match self.state {
            State::Running | State::Holding | State::Stopping => {
                if self.stop(Stopping::EStop, "emergency stop") {
                    self.state = State::Stopping;
                }
            }
            State::Paused | State::Idle => {
                self.end_activity("emergency stop");
                self.state = State::Stopped;
                self.reason = Some("emergency stop".into());
            }
            State::Stopped | State::Alarm => {}
        }
    }

    /// Stops the run: `true` if the machine brakes on its path (the caller
    /// says so in the state); `false` if the run had not started moving
    /// (its nodes still connecting), so the session settles at once where
    /// it was.
    fn stop(&mut self, how: Stopping, reason: &str) -> bool {
        if matches!(self.nodes.run().phase(), Phase::Starting) {
            self.settle_unmoved(how, reason);
            return false;
        }
        // An emergency stop overrides a hold or a cancel under way.
        if self.stopping != Some(Stopping::EStop) {
            self.stopping = Some(how);
        }
        let run = self.nodes.run_mut();
        run.stop(reason, self.now);
        if let Phase::Stopping(info) = run.phase() {
            let ms = (info.braking_at - self.now as f64) * 1e-3;
            self.events.push(
                self.now,
                Level::Info,
                format!(
                    "{reason}: braking {ms:.0} ms after the request, on the trajectory's clock"
                ),
            );
        }
        true
    }

    /// A stop before anything moved: the run is dropped for an empty one
    /// on the same links, and the job (if held) continues from where it
    /// would have started.
    fn settle_unmoved(&mut self, how: Stopping, reason: &str) {
        self.nodes.begin(&self.machine, Vec::new(), self.rest);
        self.stopping = None;
        self.events.push(
            self.now,
            Level::Info,
            format!("{reason} before anything moved"),
        );
        match how {
            Stopping::Hold => {
                if let Activity::Job(j) = &mut self.activity {
                    j.held_at = Some(j.base);
                }
                if let Activity::Stream = self.activity {
                    self.stream_held(0);
                }
                self.state = State::Paused;
            }
            Stopping::Cancel => {
                self.end_activity("cancelled");
                self.state = State::Idle;
            }
            Stopping::EStop => {
                self.end_activity("emergency stop");
                self.state = State::Stopped;
                self.reason = Some("emergency stop".into());
            }
        }
    }

    /// Clears an alarm: the person says the machine is where the session
    /// last knew it to be.
    pub fn unlock(&mut self) -> Result<(), ActionError> {
        match self.state {
            State::Alarm | State::Stopped => {
                self.state = State::Idle;
                self.reason = None;
                self.events.push(self.now, Level::Info, "unlocked".into());
                Ok(())
            }
            state => Err(ActionError::WrongState {
                action: "unlock",
                state,
            }),
        }
    }

    /// Takes control for `client`.
    pub fn take_control(&mut self, client: &str) {
        self.controller = Some(client.to_string());
        self.events.push(
            self.now,
            Level::Info,
            format!("client {client} took control"),
        );
    }

    /// Moves the named axes by the given amounts (`relative`) or to them,
    /// at `feed` units/s (the machine's drawing feed if none).
    pub fn jog(
        &mut self,
        axes: &[(String, f64)],
        relative: bool,
        feed: Option<f64>,
        client: Client,
    ) -> Result<(), ActionError> {
        self.ready("jog")?;
        self.may_drive(client)?;
        let feed = feed.unwrap_or(self.machine.draw_feed);
        if !(feed > 0.0 && feed.is_finite()) {
            return Err(ActionError::OutOfRange {
                what: "feed",
                value: feed,
                range: "> 0 units/s".into(),
            });
        }
        let mut to = self.rest;
        for (name, v) in axes {
            let i = self.axis(name)?;
            if !v.is_finite() {
                return Err(ActionError::OutOfRange {
                    what: "coordinate",
                    value: *v,
                    range: "a finite number".into(),
                });
            }
            to[i] = if relative { to[i] + v } else { *v };
        }
        clamp_move(&self.machine, &self.rest, &mut to)?;
        let cmd = Command::Move(Move {
            target: to,
            feed,
            kind: MoveKind::Feed,
        });
        self.begin(vec![here(cmd)], Activity::Other("jog"), client);
        Ok(())
    }

    /// Says the machine is at these coordinates (the others stay): no
    /// motion; the nodes take the new position with the next run.
    pub fn set_position(
        &mut self,
        axes: &[(String, f64)],
        client: Client,
    ) -> Result<(), ActionError> {
        self.ready("set the position")?;
        self.may_drive(client)?;
        let mut to = self.rest;
        for (name, v) in axes {
            to[self.axis(name)?] = *v;
        }
        motet_host::check_move(&self.machine, &to, &to)?;
        self.rest = to;
        self.events
            .push(self.now, Level::Info, "position set".into());
        Ok(())
    }

    /// Sets a tool output (pen 1 down / 0 up, laser or spindle power 0..=1).
    pub fn set_tool(&mut self, tool: &str, value: f64, client: Client) -> Result<(), ActionError> {
        self.ready("change a tool")?;
        self.may_drive(client)?;
        let index = self
            .machine
            .tools
            .iter()
            .position(|t| t.name == tool)
            .ok_or_else(|| ActionError::UnknownTool {
                name: tool.to_string(),
                tools: names(self.machine.tools.iter().map(|t| &t.name)),
            })?;
        if !ranges::TOOL_VALUE.contains(value) {
            return Err(ActionError::OutOfRange {
                what: "tool value",
                value,
                range: "0..=1".into(),
            });
        }
        let cmd = Command::Tool {
            tool: index as u8,
            value: value as f32,
        };
        self.begin(vec![here(cmd)], Activity::Other("tool change"), client);
        Ok(())
    }

    fn axis(&self, name: &str) -> Result<usize, ActionError> {
        self.machine
            .axis(&name.to_ascii_lowercase())
            .ok_or_else(|| ActionError::UnknownAxis {
                name: name.to_string(),
                axes: names(self.machine.axes.iter().map(|a| &a.name)),
            })
    }

    /// Lights node `name`'s identify LED for `seconds` (any client, any
    /// state: it moves nothing).
    pub fn identify(&mut self, name: &str, seconds: f64) -> Result<(), ActionError> {
        let k = self
            .machine
            .nodes
            .iter()
            .position(|n| n.name == name)
            .ok_or_else(|| ActionError::UnknownNode {
                name: name.to_string(),
                nodes: names(self.machine.nodes.iter().map(|n| &n.name)),
            })?;
        if !(0.0..=60.0).contains(&seconds) {
            return Err(ActionError::OutOfRange {
                what: "seconds",
                value: seconds,
                range: "0..=60".into(),
            });
        }
        let ms = (seconds * 1e3).round() as u32;
        if let Some(p) = self.nodes.run_mut().peer_mut(k) {
            p.send_service(&motet_wire::service::ServiceRequest::Identify { ms });
        }
        self.events.push(
            self.now,
            Level::Info,
            format!("identify node {name} for {seconds} s"),
        );
        Ok(())
    }

    /// Where the tool is now.
    pub fn position(&self) -> Point {
        self.position_at(self.now as f64)
    }

    fn position_at(&self, t: f64) -> Point {
        match self.state {
            State::Running | State::Holding | State::Stopping => {
                self.nodes.run().position_at(t).unwrap_or(self.rest)
            }
            _ => self.rest,
        }
    }

    /// The machine as a screen shows it now.
    pub fn status(&self) -> Status {
        let n = self.machine.axes.len();
        let now = self.now as f64;
        let p = self.position_at(now);
        let dt = 10_000.0;
        let before = self.position_at(now - dt);
        let speed = self
            .machine
            .axes
            .iter()
            .enumerate()
            .filter(|(_, a)| a.path)
            .map(|(i, _)| (p[i] - before[i]).powi(2))
            .sum::<f64>()
            .sqrt()
            / (dt * 1e-6);
        Status {
            t_us: self.now,
            state: self.state,
            connecting: self.status_connecting(),
            position: p[..n].to_vec(),
            speed,
            job: self.job_progress(),
            reason: self.reason.clone(),
            controller: self.controller.clone(),
            event_seq: self.events.last_seq(),
        }
    }

    fn job_progress(&self) -> Option<JobProgress> {
        let Activity::Job(j) = &self.activity else {
            return None;
        };
        let total = j.job.commands.len().max(1);
        let done = match (self.state, j.held_at) {
            (_, Some(at)) => at,
            (State::Running | State::Holding | State::Stopping, None) => {
                let run = self.nodes.run();
                match run.command_at(self.now as f64) {
                    Some(c) => j.base + c.saturating_sub(j.prelude),
                    None => j.base,
                }
            }
            _ => j.base,
        };
        let progress = (done as f64 / total as f64).clamp(0.0, 1.0);
        Some(JobProgress {
            id: j.job.id,
            name: j.job.name.clone(),
            progress,
            left_s: j.job.planned_s * (1.0 - progress),
        })
    }
}

fn here(item: Command) -> Located<Command> {
    Located {
        loc: SourceLoc { line: 0, column: 0 },
        item,
    }
}

fn names<'a>(it: impl Iterator<Item = &'a String>) -> String {
    it.map(String::as_str).collect::<Vec<_>>().join(", ")
}
