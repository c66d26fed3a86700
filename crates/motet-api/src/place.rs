//! A [`Placement`] carried out on a drawing's commands: the transform it
//! asks for (rotation, uniform scale, translation: shapes keep their
//! proportions), applied to every move's x and y, checked against the
//! travel.

use crate::placement::{Placed, Placement, PlacementError, PLACEMENT_TOLERANCE_MM};
use motet_host::{Clamps, Machine};
use motet_planner::{Command, Located};

/// The machine's x/y travel, where drawings are placed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Area {
    /// Indices of the x and y axes.
    pub(crate) axes: [usize; 2],
    /// `[min, max]` of x, then of y, mm.
    pub(crate) travel: [[f64; 2]; 2],
}

impl Area {
    /// The x/y travel of `machine`.
    pub(crate) fn of(machine: &Machine) -> Result<Area, PlacementError> {
        let mut axes = [0; 2];
        let mut travel = [[0.0; 2]; 2];
        for (k, name) in ["x", "y"].into_iter().enumerate() {
            let i = machine
                .axis(name)
                .ok_or_else(|| PlacementError::NoArea(format!("has no {name} axis")))?;
            let t = machine.axes[i].travel;
            if !(t[0].is_finite() && t[1].is_finite() && t[0] <= t[1]) {
                return Err(PlacementError::NoArea(format!(
                    "has {name} travel {}..{}",
                    t[0], t[1]
                )));
            }
            axes[k] = i;
            travel[k] = t;
        }
        Ok(Area { axes, travel })
    }

    fn size(&self) -> [f64; 2] {
        self.travel.map(|t| t[1] - t[0])
    }

    fn centre(&self) -> [f64; 2] {
        self.travel.map(|t| (t[0] + t[1]) / 2.0)
    }
}

/// `p ↦ scale · R(p − centre) + shift`, R the rotation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Transform {
    centre: [f64; 2],
    cos: f64,
    sin: f64,
    pub(crate) scale: f64,
    shift: [f64; 2],
}

impl Transform {
    pub(crate) fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let [dx, dy] = [p[0] - self.centre[0], p[1] - self.centre[1]];
        [
            self.scale * (self.cos * dx - self.sin * dy) + self.shift[0],
            self.scale * (self.sin * dx + self.cos * dy) + self.shift[1],
        ]
    }

    /// The point that [`Transform::apply`] takes to `q`.
    pub(crate) fn inverse(&self, q: [f64; 2]) -> [f64; 2] {
        let dx = (q[0] - self.shift[0]) / self.scale;
        let dy = (q[1] - self.shift[1]) / self.scale;
        [
            self.cos * dx + self.sin * dy + self.centre[0],
            -self.sin * dx + self.cos * dy + self.centre[1],
        ]
    }
}

/// Cosine and sine of `deg`, exact for quarter turns (so that a drawing
/// turned by 90° keeps its straight lines straight to the last bit).
fn cos_sin(deg: f64) -> (f64, f64) {
    let d = deg.rem_euclid(360.0);
    if d == 0.0 {
        (1.0, 0.0)
    } else if d == 90.0 {
        (0.0, 1.0)
    } else if d == 180.0 {
        (-1.0, 0.0)
    } else if d == 270.0 {
        (0.0, -1.0)
    } else {
        let (s, c) = d.to_radians().sin_cos();
        (c, s)
    }
}

/// x/y of every move's target.
fn points<'a>(
    commands: &'a [Located<Command>],
    area: &'a Area,
) -> impl Iterator<Item = [f64; 2]> + 'a {
    let [xi, yi] = area.axes;
    commands.iter().filter_map(move |c| match &c.item {
        Command::Move(m) => Some([m.target[xi], m.target[yi]]),
        _ => None,
    })
}

/// Least and greatest x, y; `None` without points.
fn bounds(pts: impl Iterator<Item = [f64; 2]>) -> Option<[[f64; 2]; 2]> {
    pts.fold(None, |b, p| {
        let [lo, hi] = b.unwrap_or([p, p]);
        Some([
            [lo[0].min(p[0]), lo[1].min(p[1])],
            [hi[0].max(p[0]), hi[1].max(p[1])],
        ])
    })
}

