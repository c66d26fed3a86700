//! Klipper's API server: a printer host (Moonraker, and through it the
//! Mainsail and Fluidd web pages) connects to a Unix socket
//! (`motet serve --klipper-api PATH`) and drives the machine as it would a
//! Klipper printer (docs/compat.md).
//!
//! Messages are JSON objects ended by 0x03 ([`frame`]). Queries
//! (`info`, `objects/query`, …) are answered at once from the session's
//! status ([`objects`]); `gcode/script` runs its lines in order as the
//! machine takes them (`gcode.rs`), its answer coming when the last is
//! taken; a file in the host's G-code folder prints as a job of the
//! server's own (`print.rs`). Subscriptions get what changed every
//! [`PUSH_US`].

mod endpoints;
pub mod frame;
mod gcode;
pub mod objects;
mod print;

use crate::device::{port::Port, Device};
use crate::server::{Server, Shared};
use crate::session::Session;
use frame::{Frame, Frames};
use motet_gcode::{GcodeOptions, Interpreter};
use motet_host::Machine;
use print::{Loading, Print};
use serde_json::{json, Map, Value};
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

pub use gcode::{command_word, param};

/// Who the session sees acting.
pub const CLIENT: Option<&str> = Some("klipper");
/// Subscriptions are pushed this often at most, µs (as Klipper does).
pub const PUSH_US: u64 = 250_000;
/// `gcode/script` requests a connection may have waiting; beyond, the
/// port stops reading until one is done.
pub const MAX_SCRIPTS: usize = 64;
/// Console lines kept for connections that subscribed to them.
const KEPT_OUTPUT: usize = 200;

/// What every connection shares: the print and the console.
pub(crate) struct Hub {
    shared: Arc<Shared>,
    gcodes: PathBuf,
    state: Mutex<HubState>,
}

#[derive(Default)]
pub(crate) struct HubState {
    /// The virtual SD card's print.
    print: Option<Print>,
    /// A file is being read for a print.
    loading: bool,
    /// Console lines, numbered.
    output: VecDeque<(u64, String)>,
    next_output: u64,
}

impl Hub {
    fn lock(&self) -> MutexGuard<'_, HubState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A console line for every connection that subscribed to the output.
    fn respond(&self, line: &str) {
        let mut st = self.lock();
        st.next_output += 1;
        let n = st.next_output;
        st.output.push_back((n, line.to_string()));
        if st.output.len() > KEPT_OUTPUT {
            st.output.pop_front();
        }
    }
}

/// A `gcode/script` request: its lines not yet taken.
struct Script {
    id: Option<Value>,
    lines: VecDeque<String>,
}

/// Objects asked for, each with its fields (`None`: all of them).
pub(crate) type ObjectList = Vec<(String, Option<Vec<String>>)>;

/// An `objects/subscribe`: what to push, how, and what was last pushed.
struct Subscription {
    objects: ObjectList,
    template: Map<String, Value>,
    last: Map<String, Value>,
    next_us: u64,
}

/// One connection's Klipper API server.
pub struct Klipper {
    hub: Arc<Hub>,
    frames: Frames,
    out: Vec<u8>,
    scripts: VecDeque<Script>,
    loading: Option<Loading>,
    interp: Interpreter,
    line_no: u32,
    sub: Option<Subscription>,
    /// The console subscription: its template and the last line sent.
    output: Option<(Map<String, Value>, u64)>,
    /// Requests answered so far (for tests and figures).
    pub answered: u64,
}

impl Klipper {
    fn new(hub: Arc<Hub>) -> Klipper {
        let interp = new_interpreter(&hub.shared.machine);
        Klipper {
            hub,
            frames: Frames::default(),
            out: Vec::new(),
            scripts: VecDeque::new(),
            loading: None,
            interp,
            line_no: 0,
            sub: None,
            output: None,
            answered: 0,
        }
    }

    fn send(&mut self, v: &Value) {
        self.out.extend(frame::encode(v));
    }

    fn answer(&mut self, id: Option<&Value>, r: Result<Value, String>) {
        // A request without an id gets no answer (as in Klipper).
        let Some(id) = id else { return };
        self.answered += 1;
        let v = match r {
            Ok(v) => frame::result(id, v),
            Err(m) => frame::error(Some(id), &m),
        };
        self.send(&v);
    }

    /// A fresh G-code state (after `M2`, a restart), at the machine's rest.
    fn restart_interpreter(&mut self, s: &Session) {
        self.interp = new_interpreter(&self.hub.shared.machine);
        self.interp.set_machine_position(s.rest());
    }

