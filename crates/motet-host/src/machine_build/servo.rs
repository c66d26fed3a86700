//! `[actuators.NAME.servo]`, `[actuators.NAME.motor]` and `[sensors.NAME]`:
//! a servo's loop, each value in its range, the simulated motor behind it,
//! and the sensors nodes read.

use super::Source;
use crate::machine::{Actuator, MachineError};
use crate::machine_file::{ActuatorFile, ElementFile, MachineFile, MotorFile};
use crate::servo::{MotorSpec, SensorKind, SensorSpec, ServoSpec};
use motet_planner::ranges::ValueRange;
use motet_wire::control::{ServoGains, GAIN_RANGES, LOOP_HZ, MAX_FOLLOWING};
use toml::Spanned;

/// Resistance, Ω.
const OHMS: ValueRange = ValueRange::new(1e-3, 1e3, "Ω");
/// Inductance, H.
const HENRY: ValueRange = ValueRange::new(1e-7, 1.0, "H");
/// Torque constant, N·m/A.
const TORQUE_CONSTANT: ValueRange = ValueRange::new(1e-4, 10.0, "N·m/A");
/// Rotor inertia, kg·m².
const INERTIA: ValueRange = ValueRange::new(1e-9, 10.0, "kg·m²");
/// Viscous friction, N·m·s/rad.
const DAMPING: ValueRange = ValueRange::new(0.0, 10.0, "N·m·s/rad");
/// Coulomb friction, N·m.
const FRICTION: ValueRange = ValueRange::new(0.0, 100.0, "N·m");
/// Supply, V.
const VOLTS: ValueRange = ValueRange::new(0.1, 1000.0, "V");
/// Load: mass (kg) on a linear joint, inertia (kg·m²) on an angle.
const LOAD: ValueRange = ValueRange::new(0.0, 10_000.0, "kg (kg·m² on an angle)");
/// Load force, N (N·m on an angle).
const LOAD_FORCE: ValueRange = ValueRange::new(-1e5, 1e5, "N (N·m on an angle)");
/// Limit switches beyond travel, joint units.
const LIMIT_MARGIN: ValueRange = ValueRange::new(0.0, 1e4, "units");
/// Encoder failure time, s of the job.
const FAIL_S: ValueRange = ValueRange::new(0.0, 30.0 * 86_400.0, "s");
/// Sensor noise, its unit.
const NOISE: ValueRange = ValueRange::new(0.0, 1e9, "");
/// Bytes a second a node's samples may take.
pub(super) const SAMPLE_BUDGET: ValueRange = ValueRange::new(0.0, 1e7, "B/s");
/// The default of `[nodes.NAME] sample_budget`, B/s.
pub const DEFAULT_SAMPLE_BUDGET: f64 = 400.0;

/// The servo of actuator `name`, when its chain ends in an encoder; an
/// error when only one of the chain's encoder and the `servo` table is
/// there, or a `motor` table without them.
pub(super) fn servo(
    src: &Source,
    name: &str,
    a: &ActuatorFile,
) -> Result<Option<ServoSpec>, MachineError> {
    let lines = match a.chain.get_ref().last().map(|e| e.get_ref()) {
        Some(ElementFile::Encoder { lines }) => Some(*lines),
        _ => None,
    };
    let (lines, file) = match (lines, &a.servo) {
        (None, None) => {
            if let Some(m) = &a.motor {
                return Err(src.err(
                    m.span(),
                    format!("actuator {name}: a [motor] table is a servo's; its chain ends in a stepper"),
                ));
            }
            return Ok(None);
        }
        (Some(lines), Some(f)) => (lines, f),
        (Some(_), None) => {
            return Err(src.err(
                a.chain.span(),
                format!("actuator {name}: its chain ends in an encoder, a servo's: add [actuators.{name}.servo] with the loop's gains (`motet tune` finds them)"),
            ))
        }
        (None, Some(f)) => {
            return Err(src.err(
                f.span(),
                format!("actuator {name}: a servo's chain ends in an encoder, e.g. {{ encoder = {{ lines = 1000 }} }}"),
            ))
        }
    };
    let s = file.get_ref();
    let gain = |v: &Option<Spanned<f64>>, i: usize, default: f64| -> Result<f32, MachineError> {
        let (key, lo, hi) = GAIN_RANGES[i];
        let range = ValueRange::new(lo as f64, hi as f64, "");
        src.value_or(
            v.as_ref(),
            range,
            format_args!("actuator {name}: servo {key}"),
            default,
        )
        .map(|x| x as f32)
    };
    let gains = ServoGains {
        kp: gain(&s.kp, 0, 0.0)?,
        ki: gain(&s.ki, 1, 0.0)?,
        kd: gain(&s.kd, 2, 0.0)?,
        kv: gain(&s.kv, 3, 0.0)?,
        ka: gain(&s.ka, 4, 0.0)?,
        kf: gain(&s.kf, 5, 0.0)?,
        integral_limit: gain(&s.integral_limit, 6, 0.3)?,
        output_limit: gain(&s.output_limit, 7, 1.0)?,
        derivative_hz: gain(&s.derivative_hz, 8, 0.0)?,
        lead: gain(&s.lead, 9, 0.0)?,
    };
    let rate_hz = src.value_or(
        s.rate_hz.as_ref(),
        ValueRange::new(*LOOP_HZ.start() as f64, *LOOP_HZ.end() as f64, "Hz"),
        format_args!("actuator {name}: servo rate_hz"),
        10_000.0,
    )?;
    let following_limit = src.value_or(
        s.following_limit.as_ref(),
        ValueRange::new(1.0, MAX_FOLLOWING as f64, "counts"),
        format_args!("actuator {name}: servo following_limit"),
        40.0,
    )?;
    if gains.derivative_hz as f64 > rate_hz / 2.0 {
        let span = s.derivative_hz.as_ref().map_or(file.span(), |v| v.span());
        return Err(src.err(
            span,
            format!(
                "actuator {name}: servo derivative_hz must be at most half of rate_hz ({})",
                rate_hz / 2.0
            ),
        ));
    }
    let motor = match &a.motor {
        Some(m) => motor(src, name, m.get_ref())?,
        None => MotorSpec::default(),
    };
    Ok(Some(ServoSpec {
        lines,
        rate_hz,
        gains,
        following_limit,
        motor,
    }))
}

