//! `[axes.*]`: each axis's name, travel and limits, in x, y, z, e order.

use super::Source;
use crate::machine::{Axis, MachineError};
use crate::machine_file::MachineFile;
use motet_planner::ranges;
use motet_trajectory::{ProfileKind, MAX_AXES};

/// The machine's axes, checked, in the conventional order.
pub(super) fn axes(
    src: &Source,
    raw: &MachineFile,
    profile: ProfileKind,
) -> Result<Vec<Axis>, MachineError> {
    let m = &raw.motion;
    // Axes, in file order of their names (BTreeMap: alphabetical) would scramble
    // x, y, z: order them by the conventional letters first.
    let mut names: Vec<&String> = raw.axes.keys().collect();
    let rank = |n: &str| {
        ["x", "y", "z", "e", "a", "b", "c"]
            .iter()
            .position(|k| *k == n)
            .unwrap_or(99)
    };
    names.sort_by_key(|n| (rank(n), (*n).clone()));
    if names.is_empty() {
        return Err(src.err(0..0, "the machine has no [axes]"));
    }
    if names.len() > MAX_AXES {
        let span = raw.axes[names[MAX_AXES]].span();
        return Err(src.err(span, format!("at most {MAX_AXES} axes are supported")));
    }
    let mut axes = Vec::new();
    for name in &names {
        let a = &raw.axes[*name];
        let span = a.span();
        let a = a.get_ref();
        if !name.chars().all(|c| c.is_ascii_lowercase()) || name.is_empty() {
            return Err(src.err(
                span,
                format!("axis name `{name}` must be lower-case letters"),
            ));
        }
        let path = a.path.unwrap_or(name.as_str() != "e");
        let travel = match &a.travel {
            Some(t) => {
                let (lo, hi) = match t.get_ref()[..] {
                    [lo, hi] => (lo, hi),
                    _ => (f64::NAN, f64::NAN),
                };
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(src.err(
                        t.span(),
                        format!("axis {name}: travel must be [min, max] with min < max"),
                    ));
                }
                for v in [lo, hi] {
                    src.in_range(
                        t.span(),
                        ranges::COORDINATE,
                        format_args!("axis {name}: travel"),
                        v,
                    )?;
                }
                [lo, hi]
            }
            None if !path => [f64::NEG_INFINITY, f64::INFINITY],
            None => return Err(src.err(span, format!("axis {name}: missing field `travel`"))),
        };
        for (v, range, what) in [
            (Some(&a.max_velocity), ranges::VELOCITY, "max_velocity"),
            (
                Some(&a.max_acceleration),
                ranges::ACCELERATION,
                "max_acceleration",
            ),
            (a.max_jerk.as_ref(), ranges::JERK, "max_jerk"),
        ] {
            if let Some(v) = v {
                src.value(v, range, format_args!("axis {name}: {what}"))?;
            }
        }
        axes.push(Axis {
            name: (*name).clone(),
            travel,
            max_velocity: *a.max_velocity.get_ref(),
            max_acceleration: *a.max_acceleration.get_ref(),
            max_jerk: a.max_jerk.as_ref().map(|j| *j.get_ref()),
            path,
        });
    }
    if profile == ProfileKind::SCurve && axes.iter().all(|a| a.max_jerk.is_none()) {
        return Err(src.err(
            m.profile.span(),
            "profile = \"scurve\" needs max_jerk on at least one axis",
        ));
    }
    Ok(axes)
}
