//! A hand-driven machine: the server runs a motion-stream graph on a
//! simulated node, paced to the wall clock, with the graph's inputs
//! (knobs, joysticks, buttons: its `[inputs]`) set live over the API and
//! from the page's sliders, as `motet dance --live` takes them from a
//! terminal. Its components' live parameters (gains, scales, limits) are
//! set the same way, each sent to the node as the wire carries it
//! (`GraphParam`; [`params`]). While the graph runs, the machine is the
//! graph's: the session takes no jobs, jogs or tool changes.

pub mod params;

pub use params::{ComponentView, ParamError, ParamView};

use motet_graph::GraphFile;
use motet_host::Machine;
use motet_sim::dance::{
    watch_dance, ChangeFrom, DanceMoment, DanceOptions, HeldInputs, InputSource, ParamChange,
};
use motet_wire::message::GraphInputKind;
use params::Params;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// How often the running graph says where the pen is, frames (1 ms at the
/// default 40 µs frame).
const WATCH_EVERY: u64 = 25;
/// How far the graph may run ahead of the wall clock, s: it sleeps when it
/// is further ahead (and falls behind, losing nothing, when it cannot keep
/// up).
const AHEAD_S: f64 = 0.002;
/// How long a parameter change waits for the graph's thread to send it
/// (it does within a frame or two of the wall clock).
const CHANGE_WAIT: Duration = Duration::from_secs(5);

/// Why an input could not be set. Nothing changed.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// No input of that name.
    #[error("the graph has no input `{name}` (its inputs: {inputs})")]
    Unknown {
        /// The name given.
        name: String,
        /// The graph's inputs.
        inputs: String,
    },
    /// Not a finite number.
    #[error("input `{0}`: the value must be a finite number")]
    NotFinite(String),
    /// Outside what such an input reads.
    #[error("input `{name}` ({kind}): {value} is outside {lo}..={hi}")]
    OutOfRange {
        /// The input.
        name: String,
        /// Its kind.
        kind: &'static str,
        /// The value given.
        value: f64,
        /// Lowest it takes.
        lo: f64,
        /// Highest it takes.
        hi: f64,
    },
}

/// What an input of `kind` reads: encoders ±1,000,000 counts, analog
/// inputs a raw reading of up to 12 bits, digital inputs any level
/// (nonzero is pressed), motion streams 16 signal bits. A value outside
/// would be a reading no input gives (and the node refuses some of them).
pub fn input_range(kind: GraphInputKind) -> (f64, f64) {
    match kind {
        GraphInputKind::Encoder => (-1.0e6, 1.0e6),
        GraphInputKind::Analog => (0.0, 4095.0),
        GraphInputKind::Digital => (f64::MIN, f64::MAX),
        GraphInputKind::Stream => (0.0, 65535.0),
    }
}

