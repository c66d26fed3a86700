//! `[actuators.*]`: which joint each drives, its element chain (steps per
//! unit), joint limits, step timing, and whether its pulses can keep up.

use super::joints::{joint_speed_bound, Joints};
use super::Source;
use crate::machine::{Actuator, Axis, Joint, MachineError};
use crate::machine_file::{ActuatorFile, ElementFile, MachineFile};
use motet_planner::ranges::{self, ValueRange};
use motet_trajectory::{Element, ElementChain, Unit};
use std::ops::Range;

/// Lines of an encoder per revolution.
const ENCODER_LINES: ValueRange = ValueRange::new(1.0, 1e6, "lines");

/// The machine's actuators (in the file's order), each joint's limits
/// narrowed by its actuators' own; every joint driven.
pub(super) fn actuators(
    src: &Source,
    raw: &MachineFile,
    j: &mut Joints,
    axes: &[Axis],
) -> Result<Vec<Actuator>, MachineError> {
    let Joints {
        joints,
        spans: joint_spans,
        names: joint_names,
        ..
    } = j;
    let mut actuators = Vec::new();
    let mut actuator_spans: Vec<Range<usize>> = Vec::new();
    let mut driven = vec![false; joints.len()];
    for (name, a) in &raw.actuators {
        let a = a.get_ref();
        let joint = joints
            .iter()
            .position(|j| j.name == *a.joint.get_ref())
            .ok_or_else(|| {
                src.err(
                    a.joint.span(),
                    format!(
                        "actuator {name}: unknown joint `{}`; this machine's joints are {}",
                        a.joint.get_ref(),
                        joint_names
                    ),
                )
            })?;
        driven[joint] = true;
        let chain = chain(src, name, a, joints[joint].unit)?;
        for (v, range, what) in [
            (&a.max_velocity, ranges::VELOCITY, "max_velocity"),
            (
                &a.max_acceleration,
                ranges::ACCELERATION,
                "max_acceleration",
            ),
        ] {
            if let Some(v) = v {
                src.value(v, range, format_args!("actuator {name}: {what}"))?;
            }
        }
        if let Some(v) = a.max_velocity.as_ref().map(|v| *v.get_ref()) {
            let j = &mut joints[joint];
            j.max_velocity = Some(j.max_velocity.map_or(v, |w| w.min(v)));
        }
        if let Some(v) = a.max_acceleration.as_ref().map(|v| *v.get_ref()) {
            let j = &mut joints[joint];
            j.max_acceleration = Some(j.max_acceleration.map_or(v, |w| w.min(v)));
        }
        let pulse_us = timing(
            src,
            name,
            &a.pulse_us,
            motet_wire::message::DEFAULT_PULSE_US,
            motet_wire::message::PULSE_US,
            "pulse_us",
        )?;
        let dir_setup_us = timing(
            src,
            name,
            &a.dir_setup_us,
            motet_wire::message::DEFAULT_DIR_SETUP_US,
            motet_wire::message::DIR_SETUP_US,
            "dir_setup_us",
        )?;
        actuator_spans.push(a.pulse_us.as_ref().map_or(a.joint.span(), |p| p.span()));
        let servo = super::servo::servo(src, name, a)?;
        actuators.push(Actuator {
            name: name.clone(),
            joint,
            steps_per_unit: chain.steps_per_unit,
            pulse_us,
            dir_setup_us,
            max_step_hz: None,
            servo,
        });
    }
    check_step_rates(src, &mut actuators, &actuator_spans, joints, axes)?;
    if let Some(j) = driven.iter().position(|d| !d) {
        return Err(src.err(
            joint_spans[j].clone(),
            format!(
                "joint `{}` has no actuator; add an [actuators.NAME] with joint = \"{}\"",
                joints[j].name, joints[j].name
            ),
        ));
    }

    Ok(actuators)
}

