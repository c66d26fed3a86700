//! G2/G3: the arc a line's words describe (radius or centre form), flattened
//! into feed moves.

use motet_planner::{Command, Located, Move, MoveKind, SourceError};
use motet_trajectory::Point;

use super::Interp;
use crate::arc::Arc;
use crate::block::{Param, Words};
use crate::codes::{Motion, AXIS_LETTERS};

/// Centre-offset letters, indexed as [`crate::codes::Plane::offsets`] says.
const IJK: [char; 3] = ['I', 'J', 'K'];

/// What both arc forms read: the line's words and where the arc lies.
struct ArcLine<'a> {
    w: &'a Words,
    /// G2 or G3, for messages.
    name: &'static str,
    clockwise: bool,
    /// Where the motion word (or the first axis word) is.
    at: usize,
    /// Machine axes of the plane's first and second axis.
    x: usize,
    y: usize,
    /// Indices into [`IJK`] of the plane's first, second and normal axis.
    offsets: (usize, usize, usize),
    start: Point,
    end: Point,
}

impl ArcLine<'_> {
    /// The centre-offset letters of the plane's two axes.
    fn letters(&self) -> (char, char) {
        (IJK[self.offsets.0], IJK[self.offsets.1])
    }
}

/// How an arc's feed is given.
enum ArcFeed {
    /// Units per second (G94).
    PerSecond(f64),
    /// The line's F in inverse time mode (G93): the arc takes 1/F minutes.
    InverseTime(f64),
}

impl Interp {
    /// `feed`: None in inverse time mode (taken from the line's F).
    pub(super) fn arc(
        &mut self,
        w: &Words,
        motion: Motion,
        at: usize,
        feed: Option<f64>,
    ) -> Result<(), SourceError> {
        let name = motion.name();
        let (x, y) = self.arc_axes(name, at)?;
        let feed = match feed {
            Some(f) => ArcFeed::PerSecond(f),
            None => ArcFeed::InverseTime(self.inverse_f(w, motion, at)?),
        };
        let line = ArcLine {
            w,
            name,
            clockwise: motion == Motion::Cw,
            at,
            x,
            y,
            offsets: self.plane.offsets(),
            start: self.machine,
            end: self.axis_target(w, false, false)?,
        };
        let arc = match w.r {
            Some(rp) => self.radius_form(&line, rp)?,
            None => self.centre_form(&line)?,
        };
        let (r0, r1) = arc.radii();
        if !(arc.center[0].is_finite()
            && arc.center[1].is_finite()
            && r0.is_finite()
            && r1.is_finite())
        {
            return Err(self.error(at, format!("{name} arc is out of range")));
        }
        self.emit_arc(&arc, at, feed)
    }

    /// The machine axes of the selected plane, which the machine must have.
    fn arc_axes(&self, name: &str, at: usize) -> Result<(usize, usize), SourceError> {
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
        Ok((x, y))
    }

    /// R form: the centre from the radius, end and direction.
    fn radius_form(&self, c: &ArcLine<'_>, rp: Param) -> Result<Arc, SourceError> {
        let (name, (la, lb)) = (c.name, c.letters());
        if let Some(p) = c.w.ijk.iter().flatten().next() {
            return Err(self.error(
                p.at,
                format!("{name} takes either R or {la}/{lb}, not both"),
            ));
        }
        let r = self.length_value(rp, 'R')?;
        let (sx, sy) = (c.start[c.x], c.start[c.y]);
        let (dx, dy) = (c.end[c.x] - sx, c.end[c.y] - sy);
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
        if !c.clockwise {
            h = -h;
        }
        if r < 0.0 {
            h = -h;
        }
        Ok(Arc {
            start: c.start,
            end: c.end,
            center: [sx + 0.5 * (dx - dy * h), sy + 0.5 * (dy + dx * h)],
            x: c.x,
            y: c.y,
            clockwise: c.clockwise,
            full: false,
        })
    }

    /// Centre form: offsets (G91.1) or absolute centre (G90.1); the end must
    /// lie on the circle through the start.
    fn centre_form(&self, c: &ArcLine<'_>) -> Result<Arc, SourceError> {
        let (w, name, at) = (c.w, c.name, c.at);
        let (oa, ob, on) = c.offsets;
        let (la, lb) = c.letters();
        if let Some(p) = w.ijk[on] {
            if self.value(p, IJK[on])? != 0.0 {
                return Err(self.error(
                    p.at,
                    format!(
                        "{} is not used by arcs in plane {} ({la}/{lb} are)",
                        IJK[on],
                        self.plane.name()
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
        let (sx, sy) = (c.start[c.x], c.start[c.y]);
        let (ex, ey) = (c.end[c.x], c.end[c.y]);
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
        let cx = centre(w.ijk[oa], la, c.x, sx)?;
        let cy = centre(w.ijk[ob], lb, c.y, sy)?;
        let arc = Arc {
            start: c.start,
            end: c.end,
            center: [cx, cy],
            x: c.x,
            y: c.y,
            clockwise: c.clockwise,
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
        Ok(arc)
    }

    /// Flattens `arc` into feed moves; nothing is emitted if that fails.
    fn emit_arc(&mut self, arc: &Arc, at: usize, feed: ArcFeed) -> Result<(), SourceError> {
        // The chords go into a buffer kept between arcs, so a long run of
        // arcs allocates once.
        let mut pts = core::mem::take(&mut self.scratch);
        pts.clear();
        let res = arc
            .flatten(self.tolerance, |p| pts.push(p))
            .map_err(|e| self.error(at, e.to_string()))
            .and_then(|()| match feed {
                ArcFeed::PerSecond(f) => Ok(f),
                ArcFeed::InverseTime(inv) => {
                    let mut len = 0.0;
                    let mut prev = arc.start;
                    for p in &pts {
                        len += self.move_length(&prev, p);
                        prev = *p;
                    }
                    self.inverse_feed(len, inv, at)
                }
            });
        let feed = match res {
            Ok(f) => f,
            Err(e) => {
                self.scratch = pts;
                return Err(e);
            }
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
        self.machine = arc.end;
        Ok(())
    }
}