    /// Runs waiting scripts' lines in order as far as the machine allows.
    fn run_scripts(&mut self, s: &mut Session) {
        while let Some(script) = self.scripts.front_mut() {
            let Some(line) = script.lines.front().cloned() else {
                let done = self.scripts.pop_front().map(|sc| sc.id);
                self.answer(done.flatten().as_ref(), Ok(json!({})));
                continue;
            };
            match self.line(&line, s) {
                gcode::Step::Wait => break,
                gcode::Step::Done(Ok(())) => {
                    if let Some(sc) = self.scripts.front_mut() {
                        sc.lines.pop_front();
                    }
                }
                gcode::Step::Done(Err(e)) => {
                    // The rest of that script is dropped, as Klipper
                    // aborts a script at its first error.
                    let id = self.scripts.pop_front().and_then(|sc| sc.id);
                    self.answer(id.as_ref(), Err(e));
                }
            }
        }
    }

    /// Console lines not yet sent to a connection that subscribed.
    fn push_output(&mut self) {
        let Some((template, seen)) = &self.output else {
            return;
        };
        let new: Vec<(u64, String)> = self
            .hub
            .lock()
            .output
            .iter()
            .filter(|(n, _)| n > seen)
            .cloned()
            .collect();
        let template = template.clone();
        for (n, line) in new {
            let mut m = template.clone();
            m.insert("params".into(), json!({"response": line}));
            self.send(&Value::Object(m));
            if let Some(o) = &mut self.output {
                o.1 = n;
            }
        }
    }

    /// What changed in the subscribed objects, every [`PUSH_US`].
    fn push_status(&mut self, s: &Session) {
        let now = s.status().t_us;
        let due = self.sub.as_ref().is_some_and(|sub| now >= sub.next_us);
        if !due {
            return;
        }
        let status = self.status(s, self.sub.as_ref().map_or(&[][..], |x| &x.objects[..]));
        let Some(sub) = &mut self.sub else { return };
        sub.next_us = now + PUSH_US;
        let mut diff = Map::new();
        for (name, v) in status {
            let Value::Object(fields) = v else { continue };
            let last = sub.last.entry(name.clone()).or_insert_with(|| json!({}));
            let mut changed = Map::new();
            for (k, v) in fields {
                if last.get(&k) != Some(&v) {
                    changed.insert(k.clone(), v.clone());
                    if let Value::Object(l) = last {
                        l.insert(k, v);
                    }
                }
            }
            if !changed.is_empty() {
                diff.insert(name, Value::Object(changed));
            }
        }
        if diff.is_empty() {
            return;
        }
        let mut m = sub.template.clone();
        m.insert(
            "params".into(),
            json!({"eventtime": now as f64 * 1e-6, "status": diff}),
        );
        self.send(&Value::Object(m));
    }

    /// The objects asked for (those that exist), cut to their fields.
    fn status(&self, s: &Session, objects: &[(String, Option<Vec<String>>)]) -> Map<String, Value> {
        let status = s.status();
        let mut st = self.hub.lock();
        // Up to date with the session, whatever came since the last poll.
        if let Some(p) = &mut st.print {
            p.follow(s);
        }
        let modal = self.interp.modal();
        let view = objects::View {
            s,
            status: &status,
            print: st.print.as_ref(),
            gcodes: &self.hub.gcodes,
            modal: &modal,
        };
        objects
            .iter()
            .filter_map(|(name, fields)| {
                let v = view.object(name)?;
                Some((name.clone(), objects::select(v, fields.as_deref())))
            })
            .collect()
    }
}

impl Device for Klipper {
    fn open(&mut self) {}

    fn receive(&mut self, bytes: &[u8], s: &mut Session) {
        for f in self.frames.push(bytes) {
            let req = match f {
                Frame::TooLong => Err((None, frame::RequestError::TooLong)),
                Frame::Message(m) => frame::parse(&m),
            };
            match req {
                Ok(r) => self.request(r, s),
                Err((id, e)) => {
                    self.answered += 1;
                    self.send(&frame::error(id.as_ref(), &e.to_string()));
                }
            }
        }
    }

    fn poll(&mut self, s: &mut Session) {
        if let Some(p) = &mut self.hub.lock().print {
            p.follow(s);
        }
        self.run_scripts(s);
        self.push_output();
        self.push_status(s);
    }

    fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    fn wants_input(&self) -> bool {
        self.scripts.len() < MAX_SCRIPTS
    }
}

impl Server {
    /// Opens Klipper's API server on a Unix socket at `socket` for this
    /// server's session; files to print are read from `gcodes` (the
    /// printer host's G-code folder, Klipper's `[virtual_sdcard] path`).
    /// Returns where programs connect (`unix:PATH`).
    pub fn klipper(&self, socket: &Path, gcodes: &Path) -> std::io::Result<String> {
        let hub = Arc::new(Hub {
            shared: self.shared.clone(),
            gcodes: gcodes.to_path_buf(),
            state: Mutex::new(HubState::default()),
        });
        self.device("klipper", &Port::Unix(socket.to_path_buf()), move || {
            Klipper::new(hub.clone())
        })
    }
}

fn new_interpreter(machine: &Machine) -> Interpreter {
    // The default options are valid: this cannot fail.
    Interpreter::new(&machine.job_target(), &GcodeOptions::default())
        .unwrap_or_else(|e| unreachable!("default G-code options: {e}"))
}
