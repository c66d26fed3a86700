//! The scriptable machine.

use crate::drawing::{Drawing, DrawingError};
use motet_host::{check_move, clamp_move, Clamps, MachineError};
use motet_planner::ranges::{self, number};
use motet_planner::{Command, Move, MoveKind, PlanError, Planned, Planner};
use motet_render::RenderSpec;
use motet_sim::{Held, Report, SimError, SimMachine};
use motet_trajectory::Point;
use std::path::Path;
use std::time::Instant;

/// Why a call was refused. Nothing queued before the call is affected.
#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    /// The machine file could not be read or is invalid.
    #[error(transparent)]
    Machine(#[from] MachineError),
    /// A call named an axis the machine does not have.
    #[error("unknown axis `{name}`; this machine's axes are {axes}")]
    UnknownAxis {
        /// The name given.
        name: String,
        /// The machine's axis names, comma-separated.
        axes: String,
    },
    /// A call named a tool the machine does not have.
    #[error("unknown tool `{name}`; this machine's tools are {tools}")]
    UnknownTool {
        /// The name given.
        name: String,
        /// The machine's tool names, comma-separated.
        tools: String,
    },
    /// The move would leave the travel or the kinematics' reach.
    #[error("{0}")]
    Unreachable(motet_host::MoveError),
    /// A feed outside [`ranges::VELOCITY`].
    #[error("feed must be {}, got {}", ranges::VELOCITY, number(*.0))]
    BadFeed(f64),
    /// A dwell outside [`ranges::DWELL_S`].
    #[error("dwell must be {}, got {}", ranges::DWELL_S, number(*.0))]
    BadDwell(f64),
    /// A tool value outside [`ranges::TOOL_VALUE`].
    #[error("tool value must be {}, got {}", ranges::TOOL_VALUE, number(f64::from(*.0)))]
    BadToolValue(f32),
    /// The planner refused the call's command.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The simulated machine refused what was streamed to it.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// [`Machine::save`] could not create the folder or write a file in it,
    /// or opening the machine could not make the temporary file its SVG is
    /// written to as it runs.
    #[error("cannot write {path}: {error}")]
    Io {
        /// The folder being saved into, or the temporary folder.
        path: String,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// [`Machine::save`] into a folder whose parent does not exist (only the
    /// folder itself is created).
    #[error("cannot save into {dir}: the directory {parent} does not exist")]
    NoParent {
        /// The folder asked for.
        dir: String,
        /// Its missing ancestor nearest the root.
        parent: String,
    },
    /// The executed path could not be drawn.
    #[error("render failed: {0}")]
    Render(String),
    /// A job file given to the machine could not be read or does not fit it.
    #[error(transparent)]
    Job(#[from] crate::job::JobError),
    /// The check given to [`Machine::on_interrupt`] asked to stop.
    #[error("interrupted; everything accepted before stays queued and `wait` runs it")]
    Interrupted,
}

/// Something the machine did, with the simulated time in seconds.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A tool output changed (pen lifted, laser power set).
    Tool {
        /// Simulated time of the change, seconds since the machine opened.
        time: f64,
        /// The tool's name in the machine file.
        tool: String,
        /// Its new value (0 off, 1 full on for a pen or a laser).
        value: f32,
    },
    /// The machine came to rest after [`Machine::wait`].
    Idle {
        /// Simulated time it came to rest, seconds since the machine opened.
        time: f64,
    },
}

// `Send`, so that a machine can be handed to another thread (the Python
// bindings let it work while the interpreter runs other threads).
type Listener = Box<dyn FnMut(&Event) + Send>;
type Interrupt = Box<dyn FnMut() -> bool + Send>;

/// A machine you drive call by call.
pub struct Machine {
    sim: SimMachine,
    planner: Planner,
    /// Where the machine will be after every accepted call.
    target: Point,
    /// Feed used when a call gives none, units/s.
    default_feed: f64,
    listeners: Vec<Listener>,
    interrupt: Option<Interrupt>,
    /// Nothing was accepted since the last `wait` that finished.
    idle: bool,
    calls: usize,
    /// Trajectory end time of everything planned so far, µs.
    end: f64,
    started: Instant,
    /// The executed path, drawn as it runs.
    drawing: Drawing,
    /// Targets within half a step beyond travel, clamped onto it.
    clamps: Clamps,
}

impl Machine {
    /// Opens the machine described by a machine file, at rest at its start
    /// position, on simulated nodes.
    pub fn open(path: impl AsRef<Path>) -> Result<Machine, ApiError> {
        let m = motet_host::Machine::load(path.as_ref())?;
        Machine::new(m)
    }

    /// A machine from an already validated description.
    pub fn new(machine: motet_host::Machine) -> Result<Machine, ApiError> {
        let drawing = Drawing::new(&render_spec(&machine)).map_err(|e| match e {
            DrawingError::Io(error) => ApiError::Io {
                path: std::env::temp_dir().display().to_string(),
                error,
            },
            DrawingError::Render(e) => ApiError::Render(e.to_string()),
        })?;
        let mut sim = SimMachine::new(&machine)?;
        sim.watch_tools(true);
        let planner = Planner::new(machine.limits(), machine.start, 0.0);
        Ok(Machine {
            target: machine.start,
            default_feed: machine.draw_feed,
            sim,
            planner,
            listeners: Vec::new(),
            interrupt: None,
            idle: true,
            calls: 0,
            end: 0.0,
            started: Instant::now(),
            drawing,
            clamps: Clamps::default(),
        })
    }

    fn description(&self) -> &motet_host::Machine {
        self.sim.machine()
    }

    /// The machine's axis names, in order.
    pub fn axes(&self) -> Vec<String> {
        self.description()
            .axes
            .iter()
            .map(|a| a.name.clone())
            .collect()
    }

    /// The machine's tool names.
    pub fn tools(&self) -> Vec<String> {
        self.description()
            .tools
            .iter()
            .map(|t| t.name.clone())
            .collect()
    }

    /// Calls `f` for every [`Event`] from now on.
    pub fn on_event(&mut self, f: impl FnMut(&Event) + Send + 'static) {
        self.listeners.push(Box::new(f));
    }

    /// Asks `f`, between planned items, whether to stop a call that lets
    /// time pass (a move waiting for queue room, `run_job`, `wait`); `true`
    /// ends the call with [`ApiError::Interrupted`]. Nothing accepted is lost
    /// or run twice: the call's own command stays queued (a job's commands
    /// up to the interruption), `target` says where the queued motion ends
    /// and the next call or `wait` carries on from there. `f` is asked often;
    /// it should be cheap.
    pub fn on_interrupt(&mut self, f: impl FnMut() -> bool + Send + 'static) {
        self.interrupt = Some(Box::new(f));
    }

    /// Whether everything accepted has run: no call was accepted since the
    /// last [`Machine::wait`] that finished.
    pub fn is_idle(&self) -> bool {
        self.idle
    }

    /// Moves the named axes to absolute positions (others stay) at `feed`
    /// units/s along the path, or at the machine's drawing feed.
    pub fn move_to(&mut self, target: &[(&str, f64)], feed: Option<f64>) -> Result<(), ApiError> {
        let to = self.resolve(target, false)?;
        self.queue_move(to, feed.unwrap_or(self.default_feed), MoveKind::Feed)
    }

    /// Moves the named axes to absolute positions as fast as the limits allow.
    pub fn rapid_to(&mut self, target: &[(&str, f64)]) -> Result<(), ApiError> {
        let to = self.resolve(target, false)?;
        self.queue_move(to, f64::INFINITY, MoveKind::Rapid)
    }

    /// Moves the named axes by the given amounts.
    pub fn jog(&mut self, delta: &[(&str, f64)], feed: Option<f64>) -> Result<(), ApiError> {
        let to = self.resolve(delta, true)?;
        self.queue_move(to, feed.unwrap_or(self.default_feed), MoveKind::Feed)
    }

    /// Sets a tool output: pen 1 down / 0 up, laser or spindle power 0..=1.
    pub fn set_tool(&mut self, tool: &str, value: f32) -> Result<(), ApiError> {
        if !ranges::TOOL_VALUE.contains(f64::from(value)) {
            return Err(ApiError::BadToolValue(value));
        }
        let index = self
            .description()
            .tools
            .iter()
            .position(|t| t.name == tool)
            .ok_or_else(|| ApiError::UnknownTool {
                name: tool.to_string(),
                tools: self.tools().join(", "),
            })?;
        self.push(Command::Tool {
            tool: index as u8,
            value,
        })
    }

    /// Stands still for `seconds` after the motion queued before it.
    pub fn dwell(&mut self, seconds: f64) -> Result<(), ApiError> {
        if !ranges::DWELL_S.contains(seconds) {
            return Err(ApiError::BadDwell(seconds));
        }
        self.push(Command::Dwell { seconds })
    }

    /// Reads a job file (G-code, SVG, photo), checks it against the machine and
    /// queues all of it; returns the number of commands. On error nothing of
    /// the job is queued.
    pub fn run_job(
        &mut self,
        path: impl AsRef<Path>,
        allow_unknown: bool,
    ) -> Result<usize, ApiError> {
        let path = path.as_ref();
        let job = crate::job::load_job(
            self.description(),
            path,
            &crate::job::JobOptions {
                allow_unknown,
                ..Default::default()
            },
        )?;
        // The job was checked from the machine's start; it must also fit from here.
        if let Some(Command::Move(first)) = job
            .commands
            .iter()
            .map(|c| c.item)
            .find(|c| matches!(c, Command::Move(_)))
        {
            check_move(self.description(), &self.target, &first.target)
                .map_err(ApiError::Unreachable)?;
        }
        self.clamps.moves += job.clamps.moves;
        self.clamps.max_mm = self.clamps.max_mm.max(job.clamps.max_mm);
        for c in &job.commands {
            self.push(c.item)?;
        }
        Ok(job.commands.len())
    }

    /// Blocks until everything queued has been executed and the machine rests.
    pub fn wait(&mut self) -> Result<(), ApiError> {
        self.planner.finish();
        self.drain()?;
        self.sim.run_until(self.end);
        self.sim.run_to_rest();
        self.draw_finished();
        self.notify_tools();
        let now = self.sim.now();
        // A fresh lookahead starts from rest, on the clock as it is now.
        self.planner = Planner::new(self.description().limits(), self.target, now);
        self.end = now;
        self.idle = true;
        let t = now * 1e-6;
        self.emit(&Event::Idle { time: t });
        Ok(())
    }

    /// Where the motors are now (lags the calls by the lookahead and queues).
    pub fn position(&self) -> Vec<(String, f64)> {
        self.named(&self.sim.executed_point())
    }

    /// Where the machine will be once everything queued has run.
    pub fn target(&self) -> Vec<(String, f64)> {
        self.named(&self.target)
    }

    /// Simulated time, seconds.
    pub fn time(&self) -> f64 {
        self.sim.now() * 1e-6
    }

    /// Planned items (segments, events) still held back for lookahead.
    pub fn lookahead(&self) -> usize {
        self.planner.queued()
    }

    /// The report of everything run so far.
    pub fn report(&self) -> Report {
        let mut r = self.sim.report(
            "script",
            self.calls,
            self.end,
            self.started.elapsed().as_secs_f64(),
        );
        r.clamped_moves = self.clamps.moves;
        r.max_clamp_mm = self.clamps.max_mm;
        r
    }

    /// Writes `path.png`, `path.svg` and `report.json` of everything executed so
    /// far into `dir`.
    pub fn save(&mut self, dir: impl AsRef<Path>) -> Result<(), ApiError> {
        let dir = dir.as_ref();
        let io = |e: std::io::Error| ApiError::Io {
            path: dir.display().to_string(),
            error: e,
        };
        // Only the folder itself is made: a mistyped parent path is an
        // error, not a tree of new folders.
        if !dir.is_dir() {
            // The missing folder nearest the root is the one to name.
            let missing = dir
                .ancestors()
                .skip(1)
                .take_while(|p| !p.as_os_str().is_empty() && !p.exists())
                .last();
            if let Some(parent) = missing {
                return Err(ApiError::NoParent {
                    dir: dir.display().to_string(),
                    parent: parent.display().to_string(),
                });
            }
            std::fs::create_dir(dir).map_err(io)?;
        }
        // The stroke being drawn ends here, and the next starts here.
        let strokes = self.sim.take_strokes();
        self.drawing.draw(&strokes);
        self.drawing.save(dir).map_err(|e| match e {
            DrawingError::Io(e) => io(e),
            DrawingError::Render(e) => ApiError::Render(e.to_string()),
        })?;
        let report = serde_json::to_string_pretty(&self.report()).expect("reports serialise");
        std::fs::write(dir.join("report.json"), report + "\n").map_err(io)?;
        Ok(())
    }

    /// What the session holds that depends on its length, as counts; each
    /// stays bounded however many calls it makes (ARCHITECTURE.md,
    /// "Constant memory"): the executed path is drawn as it runs.
    pub fn held(&self) -> Held {
        self.sim.held()
    }

    /// Draws the strokes of the executed path finished so far.
    fn draw_finished(&mut self) {
        let strokes = self.sim.take_finished_strokes();
        if !strokes.is_empty() {
            self.drawing.draw(&strokes);
        }
    }

    fn named(&self, p: &Point) -> Vec<(String, f64)> {
        self.description()
            .axes
            .iter()
            .enumerate()
            .map(|(i, a)| (a.name.clone(), p[i]))
            .collect()
    }

    /// The machine point a call asks for, checked before anything is queued
    /// (within half a step beyond travel: clamped onto it, and counted).
    fn resolve(&self, spec: &[(&str, f64)], relative: bool) -> Result<(Point, f64), ApiError> {
        let m = self.description();
        let mut to = self.target;
        for (name, v) in spec {
            let i = m
                .axis(&name.to_ascii_lowercase())
                .ok_or_else(|| ApiError::UnknownAxis {
                    name: name.to_string(),
                    axes: self.axes().join(", "),
                })?;
            to[i] = if relative { to[i] + v } else { *v };
        }
        let clamped = clamp_move(m, &self.target, &mut to).map_err(ApiError::Unreachable)?;
        Ok((to, clamped))
    }

    /// Queues a move to a resolved target; `clamped`: how far it was
    /// clamped onto the travel (counted once the move is accepted).
    fn queue_move(
        &mut self,
        (to, clamped): (Point, f64),
        feed: f64,
        kind: MoveKind,
    ) -> Result<(), ApiError> {
        if kind == MoveKind::Feed && !ranges::VELOCITY.contains(feed) {
            return Err(ApiError::BadFeed(feed));
        }
        let queued = self.push(Command::Move(Move {
            target: to,
            feed,
            kind,
        }));
        // Accepted (an interruption comes after): the clamp counts.
        if clamped > 0.0 && matches!(queued, Ok(()) | Err(ApiError::Interrupted)) {
            self.clamps.moves += 1;
            self.clamps.max_mm = self.clamps.max_mm.max(clamped);
        }
        queued
    }

    /// Plans a command and streams whatever became final. Once the planner
    /// has accepted the command it counts as queued, even if streaming is
    /// interrupted.
    fn push(&mut self, cmd: Command) -> Result<(), ApiError> {
        self.planner.push(&cmd)?;
        self.calls += 1;
        self.idle = false;
        if let Command::Move(m) = cmd {
            self.target = m.target;
        }
        self.drain()?;
        self.notify_tools();
        Ok(())
    }

    /// Streams the planned items to the nodes; whatever an interruption
    /// leaves stays in the planner for the next call.
    fn drain(&mut self) -> Result<(), ApiError> {
        while let Some(item) = self.planner.pop() {
            if let Planned::Segment(s) = &item {
                self.end = s.t1();
            }
            self.sim.submit(item)?;
            self.draw_finished();
            if self.interrupt.as_mut().is_some_and(|f| f()) {
                return Err(ApiError::Interrupted);
            }
        }
        Ok(())
    }

    fn notify_tools(&mut self) {
        if self.listeners.is_empty() {
            self.sim.take_tool_changes();
            return;
        }
        for (t, tool, value) in self.sim.take_tool_changes() {
            let name = self.description().tools[tool].name.clone();
            self.emit(&Event::Tool {
                time: t * 1e-6,
                tool: name,
                value,
            });
        }
    }

    fn emit(&mut self, e: &Event) {
        for l in self.listeners.iter_mut() {
            l(e);
        }
    }
}

/// The drawing's size and title: the machine's x/y travel (a default square
/// where it is unbounded).
fn render_spec(m: &motet_host::Machine) -> RenderSpec {
    let (x, y) = (m.axis("x").unwrap_or(0), m.axis("y").unwrap_or(0));
    let mut bounds = [
        [m.axes[x].travel[0], m.axes[y].travel[0]],
        [m.axes[x].travel[1], m.axes[y].travel[1]],
    ];
    if !bounds.iter().flatten().all(|v| v.is_finite()) {
        bounds = [[-100.0, -100.0], [100.0, 100.0]];
    }
    RenderSpec::new(bounds, format!("script on {}", m.name))
}
