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
use motet_host::Machine;
use motet_net::{Phase, StopInfo};
use motet_planner::{Command, Located};
use motet_trajectory::Point;
use std::sync::Arc;

mod heaters;
mod history;
mod machine_edit;
mod manual;
mod queue;
mod state;
mod status;
mod stream;
pub use heaters::HeaterState;
pub use history::{JobOutcome, KEPT_HISTORY};
pub use queue::{QueueView, QueuedJob, MAX_QUEUED};
pub use state::{ActionError, Client, State};
pub use status::{JobProgress, Status};
pub use stream::{StreamStatus, STREAM_BLOCKS};

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
    queue: queue::Queue,
    /// Counts changes to what a server keeps across restarts (the queue,
    /// the history), so it saves only when something changed.
    saved_version: u64,
    /// The graph file that drives the machine by hand, if one does.
    hand_driven: Option<String>,
    heaters: heaters::Heaters,
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
            heaters: heaters::Heaters::of(&machine),
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
            queue: queue::Queue::default(),
            saved_version: 0,
            hand_driven: None,
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

    /// Counts changes to what a server keeps across restarts.
    pub fn saved_version(&self) -> u64 {
        self.saved_version
    }

    fn changed(&mut self) {
        self.saved_version += 1;
    }

    /// Something kept across restarts changed outside the session (a job
    /// stored while the session is locked): the server writes it out soon.
    pub fn mark_changed(&mut self) {
        self.changed();
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
                self.heaters_tick(false);
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
                self.heaters_tick(true);
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
                let job_finished = matches!(self.activity, Activity::Job(_));
                self.end_activity("finished");
                self.events.push(self.now, Level::Info, what);
                self.state = State::Idle;
                self.stopping = None;
                if job_finished {
                    self.queue_advance();
                }
            }
            Phase::Stopped(info) => self.stopped(info),
            _ => {}
        }
    }

    fn stopped(&mut self, info: StopInfo) {
        self.rest = info.point;
        self.heaters_run_stopped();
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

    /// A graph drives the machine from now on (`motet serve --graph`): jobs,
    /// jogs and tool changes are refused.
    pub fn hand_driven(&mut self, graph: &str) {
        self.hand_driven = Some(graph.to_string());
        self.events.push(
            self.now,
            Level::Info,
            format!("driven by hand through the graph {graph}"),
        );
    }

    fn ready(&self, action: &'static str) -> Result<(), ActionError> {
        if let Some(graph) = &self.hand_driven {
            return Err(ActionError::HandDriven {
                action,
                graph: graph.clone(),
            });
        }
        match self.state {
            State::Idle | State::Stopped => Ok(()),
            state => Err(ActionError::WrongState { action, state }),
        }
    }

    fn begin(&mut self, commands: Vec<Located<Command>>, activity: Activity, client: Client) {
        self.heaters_track_run(&commands);
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
        self.heaters_off();
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
        self.heaters_run_stopped();
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
}
