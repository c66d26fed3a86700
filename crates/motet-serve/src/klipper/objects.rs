//! Klipper's printer objects as motet's session shows them: the ones a
//! printer host (Moonraker) and its web pages (Mainsail, Fluidd) read.
//! The session's heaters are Klipper's heater objects: the first hot end
//! `extruder` (then `extruder1`, …), the bed `heater_bed`, the chamber
//! `heater_generic chamber`.

use super::print::Print;
use crate::session::{HeaterState, Session, State, Status};
use motet_gcode::Modal;
use motet_planner::AuxChannel;
use serde_json::{json, Map, Value};
use std::path::Path;

/// The objects this server has, as `objects/list` gives them.
pub const NAMES: &[&str] = &[
    "webhooks",
    "configfile",
    "toolhead",
    "gcode_move",
    "motion_report",
    "print_stats",
    "virtual_sdcard",
    "pause_resume",
    "display_status",
    "idle_timeout",
    "heaters",
    "system_stats",
];

/// Klipper's name for the heater on `channel`.
pub fn heater_name(channel: AuxChannel) -> Option<String> {
    match channel {
        AuxChannel::Hotend(0) => Some("extruder".into()),
        AuxChannel::Hotend(i) => Some(format!("extruder{i}")),
        AuxChannel::Bed => Some("heater_bed".into()),
        AuxChannel::Chamber => Some("heater_generic chamber".into()),
        AuxChannel::Fan(_) | AuxChannel::Coolant => None,
    }
}

/// Every object this server has for `s`: [`NAMES`] and its heaters.
pub fn names(s: &Session) -> Vec<String> {
    NAMES
        .iter()
        .map(|n| n.to_string())
        .chain(s.heaters().iter().filter_map(|h| heater_name(h.channel)))
        .collect()
}

fn heater_object(h: &HeaterState) -> Value {
    let mut v = json!({
        "temperature": round2(h.temp),
        "target": h.target,
        "power": h.power,
    });
    if let AuxChannel::Hotend(_) = h.channel {
        // Klipper's default minimum extrusion temperature.
        v["can_extrude"] = json!(h.temp >= 170.0);
        v["pressure_advance"] = json!(0.0);
        v["smooth_time"] = json!(0.04);
    }
    v
}

fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

/// What the objects are read from, at one moment.
pub(crate) struct View<'a> {
    /// The session.
    pub s: &'a Session,
    /// Its status now.
    pub status: &'a Status,
    /// The virtual SD card's print, if any.
    pub print: Option<&'a Print>,
    /// The printer host's G-code folder (the virtual SD card).
    pub gcodes: &'a Path,
    /// The connection's G-code state (modes, offsets, feed).
    pub modal: &'a Modal,
}

/// Klipper's state and message for the session's state.
pub fn webhooks_state(s: &Session, status: &Status) -> (&'static str, String) {
    match s.state() {
        State::Stopped | State::Alarm => (
            "shutdown",
            format!(
                "{}: FIRMWARE_RESTART (or RESTART) to go on",
                status.reason.as_deref().unwrap_or("stopped")
            ),
        ),
        _ => ("ready", "Printer is ready".to_string()),
    }
}