/// Why a graph could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// The graph does not fit the machine, or the node refused it.
    #[error("{0}")]
    Dance(#[from] motet_sim::dance::DanceError),
    /// Its thread could not start.
    #[error("starting the graph's thread: {0}")]
    Thread(#[from] std::io::Error),
}

/// One input as a screen shows it.
#[derive(Clone, Debug, Serialize)]
pub struct InputView {
    /// Its name in the graph's `[inputs]`.
    pub name: String,
    /// `encoder`, `analog`, `digital` or `stream`.
    pub kind: &'static str,
    /// Its value now.
    pub value: f64,
}

/// The graph as a screen shows it.
#[derive(Clone, Debug, Serialize)]
pub struct GraphView {
    /// The graph file.
    pub file: String,
    /// Its frame, µs.
    pub frame_us: f64,
    /// Its inputs.
    pub inputs: Vec<InputView>,
    /// Its components' live parameters (in answers to the graph's routes;
    /// left out of the pushes, which carry `param_changes` instead).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub components: Option<Vec<ComponentView>>,
    /// Parameter changes the node took since the graph started (a client's
    /// or a stage's): a screen reads the parameters again when it grows.
    pub param_changes: u64,
    /// The node's time, s.
    pub t_s: f64,
    /// The pen's x, y, mm.
    pub position: [f64; 2],
    /// Whether the pen is down.
    pub pen_down: bool,
    /// Why the graph stopped, if it did (a node refusal).
    pub error: Option<String>,
}

struct Live {
    values: Vec<f64>,
    moment: DanceMoment,
    error: Option<String>,
    params: Params,
}

/// A client's parameter change on its way to the graph's thread, and where
/// the node's answer goes.
type Ask = (ParamChange, Sender<Result<(), String>>);

/// A graph running on its own thread.
pub struct GraphRun {
    file: String,
    frame_us: f64,
    names: Vec<String>,
    kinds: Vec<GraphInputKind>,
    /// The graph, for checking parameter changes by name.
    graph: GraphFile,
    live: Arc<Mutex<Live>>,
    asks: Mutex<Sender<Ask>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// The inputs as the graph reads them: the values set last, with the run
/// kept to the wall clock; and the clients' parameter changes.
struct Paced {
    live: Arc<Mutex<Live>>,
    start: Instant,
    asks: Receiver<Ask>,
    /// Where the answer to the change being sent goes.
    answer: Option<Sender<Result<(), String>>>,
}

impl InputSource for Paced {
    fn values(&mut self, t_s: f64, out: &mut [f64]) {
        let ahead = t_s - self.start.elapsed().as_secs_f64();
        if ahead > AHEAD_S {
            std::thread::sleep(Duration::from_secs_f64(ahead - AHEAD_S / 2.0));
        }
        let l = self.live.lock().unwrap_or_else(|e| e.into_inner());
        out.copy_from_slice(&l.values);
    }

    fn next_change(&mut self) -> Option<ParamChange> {
        let (change, answer) = self.asks.try_recv().ok()?;
        self.answer = Some(answer);
        Some(change)
    }

    fn changed(&mut self, change: &ParamChange, from: ChangeFrom, result: Result<(), String>) {
        if result.is_ok() {
            let mut l = self.live.lock().unwrap_or_else(|e| e.into_inner());
            l.params.taken(change);
        }
        if from == ChangeFrom::Source {
            if let Some(a) = self.answer.take() {
                // The client may have gone: the change stands all the same.
                let _ = a.send(result);
            }
        }
    }
}

/// Where an input starts: an analog input (a joystick, a potentiometer;
/// read 0..=1023) in the middle, so a joystick starts at rest; the others
/// at 0.
pub fn start_value(k: GraphInputKind) -> f64 {
    match k {
        GraphInputKind::Analog => ANALOG_MIDDLE,
        _ => 0.0,
    }
}

/// The middle of an analog input's range (0..=1023).
pub const ANALOG_MIDDLE: f64 = 512.0;

fn kind_name(k: GraphInputKind) -> &'static str {
    match k {
        GraphInputKind::Encoder => "encoder",
        GraphInputKind::Analog => "analog",
        GraphInputKind::Digital => "digital",
        GraphInputKind::Stream => "stream",
    }
}

impl GraphRun {
    /// Starts `graph` on `machine`: it runs until the run is dropped. It is
    /// built and run for one frame first, so a graph that does not fit the
    /// machine is an error here, not later on its thread.
    pub fn start(machine: Machine, graph: GraphFile) -> Result<GraphRun, StartError> {
        let mut rest = HeldInputs(vec![0.0; graph.inputs.len()]);
        watch_dance(
            &machine,
            &graph,
            &mut rest,
            DanceOptions::default(),
            1,
            &mut |_| false,
        )?;
        let names: Vec<String> = graph.inputs.iter().map(|i| i.name.clone()).collect();
        let kinds: Vec<GraphInputKind> = graph.inputs.iter().map(|i| i.kind).collect();
        let live = Arc::new(Mutex::new(Live {
            values: kinds.iter().map(|k| start_value(*k)).collect(),
            moment: DanceMoment {
                t_s: 0.0,
                xy: [0.0; 2],
                pen_down: false,
            },
            error: None,
            params: Params::of(&graph),
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let (file, frame_us) = (graph.file.clone(), graph.frame_us);
        let (asks, asked) = channel();
        let paced = Paced {
            live: live.clone(),
            start: Instant::now(),
            asks: asked,
            answer: None,
        };
        let (s, g) = (stop.clone(), graph.clone());
        let thread = std::thread::Builder::new()
            .name("motet-graph".into())
            .spawn(move || run(&machine, &g, paced, &s))?;
        Ok(GraphRun {
            file,
            frame_us,
            names,
            kinds,
            graph,
            live,
            asks: Mutex::new(asks),
            stop,
            thread: Some(thread),
        })
    }

    fn live(&self) -> MutexGuard<'_, Live> {
        self.live.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Sets inputs by name; all or none (a bad one changes nothing).
    pub fn set_inputs(&self, given: &[(String, f64)]) -> Result<(), InputError> {
        let mut at = Vec::with_capacity(given.len());
        for (name, value) in given {
            let Some(k) = self.names.iter().position(|n| n == name) else {
                return Err(InputError::Unknown {
                    name: name.clone(),
                    inputs: self.names.join(", "),
                });
            };
            if !value.is_finite() {
                return Err(InputError::NotFinite(name.clone()));
            }
            let (lo, hi) = input_range(self.kinds[k]);
            if !(lo..=hi).contains(value) {
                return Err(InputError::OutOfRange {
                    name: name.clone(),
                    kind: kind_name(self.kinds[k]),
                    value: *value,
                    lo,
                    hi,
                });
            }
            at.push((k, *value));
        }
        let mut l = self.live();
        for (k, v) in at {
            l.values[k] = v;
        }
        Ok(())
    }

    /// Sets `component.param` on the running graph: checked against the
    /// parameter's declared values, sent to the node as the wire carries it,
    /// and answered with what the node did. A refusal changes nothing.
    pub fn set_param(&self, component: &str, param: &str, value: f64) -> Result<(), ParamError> {
        let change = self
            .live()
            .params
            .check(&self.graph, component, param, value)?;
        let (answer, answered) = channel();
        let stopped = || ParamError::Stopped(self.live().error.clone().unwrap_or_default());
        {
            let asks = self.asks.lock().unwrap_or_else(|e| e.into_inner());
            asks.send((change, answer)).map_err(|_| stopped())?;
        }
        match answered.recv_timeout(CHANGE_WAIT) {
            Ok(Ok(())) => Ok(()),
            Ok(Err(reason)) => Err(ParamError::Refused {
                component: component.into(),
                param: param.into(),
                value,
                reason,
            }),
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => Err(stopped()),
        }
    }

    /// The graph now, with its components' live parameters.
    pub fn view_with_params(&self) -> GraphView {
        let mut v = self.view();
        v.components = Some(self.live().params.view().to_vec());
        v
    }

    /// The graph now (what the pushes carry).
    pub fn view(&self) -> GraphView {
        let l = self.live();
        GraphView {
            file: self.file.clone(),
            frame_us: self.frame_us,
            inputs: self
                .names
                .iter()
                .zip(&self.kinds)
                .zip(&l.values)
                .map(|((n, k), v)| InputView {
                    name: n.clone(),
                    kind: kind_name(*k),
                    value: *v,
                })
                .collect(),
            t_s: l.moment.t_s,
            position: l.moment.xy,
            pen_down: l.moment.pen_down,
            error: l.error.clone(),
            components: None,
            param_changes: l.params.changes,
        }
    }
}

impl Drop for GraphRun {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The graph's thread: frames until stopped; a refusal by the node ends
/// the run and is kept for the screen.
fn run(machine: &Machine, graph: &GraphFile, mut inputs: Paced, stop: &AtomicBool) {
    let live = inputs.live.clone();
    let mut watch = |m: &DanceMoment| {
        let mut l = live.lock().unwrap_or_else(|e| e.into_inner());
        l.moment = *m;
        !stop.load(Ordering::Relaxed)
    };
    let options = DanceOptions::default();
    if let Err(e) = watch_dance(
        machine,
        graph,
        &mut inputs,
        options,
        WATCH_EVERY,
        &mut watch,
    ) {
        live.lock().unwrap_or_else(|e| e.into_inner()).error = Some(e.to_string());
    }
}