/// The simulated motor's values, each in its range, defaults for the rest.
fn motor(src: &Source, name: &str, m: &MotorFile) -> Result<MotorSpec, MachineError> {
    let d = MotorSpec::default();
    let v = |key: &Option<Spanned<f64>>, range: ValueRange, what: &str, default: f64| {
        src.value_or(
            key.as_ref(),
            range,
            format_args!("actuator {name}: motor {what}"),
            default,
        )
    };
    Ok(MotorSpec {
        resistance: v(&m.resistance, OHMS, "resistance", d.resistance)?,
        inductance: v(&m.inductance, HENRY, "inductance", d.inductance)?,
        torque_constant: v(
            &m.torque_constant,
            TORQUE_CONSTANT,
            "torque_constant",
            d.torque_constant,
        )?,
        inertia: v(&m.inertia, INERTIA, "inertia", d.inertia)?,
        damping: v(&m.damping, DAMPING, "damping", d.damping)?,
        friction: v(&m.friction, FRICTION, "friction", d.friction)?,
        supply: v(&m.supply, VOLTS, "supply", d.supply)?,
        load: v(&m.load, LOAD, "load", d.load)?,
        load_force: v(&m.load_force, LOAD_FORCE, "load_force", d.load_force)?,
        limit_margin: v(
            &m.limit_margin,
            LIMIT_MARGIN,
            "limit_margin",
            d.limit_margin,
        )?,
        encoder_fails_s: match &m.encoder_fails_s {
            Some(x) => Some(src.value(
                x,
                FAIL_S,
                format_args!("actuator {name}: motor encoder_fails_s"),
            )?),
            None => None,
        },
    })
}

/// The machine's sensors, each on a servo actuator.
pub(super) fn sensors(
    src: &Source,
    raw: &MachineFile,
    actuators: &[Actuator],
) -> Result<Vec<SensorSpec>, MachineError> {
    let mut out = Vec::new();
    for (name, s) in &raw.sensors {
        let s = s.get_ref();
        let kind = match s.kind.get_ref().as_str() {
            "accelerometer" => SensorKind::Accelerometer,
            other => {
                return Err(src.err(
                    s.kind.span(),
                    format!("sensor {name}: unknown kind `{other}`; expected accelerometer"),
                ))
            }
        };
        let actuator = actuators
            .iter()
            .position(|a| a.name == *s.actuator.get_ref())
            .ok_or_else(|| {
                src.err(
                    s.actuator.span(),
                    format!("sensor {name}: unknown actuator `{}`", s.actuator.get_ref()),
                )
            })?;
        if actuators[actuator].servo.is_none() {
            return Err(src.err(
                s.actuator.span(),
                format!("sensor {name}: an accelerometer is simulated on a servo actuator's load; `{}` is a stepper", s.actuator.get_ref()),
            ));
        }
        let rate_hz = src.value_or(
            s.rate_hz.as_ref(),
            ValueRange::new(*LOOP_HZ.start() as f64, *LOOP_HZ.end() as f64, "Hz"),
            format_args!("sensor {name}: rate_hz"),
            1000.0,
        )?;
        let noise = src.value_or(
            s.noise.as_ref(),
            NOISE,
            format_args!("sensor {name}: noise"),
            0.0,
        )?;
        out.push(SensorSpec {
            name: name.clone(),
            kind,
            actuator,
            rate_hz,
            noise,
        });
    }
    Ok(out)
}
