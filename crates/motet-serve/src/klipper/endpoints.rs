//! The endpoints: what each request does and answers.

use super::frame::Request;
use super::objects::{self, webhooks_state};
use super::{Klipper, ObjectList, Script, Subscription, CLIENT};
use crate::session::Session;
use serde_json::{json, Map, Value};
use std::os::unix::fs::MetadataExt;

/// The endpoints, as `list_endpoints` gives them.
pub const ENDPOINTS: &[&str] = &[
    "info",
    "emergency_stop",
    "list_endpoints",
    "register_remote_method",
    "objects/list",
    "objects/query",
    "objects/subscribe",
    "gcode/script",
    "gcode/help",
    "gcode/restart",
    "gcode/firmware_restart",
    "gcode/subscribe_output",
    "pause_resume/pause",
    "pause_resume/resume",
    "pause_resume/cancel",
];

/// Commands `gcode/help` lists, with what they do here.
const HELP: &[(&str, &str)] = &[
    ("G0", "Rapid move (motet's G-code interpreter)"),
    ("G1", "Linear move"),
    ("M112", "Emergency stop"),
    ("M114", "Report the position"),
    ("M400", "Wait until the machine rests"),
    ("SDCARD_PRINT_FILE", "Print a file from the G-code folder"),
    ("SDCARD_RESET_FILE", "Forget the last print"),
    ("PAUSE", "Hold the print on its path"),
    ("RESUME", "Continue a held print"),
    ("CANCEL_PRINT", "Cancel the print"),
    ("FIRMWARE_RESTART", "Clear an emergency stop or alarm"),
    ("RESTART", "Clear an emergency stop or alarm"),
    ("GET_POSITION", "Report the position"),
    ("STATUS", "Report the machine's state"),
];

/// The `objects` parameter: names and their fields (`None`: all).
fn objects_param(p: &Map<String, Value>) -> Result<ObjectList, String> {
    let Some(o) = p.get("objects") else {
        return Err("Missing Argument [objects]".into());
    };
    let Value::Object(o) = o else {
        return Err("Invalid Argument Type [objects]: expected an object".into());
    };
    o.iter()
        .map(|(name, fields)| {
            let fields = match fields {
                Value::Null => None,
                Value::Array(a) => Some(
                    a.iter()
                        .map(|f| f.as_str().map(str::to_string))
                        .collect::<Option<Vec<_>>>()
                        .ok_or(format!(
                            "Invalid Argument Type [objects.{name}]: expected field names"
                        ))?,
                ),
                _ => {
                    return Err(format!(
                        "Invalid Argument Type [objects.{name}]: expected a list or null"
                    ))
                }
            };
            Ok((name.clone(), fields))
        })
        .collect()
}

fn template(p: &Map<String, Value>) -> Result<Map<String, Value>, String> {
    match p.get("response_template") {
        Some(Value::Object(t)) => Ok(t.clone()),
        Some(_) => Err("Invalid Argument Type [response_template]: expected an object".into()),
        None => Err("Missing Argument [response_template]".into()),
    }
}

impl Klipper {
    /// Acts on one request; queries are answered now, scripts when run.
    pub(super) fn request(&mut self, r: Request, s: &mut Session) {
        let id = r.id.clone();
        let p = &r.params;
        let answer: Result<Value, String> = match r.method.as_str() {
            "info" => Ok(self.info(s)),
            "list_endpoints" => Ok(json!({"endpoints": ENDPOINTS})),
            "objects/list" => Ok(json!({"objects": objects::names(s)})),
            "objects/query" => objects_param(p).map(|o| {
                json!({"eventtime": s.status().t_us as f64 * 1e-6, "status": self.status(s, &o)})
            }),
            "objects/subscribe" => self.subscribe(p, s),
            "gcode/subscribe_output" => template(p).map(|t| {
                let seen = self.hub.lock().next_output;
                self.output = Some((t, seen));
                json!({})
            }),
            "register_remote_method" => template(p).and_then(|_| match p.get("remote_method") {
                Some(Value::String(_)) => Ok(json!({})),
                _ => Err("Missing Argument [remote_method]".into()),
            }),
            "gcode/help" => Ok(Value::Object(
                HELP.iter().map(|(k, v)| (k.to_string(), json!(v))).collect(),
            )),
            "emergency_stop" => {
                s.estop();
                // What waited can no longer run.
                for sc in std::mem::take(&mut self.scripts) {
                    self.answer(sc.id.as_ref(), Err("Printer is shutdown".into()));
                }
                Ok(json!({}))
            }
            "gcode/script" => match p.get("script") {
                Some(Value::String(script)) => {
                    let lines = script.lines().map(str::to_string).collect();
                    return self.scripts.push_back(Script { id, lines });
                }
                Some(_) => Err("Invalid Argument Type [script]: expected a string".into()),
                None => Err("Missing Argument [script]".into()),
            },
            m @ ("gcode/restart" | "gcode/firmware_restart" | "pause_resume/pause"
            | "pause_resume/resume" | "pause_resume/cancel") => {
                // In order with the scripts before them.
                let line = match m {
                    "pause_resume/pause" => "PAUSE",
                    "pause_resume/resume" => "RESUME",
                    "pause_resume/cancel" => "CANCEL_PRINT",
                    "gcode/restart" => "RESTART",
                    _ => "FIRMWARE_RESTART",
                };
                let lines = [line.to_string()].into();
                return self.scripts.push_back(Script { id, lines });
            }
            m => Err(format!("No registered endpoint '{m}'")),
        };
        self.answer(id.as_ref(), answer);
    }

    fn subscribe(&mut self, p: &Map<String, Value>, s: &Session) -> Result<Value, String> {
        let objects = objects_param(p)?;
        let template = template(p)?;
        let now = s.status().t_us;
        let status = self.status(s, &objects);
        // A new subscription replaces the connection's last one (as in
        // Klipper); pushes carry what changed after this answer.
        self.sub = Some(Subscription {
            objects,
            template,
            last: status.clone(),
            next_us: now + super::PUSH_US,
        });
        Ok(json!({"eventtime": now as f64 * 1e-6, "status": status}))
    }

    fn info(&self, s: &Session) -> Value {
        let status = s.status();
        let (state, message) = webhooks_state(s, &status);
        let exe = std::env::current_exe().unwrap_or_default();
        let dir = exe.parent().map(|p| p.to_path_buf()).unwrap_or_default();
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
        // The process's own ids, as the owner of its /proc entry.
        let (uid, gid) = std::fs::metadata("/proc/self")
            .map(|m| (m.uid(), m.gid()))
            .unwrap_or((0, 0));
        json!({
            "state": state,
            "state_message": message,
            "hostname": host.trim(),
            "klipper_path": dir.display().to_string(),
            "python_path": exe.display().to_string(),
            "process_id": std::process::id(),
            "user_id": uid,
            "group_id": gid,
            "log_file": "",
            "config_file": s.machine().file.display().to_string(),
            "software_version": format!("motet {}", env!("CARGO_PKG_VERSION")),
            "cpu_info": format!("{} cores", std::thread::available_parallelism().map_or(1, |n| n.get())),
            "app": "motet",
            "client": CLIENT,
        })
    }
}
