//! The joints: the kinematics' own (replacing x and y, or x, y and z),
//! then every other axis as a joint of its own.

use super::Source;
use crate::machine::{Axis, Joint, MachineError};
use crate::machine_file::MachineFile;
use motet_trajectory::kinematics::NO_AXIS;
use motet_trajectory::{JointMap, KinematicsKind, Unit};
use std::ops::Range;

/// The joints and where each comes from in the file.
pub(super) struct Joints {
    /// See [`crate::Machine::joints`]; limits still unset until the
    /// actuators narrow them.
    pub joints: Vec<Joint>,
    /// Where each joint comes from, for "no actuator" errors.
    pub spans: Vec<Range<usize>>,
    /// The joints' names, for "unknown joint" errors.
    pub names: String,
    /// See [`crate::Machine::kinematic_axes`].
    pub kinematic_axes: Option<[usize; 3]>,
}

/// The machine's joints given its kinematics and axes.
pub(super) fn joints(
    src: &Source,
    raw: &MachineFile,
    kinematics: KinematicsKind,
    axes: &[Axis],
) -> Result<Joints, MachineError> {
    let m = &raw.motion;
    let axis_index = |n: &str| axes.iter().position(|a| a.name == n);
    // Joints: the kinematics replaces x and y (a delta also z); every
    // other axis is its own joint.
    let replaced = kinematics.joints().len();
    let kinematic_axes = if replaced == 0 {
        None
    } else {
        let z = axis_index("z");
        match (axis_index("x"), axis_index("y"), z) {
            // A planar kinematics reads no z.
            (Some(x), Some(y), _) if replaced < 3 => Some([x, y, NO_AXIS.into()]),
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => {
                let needs = if replaced < 3 {
                    "x and y"
                } else {
                    "x, y and z"
                };
                return Err(src.err(
                    m.kinematics.span(),
                    format!("{} kinematics needs axes named {needs}", kinematics.name()),
                ));
            }
        }
    };
    let mut joints = Vec::new();
    let mut joint_spans = Vec::new();
    if let Some(axes) = kinematic_axes {
        for (j, spec) in kinematics.joints().iter().enumerate() {
            joint_spans.push(m.kinematics.span());
            let angle = spec.angle;
            joints.push(Joint {
                name: spec.name.to_string(),
                map: kinematics.joint_map(j, axes),
                unit: if angle {
                    Unit::Degree
                } else {
                    Unit::Millimetre
                },
                max_velocity: None,
                max_acceleration: None,
            });
        }
    }
    for (i, a) in axes.iter().enumerate() {
        if kinematic_axes.is_some_and(|axes| axes[..replaced].contains(&i)) {
            continue;
        }
        joint_spans.push(raw.axes[&a.name].span());
        joints.push(Joint {
            name: a.name.clone(),
            map: JointMap::axis(i),
            // A, B and C are rotary axes, in degrees (as G-code reads them).
            unit: if matches!(a.name.as_str(), "a" | "b" | "c") {
                Unit::Degree
            } else {
                Unit::Millimetre
            },
            max_velocity: None,
            max_acceleration: None,
        });
    }
    let joint_names = joints
        .iter()
        .map(|j| j.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");

    Ok(Joints {
        joints,
        spans: joint_spans,
        names: joint_names,
        kinematic_axes,
    })
}

/// The fastest a joint moves, units/s: its own limit, or what its axes'
/// limits allow (a linear joint: the sum of each axis's share; a joint
/// with a gradient bound, such as a polar radius or a delta carriage: the
/// bound times the tool's speed). A joint without one (a polar angle near
/// the centre, an arm's angles) has no bound but its own.
pub(super) fn joint_speed_bound(j: &Joint, axes: &[Axis]) -> Option<f64> {
    let v = |i: usize| axes.get(i).map_or(f64::INFINITY, |a| a.max_velocity);
    let derived = match j.map {
        JointMap::Linear { coeffs } => Some(
            coeffs
                .iter()
                .enumerate()
                .filter(|(_, c)| **c != 0.0)
                .map(|(i, c)| c.abs() * v(i))
                .sum::<f64>(),
        ),
        JointMap::Kinematic {
            kinematics,
            joint,
            axes,
        } => kinematics.gradient_bound(joint as usize).map(|g| {
            let moved = &axes[..kinematics.joints().len()];
            g * moved
                .iter()
                .map(|a| v(*a as usize).powi(2))
                .sum::<f64>()
                .sqrt()
        }),
    };
    match (j.max_velocity, derived) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
    .filter(|v| v.is_finite())
}
