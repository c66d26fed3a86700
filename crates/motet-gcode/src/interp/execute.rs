//! Program flow: a block executed in the fixed order of the crate
//! documentation, whatever the order of its words.

use motet_planner::ranges;
use motet_planner::{AuxChannel, Command, SourceError};
use motet_trajectory::MAX_AXES;

use super::diagnostics::WarnKey;
use super::{Interp, ToolState};
use crate::block::Words;
use crate::codes::{Motion, NonModal, Stop};

impl Interp {
    /// Executes one collected block, in the order of the crate documentation.
    pub(super) fn execute(&mut self, w: &Words) -> Result<(), SourceError> {
        let lenient = w.unknown_g;
        // Modes first: they only change how later steps read the words.
        self.set_modes(w);
        self.feed_words(w)?;
        self.select_extruder(w);
        // S and M3/M4/M5.
        self.spindle(w, lenient)?;
        self.coolant(w);
        // Printer codes (temperatures, fans, M400).
        if let Some((pc, code, at, args)) = w.printer {
            self.printer(pc, code, at, args)?;
        }
        self.dwell(w, lenient)?;
        // Motion mode.
        if let Some((m, _)) = w.motion {
            self.motion = Some(m);
        }
        let machine_coords = self.group_zero(w, lenient)?;
        let axes_used = matches!(
            w.nonmodal,
            Some((NonModal::Home | NonModal::SetPosition, _))
        ) || (matches!(w.nonmodal, Some((NonModal::G10, _))) && w.l.is_some());
        if !axes_used {
            self.motion(w, machine_coords)?;
        }
        self.stop(w);
        Ok(())
    }

    /// Units, plane, distance modes and coordinate system.
    fn set_modes(&mut self, w: &Words) {
        if let Some((inch, _)) = w.units {
            self.inch = inch;
        }
        if let Some((p, _)) = w.plane {
            self.plane = p;
        }
        if let Some((rel, _)) = w.distance {
            self.relative = rel;
        }
        if let Some((rel, _)) = w.arc_distance {
            self.arc_relative = rel;
        }
        if let Some((rel, _)) = w.extrusion {
            self.e_relative = rel;
        }
        if let Some((cs, _)) = w.wcs {
            if cs != self.cs {
                self.cs = cs;
                self.update_offset();
            }
        }
    }

    /// G93/G94, then F (read in this line's units).
    fn feed_words(&mut self, w: &Words) -> Result<(), SourceError> {
        if let Some((inv, _)) = w.feed_mode {
            if inv != self.inverse_time {
                self.inverse_time = inv;
                self.feed = None;
            }
        }
        if let Some(p) = w.f {
            let v = self.value(p, 'F')?;
            if !(v.is_finite() && v > 0.0) {
                return Err(self.error(p.at, "feed rate must be positive"));
            }
            if self.inverse_time {
                self.in_range(p, ranges::INVERSE_TIME_F, "F (inverse time, G93)", v)?;
            } else {
                let f = v * self.length_scale() / 60.0;
                if !ranges::VELOCITY.contains(f) {
                    return Err(self.error(
                        p.at,
                        format!(
                            "F{} is a feed of {} units/s; feeds must be {}",
                            ranges::number(v),
                            ranges::number(f),
                            ranges::VELOCITY
                        ),
                    ));
                }
                self.feed = Some(f);
            }
        }
        Ok(())
    }

    /// T: the extruder temperatures apply to.
    fn select_extruder(&mut self, w: &Words) {
        if let Some((t, at)) = w.t {
            if t != 0 {
                self.warn(WarnKey(b'T', 0), at, || {
                    format!("T{t} selects extruder {t} for temperatures; moves still drive the one E axis")
                });
            }
            self.extruder = t;
        }
    }

    /// M7/M8/M9.
    fn coolant(&mut self, w: &Words) {
        if let Some((v, at)) = w.coolant {
            self.coolant_on = v != 0;
            self.emit(
                at,
                Command::Aux {
                    channel: AuxChannel::Coolant,
                    value: f32::from(v),
                    wait: false,
                },
            );
        }
    }

