//! Coordinate systems and offsets: work offsets (G54…G59, G10 L2/L20), G92,
//! homing (G28, G28.1) and firmware retraction (G10/G11 without L).

use motet_planner::{Command, Move, MoveKind, SourceError};

use super::diagnostics::WarnKey;
use super::Interp;
use crate::block::Words;
use crate::codes::SLOT_E;

impl Interp {
    pub(super) fn update_offset(&mut self) {
        let wcs = &self.wcs[self.cs];
        for ((o, w), g) in self.offset.iter_mut().zip(wcs).zip(&self.g92) {
            *o = w + g;
        }
        if self.retracted {
            if let Some(e) = self.letter_axis[SLOT_E] {
                self.offset[e] -= self.retract_length;
            }
        }
    }

    pub(super) fn home(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        // Intermediate point: the axis words that have values.
        if w.axes.iter().flatten().any(|p| p.value.is_some()) {
            let mid = self.axis_target(w, false, true)?;
            self.rapid_to(at, mid);
        }
        let mut target = self.machine;
        for (slot, &ax) in self.letter_axis.iter().enumerate() {
            let Some(i) = ax else { continue };
            let named = if w.any_axis() {
                w.axes[slot].is_some()
            } else {
                slot != SLOT_E
            };
            if named {
                target[i] = self.home[i];
                self.g92[i] = 0.0;
            }
        }
        self.update_offset();
        self.warn(WarnKey(b'G', 280), at, || {
            "G28 (home) is simulated as a rapid move to the home position".into()
        });
        self.rapid_to(at, target);
        Ok(())
    }

    pub(super) fn set_position(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        if !w.any_axis() {
            return Err(self.error(at, "G92 needs at least one axis word"));
        }
        for (slot, p) in w.axes.iter().enumerate() {
            if let (Some(p), Some(i)) = (*p, self.letter_axis[slot]) {
                let v = self.axis_value(p, slot)?;
                let rest = self.offset[i] - self.g92[i];
                let g = self.machine[i] - v - rest;
                if !g.is_finite() {
                    return Err(self.error(p.at, "coordinate out of range"));
                }
                self.g92[i] = g;
            }
        }
        self.update_offset();
        Ok(())
    }

    /// G10 L2 / L20.
    pub(super) fn set_offsets(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        let l = w.l.map(|l| self.value(l, 'L')).transpose()?;
        let l20 = match l {
            Some(2.0) => false,
            Some(20.0) => true,
            Some(v) => {
                return Err(self.error(
                    at,
                    format!("G10 L{v} is not supported (L2 and L20 set work offsets; G10 without L retracts)"),
                ))
            }
            None => unreachable!("set_offsets is only called with an L word"),
        };
        if let Some(r) = w.r {
            return Err(self.error(r.at, "G10 R (rotation) is not supported"));
        }
        let Some(p) = w.p else {
            return Err(self.error(at, "G10 L2/L20 needs P (coordinate system 0..6)"));
        };
        let pv = self.value(p, 'P')?;
        let cs = match pv {
            0.0 => self.cs,
            v if v.fract() == 0.0 && (1.0..=6.0).contains(&v) => v as usize - 1,
            _ => {
                return Err(self.error(
                    p.at,
                    format!(
                        "G10: P{pv} is not a coordinate system (P0 current, P1..P6 = G54..G59)"
                    ),
                ))
            }
        };
        for (slot, q) in w.axes.iter().enumerate() {
            if let (Some(q), Some(i)) = (*q, self.letter_axis[slot]) {
                let v = self.axis_value(q, slot)?;
                let o = if l20 {
                    let rest = self.offset[i] - self.wcs[self.cs][i] - self.g92[i];
                    self.machine[i] - self.g92[i] - rest - v
                } else {
                    v
                };
                if !o.is_finite() {
                    return Err(self.error(q.at, "coordinate out of range"));
                }
                self.wcs[cs][i] = o;
            }
        }
        self.update_offset();
        Ok(())
    }

    /// G10/G11 without L: firmware retraction.
    pub(super) fn retract(&mut self, retract: bool, at: usize) -> Result<(), SourceError> {
        let name = if retract { "G10" } else { "G11" };
        let Some(e) = self.letter_axis[SLOT_E] else {
            return Err(self.error(
                at,
                format!(
                    "{name} (firmware retraction) needs an E axis (axes: {})",
                    self.axes_list()
                ),
            ));
        };
        if self.retracted == retract {
            return Ok(());
        }
        self.retracted = retract;
        self.update_offset();
        let mut target = self.machine;
        if retract {
            target[e] -= self.retract_length;
        } else {
            target[e] += self.retract_length;
        }
        if target != self.machine {
            self.machine = target;
            self.emit(
                at,
                Command::Move(Move {
                    target,
                    feed: self.retract_speed,
                    kind: MoveKind::Feed,
                }),
            );
        }
        Ok(())
    }
}
