//! The tool (M3/M4/M5 and S), coolant and printer codes (temperatures, fans,
//! M400).

use motet_planner::ranges;
use motet_planner::{AuxChannel, Command, SourceError, ToolKind};

use super::diagnostics::WarnKey;
use super::{Interp, ToolState};
use crate::block::{PArgs, Words};
use crate::codes::{code_name, NonModal, Printer, Spindle};

impl Interp {
    pub(super) fn spindle(&mut self, w: &Words, lenient: bool) -> Result<(), SourceError> {
        let dwell = matches!(w.nonmodal, Some((NonModal::Dwell, _)));
        if let Some((sp, at)) = w.spindle {
            let Some((tool, kind, on_value)) = self.tool else {
                return Err(self.error(
                    at,
                    format!("{} needs a tool, and this machine has none", sp.name()),
                ));
            };
            let value = match (sp, kind, w.s) {
                (Spindle::Off, _, _) => 0.0,
                (_, _, None) => on_value,
                (_, ToolKind::Pen, Some(_)) => 1.0,
                (_, _, Some(s)) => power(self.value(s, 'S')?),
            };
            match (sp, kind) {
                (Spindle::Ccw, ToolKind::Laser) => {
                    self.tool_state = ToolState::PerSpeed(value, None);
                    if !self.inverse_time {
                        self.per_speed_sync(at, self.feed);
                    }
                    return Ok(());
                }
                (Spindle::Ccw, _) => {
                    self.warn(WarnKey(b'M', 40), at, || {
                        "M4 on a pen or spindle acts as M3 (power following speed is for lasers)"
                            .into()
                    });
                }
                _ => {}
            }
            self.tool_state = if sp == Spindle::Off {
                ToolState::Off
            } else {
                ToolState::On(value)
            };
            self.emit(at, Command::Tool { tool, value });
        } else if let (Some(s), false) = (w.s, dwell) {
            let v = self.value(s, 'S')?;
            match (self.tool, self.tool_state) {
                (Some((_, ToolKind::Pen, _)), ToolState::On(_) | ToolState::PerSpeed(..)) => {}
                (Some((tool, _, _)), ToolState::On(cur)) => {
                    let value = power(v);
                    if value != cur {
                        self.tool_state = ToolState::On(value);
                        self.emit(s.at, Command::Tool { tool, value });
                    }
                }
                (Some(_), ToolState::PerSpeed(cur, _)) => {
                    let value = power(v);
                    if value != cur {
                        self.tool_state = ToolState::PerSpeed(value, None);
                        if !self.inverse_time {
                            self.per_speed_sync(s.at, self.feed);
                        }
                    }
                }
                _ if lenient => {}
                _ => self.warn(WarnKey(b'S', 0), s.at, || {
                    "S without M3 has no effect while the tool is off; put S on the M3 line".into()
                }),
            }
        }
        Ok(())
    }

    /// While M4 is on, emit ToolPerSpeed if `feed` differs from the last one.
    pub(super) fn per_speed_sync(&mut self, at: usize, feed: Option<f64>) {
        if let (ToolState::PerSpeed(value, last), Some(f), Some((tool, _, _))) =
            (self.tool_state, feed, self.tool)
        {
            if last != Some(f) {
                self.tool_state = ToolState::PerSpeed(value, Some(f));
                self.emit(
                    at,
                    Command::ToolPerSpeed {
                        tool,
                        value,
                        feed: f,
                    },
                );
            }
        }
    }

    pub(super) fn printer(
        &mut self,
        pc: Printer,
        code: u32,
        at: usize,
        a: PArgs,
    ) -> Result<(), SourceError> {
        let name = code_name(b'M', code);
        let index = |v: Option<f64>, default: u8, letter: char| -> Result<u8, SourceError> {
            match v {
                None => Ok(default),
                Some(v) if (0.0..=255.0).contains(&v) && v.fract() == 0.0 => Ok(v as u8),
                Some(v) => Err(self.error(at, format!("{name}: bad {letter}{v}"))),
            }
        };
        let temperature = |wait: bool| -> Result<f32, SourceError> {
            let v = match (a.s, a.r, wait) {
                (Some(s), _, _) => s,
                (None, Some(r), true) => r,
                _ => {
                    return Err(self.error(
                        at,
                        format!(
                            "{name} needs S (temperature){}",
                            if wait { " or R" } else { "" }
                        ),
                    ))
                }
            };
            ranges::TEMPERATURE_C
                .check(format_args!("{name}: temperature"), v)
                .map_err(|e| self.error(at, e.to_string()))?;
            Ok(v as f32)
        };
        let (channel, value, wait) = match pc {
            Printer::Hotend { wait } => {
                let e = index(a.t, self.extruder, 'T')?;
                (AuxChannel::Hotend(e), temperature(wait)?, wait)
            }
            Printer::Bed { wait } => (AuxChannel::Bed, temperature(wait)?, wait),
            Printer::Chamber { wait } => (AuxChannel::Chamber, temperature(wait)?, wait),
            Printer::FanOn => {
                let fan = index(a.p, 0, 'P')?;
                let v = a.s.map_or(1.0, |s| (s / 255.0).clamp(0.0, 1.0)) as f32;
                (AuxChannel::Fan(fan), v, false)
            }
            Printer::FanOff => (AuxChannel::Fan(index(a.p, 0, 'P')?), 0.0, false),
            Printer::Sync => {
                self.emit(at, Command::Sync);
                return Ok(());
            }
        };
        self.emit(
            at,
            Command::Aux {
                channel,
                value,
                wait,
            },
        );
        Ok(())
    }
}

/// Laser/spindle power from an S word, grbl `$30=1000`.
fn power(s: f64) -> f32 {
    ((s / 1000.0).clamp(0.0, 1.0)) as f32
}