/// The actuator's element chain, each element in its range, and the steps
/// per unit of its joint it gives.
fn chain(
    src: &Source,
    name: &str,
    a: &ActuatorFile,
    unit: Unit,
) -> Result<ElementChain, MachineError> {
    let mut elements = Vec::new();
    for e in a.chain.get_ref() {
        check_element(src, name, e)?;
        let el = match e.get_ref() {
            ElementFile::Pulley(p) => {
                let circumference = match (p.pitch_diameter, p.teeth, p.belt_pitch) {
                    (Some(d), None, None) => std::f64::consts::PI * d,
                    (None, Some(t), Some(pitch)) => t as f64 * pitch,
                    _ => {
                        return Err(src.err(
                            e.span(),
                            format!("actuator {name}: a pulley needs either pitch_diameter, or teeth and belt_pitch"),
                        ))
                    }
                };
                Element::Pulley { circumference }
            }
            ElementFile::Leadscrew { lead } => Element::Leadscrew { lead: *lead },
            ElementFile::Gear { ratio } => Element::Gear { ratio: *ratio },
            ElementFile::Stepper { step_angle } => Element::Stepper {
                step_angle: *step_angle,
            },
            ElementFile::Microstep(n) => Element::Microstep { divisions: *n },
            ElementFile::Invert => Element::Invert,
            ElementFile::Encoder { lines } => Element::Encoder { lines: *lines },
        };
        elements.push(el);
    }
    let chain = ElementChain::new(unit, &elements).map_err(|e| {
        let span = a
            .chain
            .get_ref()
            .get(e.index)
            .map_or(a.chain.span(), |x| x.span());
        src.err(
            span,
            format!("actuator {name}: impossible element chain: {e}"),
        )
    })?;
    // Each element is in its range, yet together they can still give
    // more steps than a node follows, or fewer than make sense.
    src.in_range(
        a.chain.span(),
        ranges::STEPS_PER_UNIT,
        format_args!("actuator {name}: the chain's steps per unit of its joint"),
        chain.steps_per_unit.abs(),
    )?;
    Ok(chain)
}

/// A step timing key (`pulse_us`, `dir_setup_us`): its default when left
/// out, else within what drivers take.
fn timing(
    src: &Source,
    name: &str,
    key: &Option<toml::Spanned<f64>>,
    default: f32,
    range: std::ops::RangeInclusive<f32>,
    what: &str,
) -> Result<f32, MachineError> {
    let Some(v) = key else {
        return Ok(default);
    };
    let x = *v.get_ref();
    if !(x.is_finite() && range.contains(&(x as f32))) {
        return Err(src.err(
            v.span(),
            format!(
                "actuator {name}: {what} must be from {} to {} µs",
                range.start(),
                range.end()
            ),
        ));
    }
    Ok(x as f32)
}

/// Each actuator's top step rate from its joint's top speed: a step output
/// high for `pulse_us` and low as long between pulses steps at most
/// 1 / (2 · pulse_us), and a faster actuator would fall behind.
fn check_step_rates(
    src: &Source,
    actuators: &mut [Actuator],
    spans: &[Range<usize>],
    joints: &[Joint],
    axes: &[Axis],
) -> Result<(), MachineError> {
    for (a, span) in actuators.iter_mut().zip(spans) {
        a.max_step_hz =
            joint_speed_bound(&joints[a.joint], axes).map(|v| v * a.steps_per_unit.abs());
        let reach = 1e6 / (2.0 * a.pulse_us as f64);
        // A servo's counts are an encoder's, not pulses its node gives.
        if let Some(hz) = a.max_step_hz.filter(|&hz| hz > reach && a.servo.is_none()) {
            return Err(src.err(
                span.clone(),
                format!(
                    "actuator {}: at its joint's top speed it steps {hz:.0} times a second, but a {} µs pulse (and as long low) allows {reach:.0}: shorten pulse_us or lower max_velocity",
                    a.name, a.pulse_us
                ),
            ));
        }
    }
    Ok(())
}

/// The values of one chain element, each in its range.
fn check_element(
    src: &Source,
    actuator: &str,
    e: &toml::Spanned<ElementFile>,
) -> Result<(), MachineError> {
    let span = e.span();
    let check = |range: ValueRange, what: &str, v: f64| {
        src.in_range(
            span.clone(),
            range,
            format_args!("actuator {actuator}: {what}"),
            v,
        )
        .map(|_| ())
    };
    match e.get_ref() {
        ElementFile::Pulley(p) => {
            if let Some(d) = p.pitch_diameter {
                check(ranges::ELEMENT_MM, "pulley pitch_diameter", d)?;
            }
            if let Some(t) = p.teeth {
                check(ranges::TEETH, "pulley teeth", f64::from(t))?;
            }
            if let Some(b) = p.belt_pitch {
                check(ranges::ELEMENT_MM, "pulley belt_pitch", b)?;
            }
            Ok(())
        }
        ElementFile::Leadscrew { lead } => check(ranges::ELEMENT_MM, "leadscrew lead", *lead),
        ElementFile::Gear { ratio } => check(ranges::GEAR_RATIO, "gear ratio", *ratio),
        ElementFile::Stepper { step_angle } => {
            check(ranges::STEP_ANGLE_DEG, "stepper step_angle", *step_angle)
        }
        ElementFile::Microstep(n) => check(ranges::MICROSTEPS, "microstep", f64::from(*n)),
        ElementFile::Invert => Ok(()),
        ElementFile::Encoder { lines } => check(ENCODER_LINES, "encoder lines", f64::from(*lines)),
    }
}
