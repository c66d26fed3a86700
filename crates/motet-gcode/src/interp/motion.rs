//! Straight moves (G0/G1, G53) and the feed and target of a motion line.

use motet_planner::{Command, Move, MoveKind, SourceError};
use motet_trajectory::{Point, MAX_AXES};

use super::Interp;
use crate::block::Words;
use crate::codes::{Motion, SLOT_E};

impl Interp {
    pub(super) fn motion(&mut self, w: &Words, machine_coords: bool) -> Result<(), SourceError> {
        let [i, j, k] = w.ijk;
        let arc_words = i.is_some() || j.is_some() || k.is_some() || w.r.is_some();
        let explicit = w.motion.map(|(_, at)| at);
        // Axis words left over by a skipped unknown code belong to it.
        if w.unknown_g && explicit.is_none() {
            return Ok(());
        }
        let Some(motion) = self.motion else {
            if let Some(at) = w.first_axis_at() {
                return Err(self.error(at, "axis words without a motion mode (no G0/G1/G2/G3 yet)"));
            }
            return self.check_arc_words_unused(w, false);
        };
        let at = explicit.or(w.first_axis_at()).unwrap_or(0);
        match motion {
            Motion::Rapid | Motion::Linear => {
                self.check_arc_words_unused(w, w.unknown_g)?;
                if !w.any_axis() {
                    return Ok(());
                }
                let target = self.axis_target(w, machine_coords, false)?;
                if motion == Motion::Rapid {
                    self.rapid_to(at, target);
                    return Ok(());
                }
                let feed = if self.inverse_time {
                    let f = self.inverse_f(w, motion, at)?;
                    if target == self.machine {
                        return Ok(());
                    }
                    let len = self.move_length(&self.machine, &target);
                    self.inverse_feed(len, f, at)?
                } else {
                    self.need_feed(motion, at)?
                };
                if target != self.machine {
                    self.per_speed_sync(at, Some(feed));
                    self.machine = target;
                    self.emit(
                        at,
                        Command::Move(Move {
                            target,
                            feed,
                            kind: MoveKind::Feed,
                        }),
                    );
                }
                Ok(())
            }
            Motion::Cw | Motion::Ccw => {
                if !w.any_axis() && !arc_words {
                    return Ok(());
                }
                if machine_coords {
                    return Err(self.error(at, "G53 needs G0 or G1"));
                }
                let feed = if self.inverse_time {
                    None
                } else {
                    Some(self.need_feed(motion, at)?)
                };
                self.arc(w, motion, at, feed)
            }
        }
    }

    pub(super) fn need_feed(&self, motion: Motion, at: usize) -> Result<f64, SourceError> {
        self.feed.ok_or_else(|| {
            self.error(
                at,
                format!("{} without a feed rate (no F word yet)", motion.name()),
            )
        })
    }

    /// The inverse-time F of a G93 motion line.
    pub(super) fn inverse_f(
        &self,
        w: &Words,
        motion: Motion,
        at: usize,
    ) -> Result<f64, SourceError> {
        match w.f {
            Some(p) => self.value(p, 'F'),
            None => Err(self.error(
                at,
                format!(
                    "{} in inverse time mode (G93) needs an F word on its line",
                    motion.name()
                ),
            )),
        }
    }

    pub(super) fn inverse_feed(&self, length: f64, f: f64, at: usize) -> Result<f64, SourceError> {
        let feed = length * f / 60.0;
        if !(feed.is_finite() && feed > 0.0) {
            return Err(self.error(at, "inverse time feed is out of range"));
        }
        Ok(feed)
    }

    pub(super) fn rapid_to(&mut self, at: usize, target: Point) {
        if target != self.machine {
            self.machine = target;
            self.emit(
                at,
                Command::Move(Move {
                    target,
                    feed: f64::INFINITY,
                    kind: MoveKind::Rapid,
                }),
            );
        }
    }

    /// Machine target from the line's axis words. `machine_coords`: G53.
    /// `skip_bare`: letters without a number keep their position (G28 X).
    pub(super) fn axis_target(
        &self,
        w: &Words,
        machine_coords: bool,
        skip_bare: bool,
    ) -> Result<Point, SourceError> {
        let mut t = self.machine;
        for (slot, p) in w.axes.iter().enumerate() {
            if let (Some(p), Some(i)) = (*p, self.letter_axis[slot]) {
                if skip_bare && p.value.is_none() {
                    continue;
                }
                let v = self.axis_value(p, slot)?;
                let rel = if slot == SLOT_E {
                    self.e_relative
                } else {
                    self.relative
                };
                let m = if machine_coords {
                    v
                } else if rel {
                    self.machine[i] + v
                } else {
                    v + self.offset[i]
                };
                if !m.is_finite() {
                    return Err(self.error(p.at, "coordinate out of range"));
                }
                t[i] = m;
            }
        }
        Ok(t)
    }

    /// Length of a move as the planner measures it.
    pub(super) fn move_length(&self, a: &Point, b: &Point) -> f64 {
        let mut path = 0.0;
        let mut all = 0.0;
        for i in 0..MAX_AXES {
            let d = b[i] - a[i];
            all += d * d;
            if self.path[i] {
                path += d * d;
            }
        }
        let path = path.sqrt();
        if path > 1e-9 {
            path
        } else {
            all.sqrt()
        }
    }
}