impl View<'_> {
    /// `p` on Klipper's four axes X, Y, Z, E (0 where the machine has none).
    fn xyze(&self, p: &[f64]) -> Vec<f64> {
        ["x", "y", "z", "e"]
            .iter()
            .map(|n| self.s.machine().axis(n).and_then(|i| p.get(i).copied()))
            .map(|v| v.unwrap_or(0.0))
            .collect()
    }

    fn axis_limit(&self, end: usize) -> Vec<f64> {
        let m = self.s.machine();
        ["x", "y", "z", "e"]
            .iter()
            .map(|n| m.axis(n).map_or(0.0, |i| m.axes[i].travel[end]))
            .map(|v| if v.is_finite() { v } else { 0.0 })
            .collect()
    }

    fn path_max(&self, f: impl Fn(&motet_host::Axis) -> f64) -> f64 {
        let m = self.s.machine();
        let v = m
            .axes
            .iter()
            // Klipper's limits are the XY plane's (Z has its own).
            .filter(|a| a.path && (a.name == "x" || a.name == "y"))
            .map(f)
            .fold(f64::INFINITY, f64::min);
        if v.is_finite() {
            v
        } else {
            0.0
        }
    }

    fn printing(&self) -> bool {
        self.print
            .is_some_and(|p| p.ended.is_none() && p.paused_since.is_none())
    }

    /// The object `name`'s whole status, if there is such an object.
    pub fn object(&self, name: &str) -> Option<Value> {
        let st = self.status;
        let t = st.t_us as f64 * 1e-6;
        Some(match name {
            "webhooks" => {
                let (state, message) = webhooks_state(self.s, st);
                json!({"state": state, "state_message": message})
            }
            "configfile" => self.configfile(),
            "toolhead" => json!({
                "homed_axes": "xyz",
                "axis_minimum": self.axis_limit(0),
                "axis_maximum": self.axis_limit(1),
                "print_time": t,
                "estimated_print_time": t,
                "stalls": 0,
                "extruder": if self.s.heaters().iter().any(|h| h.channel == AuxChannel::Hotend(0)) {
                    "extruder"
                } else {
                    ""
                },
                "position": self.xyze(&self.s.rest()[..]),
                "max_velocity": self.path_max(|a| a.max_velocity),
                "max_accel": self.path_max(|a| a.max_acceleration),
                "minimum_cruise_ratio": 0.5,
                "square_corner_velocity": 5.0,
            }),
            "gcode_move" => self.gcode_move(),
            "motion_report" => json!({
                "live_position": self.xyze(&st.position),
                "live_velocity": st.speed,
                "live_extruder_velocity": 0.0,
                "steppers": [],
                "trapq": [],
            }),
            "print_stats" => self.print_stats(),
            "virtual_sdcard" => {
                let p = self
                    .print
                    .filter(|p| p.ended.is_none() || p.state() == "complete");
                json!({
                    "file_path": p.map(|p| p.path.display().to_string()),
                    "progress": p.map_or(0.0, |p| p.progress),
                    "is_active": self.printing(),
                    "file_position": p.map_or(0, |p| (p.progress * p.size as f64) as u64),
                    "file_size": p.map_or(0, |p| p.size),
                })
            }
            "pause_resume" => json!({
                "is_paused": self.print.is_some_and(|p| p.state() == "paused")
                    || (self.s.state() == State::Paused),
            }),
            "display_status" => json!({
                "progress": self.print.map_or(0.0, |p| p.progress),
                "message": Value::Null,
            }),
            "idle_timeout" => {
                let busy = !matches!(
                    self.s.state(),
                    State::Idle | State::Stopped | State::Alarm | State::Paused
                );
                json!({
                    "state": if busy { "Printing" } else { "Ready" },
                    "printing_time": self.print.map_or(0.0, |p| p.total_s(st.t_us)),
                })
            }
            "heaters" => {
                let names: Vec<String> = self
                    .s
                    .heaters()
                    .iter()
                    .filter_map(|h| heater_name(h.channel))
                    .collect();
                json!({
                    "available_heaters": names,
                    "available_sensors": names,
                    "available_monitors": [],
                })
            }
            "system_stats" => json!({"sysload": 0.0, "cputime": 0.0, "memavail": 0}),
            other => {
                let h = self
                    .s
                    .heaters()
                    .iter()
                    .find(|h| heater_name(h.channel).as_deref() == Some(other))?;
                heater_object(h)
            }
        })
    }

    fn gcode_move(&self) -> Value {
        let m = self.modal;
        let pos = self.xyze(&self.s.position()[..]);
        let offset = self.xyze(&m.offset[..]);
        let gcode_position: Vec<f64> = pos.iter().zip(&offset).map(|(p, o)| p - o).collect();
        json!({
            "speed_factor": 1.0,
            "speed": m.feed.unwrap_or(0.0),
            "extrude_factor": 1.0,
            "absolute_coordinates": !m.relative,
            "absolute_extrude": !m.relative,
            "homing_origin": offset,
            "position": pos,
            "gcode_position": gcode_position,
        })
    }

    fn print_stats(&self) -> Value {
        let now = self.status.t_us;
        match self.print {
            None => json!({
                "filename": "",
                "total_duration": 0.0,
                "print_duration": 0.0,
                "filament_used": 0.0,
                "state": "standby",
                "message": "",
                "info": {"total_layer": Value::Null, "current_layer": Value::Null},
            }),
            Some(p) => json!({
                "filename": p.filename,
                "total_duration": p.total_s(now),
                "print_duration": p.print_s(now),
                "filament_used": 0.0,
                "state": p.state(),
                "message": match &p.ended {
                    Some(("error", _, why)) => why.clone(),
                    _ => String::new(),
                },
                "info": {"total_layer": Value::Null, "current_layer": Value::Null},
            }),
        }
    }

    fn configfile(&self) -> Value {
        let m = self.s.machine();
        let gcodes = self.gcodes.display().to_string();
        let kin = format!("{:?}", m.kinematics).to_lowercase();
        let (v, a) = (
            self.path_max(|a| a.max_velocity),
            self.path_max(|a| a.max_acceleration),
        );
        let config = json!({
            "printer": {"kinematics": kin, "max_velocity": v.to_string(), "max_accel": a.to_string()},
            "virtual_sdcard": {"path": gcodes},
            "pause_resume": {},
            "display_status": {},
        });
        let settings = json!({
            "printer": {"kinematics": kin, "max_velocity": v, "max_accel": a},
            "virtual_sdcard": {"path": gcodes, "on_error_gcode": ""},
            "pause_resume": {"recover_velocity": 50.0},
            "display_status": {},
        });
        json!({
            "config": config,
            "settings": settings,
            "save_config_pending": false,
            "save_config_pending_items": {},
            "warnings": [],
        })
    }
}

/// `status` cut to the fields asked for (`None`: all of them).
pub fn select(status: Value, fields: Option<&[String]>) -> Value {
    match (status, fields) {
        (Value::Object(o), Some(f)) => {
            let kept: Map<String, Value> = o.into_iter().filter(|(k, _)| f.contains(k)).collect();
            Value::Object(kept)
        }
        (v, _) => v,
    }
}
