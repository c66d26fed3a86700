//! `[motion]`: the profile and the planner's settings, where jobs start,
//! the drawing feed and the stop horizon.

use super::Source;
use crate::machine::{Axis, MachineError, NodeSpec};
use crate::machine_file::MotionFile;
use motet_planner::ranges;
use motet_trajectory::kinematics::tool_point;
use motet_trajectory::{KinematicsKind, Point, ProfileKind, MAX_AXES};

/// The motion settings checked before the axes.
pub(super) struct Settings {
    /// `[motion] profile`; the axes need `max_jerk` for an S-curve.
    pub profile: ProfileKind,
    /// `[motion] lookahead`, in range.
    pub lookahead: usize,
}

/// The profile kind, the ranges of the motion settings, the lookahead.
pub(super) fn settings(src: &Source, m: &MotionFile) -> Result<Settings, MachineError> {
    let profile = match m.profile.get_ref().as_str() {
        "trapezoid" => ProfileKind::Trapezoid,
        "scurve" => ProfileKind::SCurve,
        other => {
            return Err(src.err(
                m.profile.span(),
                format!("unknown profile `{other}`; expected trapezoid or scurve"),
            ))
        }
    };
    for (v, range, what) in [
        (
            &m.junction_deviation,
            ranges::JUNCTION_DEVIATION_MM,
            "junction_deviation",
        ),
        (&m.tolerance, ranges::TOLERANCE_MM, "tolerance"),
        (&m.min_radius, ranges::MIN_RADIUS_MM, "min_radius"),
    ] {
        src.value(v, range, format_args!("[motion] {what}"))?;
    }
    let lookahead = ranges::LOOKAHEAD
        .check_count("[motion] lookahead", *m.lookahead.get_ref())
        .map_err(|e| src.err(m.lookahead.span(), e.to_string()))?;

    Ok(Settings { profile, lookahead })
}

/// The start point: each axis's `[motion] start` value, else 0 (or the
/// travel's low end when 0 is outside it); within travel, and within the
/// kinematics' reach.
pub(super) fn start(
    src: &Source,
    m: &MotionFile,
    axes: &[Axis],
    kinematics: KinematicsKind,
    kinematic_axes: Option<[usize; 3]>,
) -> Result<Point, MachineError> {
    let axis_index = |n: &str| axes.iter().position(|a| a.name == n);
    let replaced = kinematics.joints().len();
    let mut start = [0.0; MAX_AXES];
    for (i, a) in axes.iter().enumerate() {
        if a.travel[0] > 0.0 || a.travel[1] < 0.0 {
            start[i] = a.travel[0];
        }
    }
    for (name, v) in m.start.get_ref() {
        let i = axis_index(name).ok_or_else(|| {
            src.err(
                m.start.span(),
                format!("[motion] start: unknown axis `{name}`"),
            )
        })?;
        if !(v.is_finite() && *v >= axes[i].travel[0] && *v <= axes[i].travel[1]) {
            return Err(src.err(
                m.start.span(),
                format!("[motion] start: {name} = {v} is outside the axis's travel"),
            ));
        }
        start[i] = *v;
    }
    if let Some(axes) = kinematic_axes {
        let p = tool_point(axes.map(|a| a as u8), &start);
        if let Err(why) = kinematics.reach(p) {
            let shown: Vec<String> = p[..replaced.max(2)].iter().map(f64::to_string).collect();
            return Err(src.err(
                m.start.span(),
                format!(
                    "[motion] start ({}) is {why} of the {} kinematics; set [motion] start = {{ x = …, y = … }}",
                    shown.join(", "),
                    kinematics.name()
                ),
            ));
        }
    }
    if let (KinematicsKind::Polar(_), Some([x, y, _])) = (kinematics, kinematic_axes) {
        if start[x].hypot(start[y]) < *m.min_radius.get_ref() {
            return Err(src.err(
                m.kinematics.span(),
                format!(
                    "a polar machine cannot start within min_radius = {} mm of the centre; set [motion] start = {{ x = …, y = … }}",
                    m.min_radius.get_ref()
                ),
            ));
        }
    }
    Ok(start)
}

/// `[motion] draw_feed`, by default half the slowest path axis's speed.
pub(super) fn draw_feed(src: &Source, m: &MotionFile, axes: &[Axis]) -> Result<f64, MachineError> {
    let slowest = axes
        .iter()
        .filter(|a| a.path)
        .map(|a| a.max_velocity)
        .fold(f64::INFINITY, f64::min);
    let draw_feed = m.draw_feed.as_ref().map_or(
        if slowest.is_finite() {
            0.5 * slowest
        } else {
            10.0
        },
        |d| *d.get_ref(),
    );
    let span = m.draw_feed.as_ref().map_or(0..0, |d| d.span());
    src.in_range(span, ranges::VELOCITY, "[motion] draw_feed", draw_feed)?;

    Ok(draw_feed)
}

/// `[motion] stop_horizon`, within what the smallest node queue holds.
pub(super) fn stop_horizon(
    src: &Source,
    m: &MotionFile,
    nodes: &[NodeSpec],
) -> Result<usize, MachineError> {
    // A node holding the horizon's segments can always be given a window it
    // can stop inside; a longer horizon than the smallest queue cannot be.
    let smallest_queue = nodes.iter().map(|n| n.queue).min().unwrap_or(64);
    let horizon = *m.stop_horizon.get_ref();
    if !(0..=smallest_queue as i64).contains(&horizon) {
        return Err(src.err(
            m.stop_horizon.span(),
            format!(
                "[motion] stop_horizon must be 0 (off) to {smallest_queue} (the smallest node queue), got {horizon}"
            ),
        ));
    }
    Ok(horizon as usize)
}