    /// G4, and P and L words where nothing on the line uses them.
    fn dwell(&mut self, w: &Words, lenient: bool) -> Result<(), SourceError> {
        if let Some((NonModal::Dwell, at)) = w.nonmodal {
            // With M3/M4 on the line, S is the tool's; otherwise it is seconds.
            let s = if w.spindle.is_some() { None } else { w.s };
            let seconds = match (w.p, s) {
                (Some(_), Some(s)) => {
                    return Err(
                        self.error(s.at, "G4 takes P (milliseconds) or S (seconds), not both")
                    )
                }
                (Some(p), None) => {
                    let ms = ranges::DWELL_S.scaled(1000.0, "ms");
                    let v = self.value(p, 'P')?;
                    self.in_range(p, ms, "G4 P (dwell)", v)? / 1000.0
                }
                (None, Some(s)) => {
                    let v = self.value(s, 'S')?;
                    self.in_range(s, ranges::DWELL_S, "G4 S (dwell)", v)?
                }
                (None, None) => {
                    return Err(self.error(at, "G4 needs P (milliseconds) or S (seconds)"))
                }
            };
            self.emit(at, Command::Dwell { seconds });
        } else if let (Some(p), false) = (w.p, lenient) {
            let g10 = matches!(w.nonmodal, Some((NonModal::G10, _))) && w.l.is_some();
            if !g10 {
                return Err(self.error(p.at, "P is only used with G4 (dwell) and G10 L2/L20 here"));
            }
        }
        if let (Some(l), false) = (w.l, lenient) {
            if !matches!(w.nonmodal, Some((NonModal::G10, _))) {
                return Err(self.error(l.at, "L is only used with G10"));
            }
        }
        Ok(())
    }

    /// Group 0 codes that use the axis words or change offsets. Returns
    /// whether this line's motion is in machine coordinates (G53).
    fn group_zero(&mut self, w: &Words, lenient: bool) -> Result<bool, SourceError> {
        let mut machine_coords = false;
        match w.nonmodal {
            Some((nm @ (NonModal::Home | NonModal::SetPosition), at)) => {
                self.no_motion_axes(w, nm.name(), at)?;
                self.check_arc_words_unused(w, lenient)?;
                if nm == NonModal::Home {
                    self.home(w, at)?;
                } else {
                    self.set_position(w, at)?;
                }
            }
            Some((NonModal::G10, at)) => {
                if w.l.is_some() {
                    self.no_motion_axes(w, "G10", at)?;
                    self.set_offsets(w, at)?;
                    self.check_arc_words_unused(w, lenient)?;
                } else {
                    self.check_arc_words_unused(w, lenient)?;
                    self.no_axes(w, "G10 without L (firmware retraction)")?;
                    self.retract(true, at)?;
                }
            }
            Some((NonModal::Unretract, at)) => {
                self.no_axes(w, "G11 (firmware unretraction)")?;
                self.retract(false, at)?;
            }
            Some((NonModal::SetHome, _)) => {
                self.no_axes(w, "G28.1")?;
                self.home = self.machine;
            }
            Some((NonModal::ResetPosition, _)) => {
                self.no_axes(w, "G92.1")?;
                self.g92 = [0.0; MAX_AXES];
                self.update_offset();
            }
            Some((NonModal::Machine, at)) => {
                if w.any_axis() && !matches!(self.motion, Some(Motion::Rapid | Motion::Linear)) {
                    return Err(self.error(at, "G53 needs G0 or G1"));
                }
                machine_coords = true;
            }
            _ => {}
        }
        Ok(machine_coords)
    }

    /// M0/M1 pause; M2/M30 switch the tool and coolant off and end the program.
    fn stop(&mut self, w: &Words) {
        if let Some((stop, at)) = w.stop {
            match stop {
                Stop::Pause => self.emit(at, Command::Pause { optional: false }),
                Stop::OptionalPause => self.emit(at, Command::Pause { optional: true }),
                Stop::End(_) => {
                    if self.tool_state != ToolState::Off {
                        if let Some((tool, _, _)) = self.tool {
                            self.emit(at, Command::Tool { tool, value: 0.0 });
                        }
                        self.tool_state = ToolState::Off;
                    }
                    if self.coolant_on {
                        self.coolant_on = false;
                        self.emit(
                            at,
                            Command::Aux {
                                channel: AuxChannel::Coolant,
                                value: 0.0,
                                wait: false,
                            },
                        );
                    }
                    self.ended = true;
                }
            }
        }
    }

    /// An explicit motion code with axis words next to a code that uses them.
    pub(super) fn no_motion_axes(
        &self,
        w: &Words,
        name: &str,
        at: usize,
    ) -> Result<(), SourceError> {
        if let Some((m, _)) = w.motion {
            if w.any_axis() {
                return Err(self.error(
                    at,
                    format!(
                        "{name} and {} on one line both use the axis words",
                        m.name()
                    ),
                ));
            }
        }
        Ok(())
    }

    pub(super) fn no_axes(&self, w: &Words, what: &str) -> Result<(), SourceError> {
        if w.motion.is_none() {
            if let Some(p) = w.axes.iter().flatten().next() {
                return Err(self.error(p.at, format!("{what} takes no axis words")));
            }
        }
        Ok(())
    }

    pub(super) fn check_arc_words_unused(
        &self,
        w: &Words,
        lenient: bool,
    ) -> Result<(), SourceError> {
        if lenient {
            return Ok(());
        }
        let [i, j, k] = w.ijk;
        for (p, l) in [(i, 'I'), (j, 'J'), (k, 'K'), (w.r, 'R')] {
            if let Some(p) = p {
                return Err(self.error(p.at, format!("{l} is only used with G2/G3 arcs")));
            }
        }
        Ok(())
    }
}
