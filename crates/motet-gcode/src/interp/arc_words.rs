//! G2/G3: the arc a line's words describe (radius or centre form), flattened
//! into feed moves.

use motet_planner::{Command, Located, Move, MoveKind, SourceError};

use super::Interp;
use crate::arc::Arc;
use crate::block::{Param, Words};
use crate::codes::{Motion, AXIS_LETTERS};

impl Interp {
    /// `feed`: None in inverse time mode (taken from the line's F).
    pub(super) fn arc(
        &mut self,
        w: &Words,
        motion: Motion,
        at: usize,
        feed: Option<f64>,
    ) -> Result<(), SourceError> {
        let clockwise = motion == Motion::Cw;
        let name = motion.name();
        let plane = self.plane;
        let (sa, sb) = plane.slots();
        let (Some(x), Some(y)) = (self.letter_axis[sa], self.letter_axis[sb]) else {
            return Err(self.error(
                at,
                format!(
                    "{name} in plane {} needs axes {} and {} (axes: {})",
                    plane.name(),
                    (AXIS_LETTERS[sa] as char).to_ascii_lowercase(),
                    (AXIS_LETTERS[sb] as char).to_ascii_lowercase(),
                    self.axes_list()
                ),
            ));
        };
        let inverse = if feed.is_none() {
            Some(self.inverse_f(w, motion, at)?)
        } else {
            None
        };
        const IJK: [char; 3] = ['I', 'J', 'K'];
        let (oa, ob, on) = plane.offsets();
        let (la, lb) = (IJK[oa], IJK[ob]);
        let start = self.machine;
        let end = self.axis_target(w, false, false)?;
        let (sx, sy) = (start[x], start[y]);
        let (ex, ey) = (end[x], end[y]);
        let arc = if let Some(rp) = w.r {
            if let Some(p) = w.ijk.iter().flatten().next() {
                return Err(self.error(
                    p.at,
                    format!("{name} takes either R or {la}/{lb}, not both"),
                ));
            }
            let r = self.length_value(rp, 'R')?;
            let (dx, dy) = (ex - sx, ey - sy);
            let d2 = dx * dx + dy * dy;
            let d = d2.sqrt();
            if d == 0.0 {
                return Err(self.error(
                    rp.at,
                    format!("{name} in R form needs an end point different from the start (use {la}/{lb} for a full circle)"),
                ));
            }
            let mut h4 = 4.0 * r * r - d2;
            if h4 < 0.0 {
                if r.abs() < d / 2.0 - 1e-9 * d.max(1.0) {
                    return Err(self.error(
                        rp.at,
                        format!(
                            "{name} radius {} is smaller than half the distance to the end point ({})",
                            r.abs(),
                            d / 2.0
                        ),
                    ));
                }
                h4 = 0.0;
            }
            // grbl's construction: centre on the perpendicular bisector; the
            // sign picks the side (short arc for R > 0, long arc for R < 0).
            let mut h = -h4.sqrt() / d;
            if !clockwise {
                h = -h;
            }
            if r < 0.0 {
                h = -h;
            }
            Arc {
                start,
                end,
                center: [sx + 0.5 * (dx - dy * h), sy + 0.5 * (dy + dx * h)],
                x,
                y,
                clockwise,
                full: false,
            }
        } else {
            if let Some(p) = w.ijk[on] {
                if self.value(p, IJK[on])? != 0.0 {
                    return Err(self.error(
                        p.at,
                        format!(
                            "{} is not used by arcs in plane {} ({la}/{lb} are)",
                            IJK[on],
                            plane.name()
                        ),
                    ));
                }
            }
            if w.ijk[oa].is_none() && w.ijk[ob].is_none() {
                return Err(self.error(
                    at,
                    format!("{name} needs {la}/{lb} (centre offset) or R (radius)"),
                ));
            }
            let centre = |p: Option<Param>, letter: char, axis: usize, s: f64| {
                let v = match p {
                    Some(p) => Some(self.length_value(p, letter)?),
                    None => None,
                };
                Ok::<f64, SourceError>(if self.arc_relative {
                    s + v.unwrap_or(0.0)
                } else {
                    // G90.1: absolute program coordinates; a missing one is
                    // the start's.
                    v.map_or(s, |v| v + self.offset[axis])
                })
            };
            let cx = centre(w.ijk[oa], la, x, sx)?;
            let cy = centre(w.ijk[ob], lb, y, sy)?;
            let arc = Arc {
                start,
                end,
                center: [cx, cy],
                x,
                y,
                clockwise,
                full: (ex - sx).hypot(ey - sy) <= 1e-9 * (1.0 + sx.abs().max(sy.abs())),
            };
            let (r0, r1) = arc.radii();
            if !r0.is_finite() || r0 <= 0.0 {
                return Err(self.error(
                    at,
                    format!("{name} radius is zero (the centre is the start)"),
                ));
            }
            if (r0 - r1).abs() > 0.002f64.max(0.001 * r0) {
                return Err(self.error(
                    at,
                    format!(
                        "{name} end point is not on the arc: radius to start {r0:.4}, to end {r1:.4}"
                    ),
                ));
            }
            arc
        };
        let (r0, r1) = arc.radii();
        if !(arc.center[0].is_finite()
            && arc.center[1].is_finite()
            && r0.is_finite()
            && r1.is_finite())
        {
            return Err(self.error(at, format!("{name} arc is out of range")));
        }
        let tol = self.tolerance;
        let mut pts = core::mem::take(&mut self.scratch);
        pts.clear();
        let res = arc.flatten(tol, |p| pts.push(p));
        if let Err(m) = res {
            self.scratch = pts;
            return Err(self.error(at, m));
        }
        let feed = match (feed, inverse) {
            (Some(f), _) => f,
            (None, Some(inv)) => {
                let mut len = 0.0;
                let mut prev = start;
                for p in &pts {
                    len += self.move_length(&prev, p);
                    prev = *p;
                }
                match self.inverse_feed(len, inv, at) {
                    Ok(f) => f,
                    Err(e) => {
                        self.scratch = pts;
                        return Err(e);
                    }
                }
            }
            (None, None) => unreachable!("inverse time arcs have an F"),
        };
        self.per_speed_sync(at, Some(feed));
        let loc = self.loc(at);
        self.out.extend(pts.iter().map(|&target| Located {
            loc,
            item: Command::Move(Move {
                target,
                feed,
                kind: MoveKind::Feed,
            }),
        }));
        self.scratch = pts;
        self.machine = end;
        Ok(())
    }
}