/// The transform `placement` (already checked) asks for on this drawing;
/// `None` for a drawing without moves (nothing to place).
pub(crate) fn plan(
    placement: &Placement,
    commands: &[Located<Command>],
    area: &Area,
) -> Result<Option<Transform>, PlacementError> {
    let Some([lo, hi]) = bounds(points(commands, area)) else {
        return Ok(None);
    };
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let (cos, sin) = cos_sin(placement.rotate_deg);
    let turned = Transform {
        centre,
        cos,
        sin,
        scale: 1.0,
        shift: [0.0; 2],
    };
    // The rotated drawing's own box, about the origin.
    let [qlo, qhi] = bounds(points(commands, area).map(|p| turned.apply(p))).unwrap_or([lo, hi]);
    let scale = match placement.fit_margin_mm {
        Some(margin) => fit_scale(margin, [qhi[0] - qlo[0], qhi[1] - qlo[1]], area)?,
        None => placement.scale.unwrap_or(1.0),
    };
    // Where the placed box's lower-left corner goes.
    let corner = match (placement.fit_margin_mm, placement.origin) {
        (Some(_), _) => {
            let c = area.centre();
            [
                c[0] - scale * (qhi[0] - qlo[0]) / 2.0,
                c[1] - scale * (qhi[1] - qlo[1]) / 2.0,
            ]
        }
        (None, Some(o)) => o,
        (None, None) => lo,
    };
    Ok(Some(Transform {
        scale,
        shift: [corner[0] - scale * qlo[0], corner[1] - scale * qlo[1]],
        ..turned
    }))
}

/// The largest factor that fits a box of `size` into the travel less
/// `margin` on every side.
fn fit_scale(margin: f64, size: [f64; 2], area: &Area) -> Result<f64, PlacementError> {
    let travel = area.size();
    let room = travel.map(|t| t - 2.0 * margin);
    if !(room[0] > 0.0 && room[1] > 0.0) {
        return Err(PlacementError::MarginTooLarge {
            margin_mm: margin,
            width_mm: travel[0],
            height_mm: travel[1],
        });
    }
    // A straight line has no height: only its width limits it.
    let scale = (0..2)
        .filter(|&k| size[k] > 0.0)
        .map(|k| room[k] / size[k])
        .fold(f64::INFINITY, f64::min);
    if scale.is_finite() {
        Ok(scale)
    } else {
        Err(PlacementError::NothingToFit)
    }
}

/// Moves every move's x and y by `t`, then checks the placed drawing
/// against the travel: a point beyond it by at most
/// [`PLACEMENT_TOLERANCE_MM`] is put on its edge and counted, farther is an
/// error.
pub(crate) fn apply(
    placement: &Placement,
    t: &Transform,
    commands: &mut [Located<Command>],
    area: &Area,
) -> Result<Placed, PlacementError> {
    let [xi, yi] = area.axes;
    for c in commands.iter_mut() {
        if let Command::Move(m) = &mut c.item {
            [m.target[xi], m.target[yi]] = t.apply([m.target[xi], m.target[yi]]);
        }
    }
    let [lo, hi] = bounds(points(commands, area)).unwrap_or_default();
    for (k, axis) in ["x", "y"].into_iter().enumerate() {
        let [min, max] = area.travel[k];
        if !(lo[k] >= min - PLACEMENT_TOLERANCE_MM && hi[k] <= max + PLACEMENT_TOLERANCE_MM) {
            return Err(PlacementError::Beyond {
                axis,
                lo: lo[k],
                hi: hi[k],
                min,
                max,
                hint: "use --fit, a smaller --scale or another --origin",
            });
        }
    }
    let mut clamps = Clamps::default();
    for c in commands.iter_mut() {
        if let Command::Move(m) = &mut c.item {
            let mut beyond: f64 = 0.0;
            for (k, i) in [xi, yi].into_iter().enumerate() {
                let [min, max] = area.travel[k];
                let v = m.target[i];
                beyond = beyond.max(min - v).max(v - max);
                m.target[i] = v.clamp(min, max);
            }
            if beyond > 0.0 {
                clamps.moves += 1;
                clamps.max_mm = clamps.max_mm.max(beyond);
            }
        }
    }
    let clip = |p: [f64; 2]| [0, 1].map(|k| p[k].clamp(area.travel[k][0], area.travel[k][1]));
    Ok(Placed {
        scale: t.scale,
        rotate_deg: placement.rotate_deg,
        min: clip(lo),
        max: clip(hi),
        clamps,
    })
}
