//! The host's words for a node's closed loops: which actuator, sensor or
//! heater a loop's source is, and what a fault says.

use crate::machine::Machine;
use motet_wire::control::{FaultKind, SampleSource};

/// The machine's name for `source` on node `node` (index into
/// [`Machine::nodes`]): `actuator x_axis`, `sensor accel`, `heater 0`.
pub fn source_name(machine: &Machine, node: usize, source: SampleSource) -> String {
    let spec = machine.nodes.get(node);
    match source {
        SampleSource::Servo(ch) => spec
            .and_then(|n| n.actuators.get(ch as usize))
            .map(|&a| format!("actuator {}", machine.actuators[a].name))
            .unwrap_or_else(|| format!("servo channel {ch}")),
        SampleSource::Sensor(i) => spec
            .and_then(|n| n.sensors.get(i as usize))
            .map(|&s| format!("sensor {}", machine.sensors[s].name))
            .unwrap_or_else(|| format!("sensor {i}")),
        SampleSource::Heater(i) => crate::heater_loop::by_source(machine, node, i)
            .map(|h| format!("heater {}", machine.heaters[h].name))
            .unwrap_or_else(|| format!("heater {i}")),
    }
}

/// A fault as the person reads it, naming the node, the loop, the field
/// at fault and the host time (s from the trajectory's start `t0`, µs).
pub fn fault_text(
    machine: &Machine,
    node: usize,
    source: SampleSource,
    kind: FaultKind,
    at_us: f64,
    value: f32,
    t0_us: f64,
) -> String {
    // A heater's fault says what its runaway watch saw.
    if let SampleSource::Heater(i) = source {
        return crate::heater_loop::fault_text(machine, node, i, kind, at_us, value, t0_us);
    }
    let name = source_name(machine, node, source);
    let node_name = machine.nodes.get(node).map_or("?", |n| n.name.as_str());
    let at = (at_us - t0_us) * 1e-6;
    let field = match (source, kind) {
        (SampleSource::Servo(_), FaultKind::SensorLost) => "encoder",
        (_, FaultKind::SensorLost) => "reading",
        (_, FaultKind::Following) => "following error",
        (_, FaultKind::Limit) => "limit switch",
        (_, FaultKind::Runaway) => "reading",
    };
    match kind {
        FaultKind::Following => format!(
            "node {node_name}: {name}: following error {value:.1} counts beyond its limit at {at:.4} s; the drive was stopped"
        ),
        FaultKind::Limit => format!(
            "node {node_name}: {name}: {field} open at {at:.4} s (following error {value:.1} counts); the drive was stopped"
        ),
        FaultKind::SensorLost | FaultKind::Runaway => format!(
            "node {node_name}: {name}: {field} stopped reporting at {at:.4} s; the drive was stopped"
        ),
    }
}

/// Bytes a servo sample takes at most as the budget counts it (a 2-byte
/// delta and its errors take 4; a fast move's 3-byte delta 5).
pub const SERVO_SAMPLE_BYTES: f64 = 5.0;
/// Bytes of a sensor sample (an `f32`).
pub const VALUE_SAMPLE_BYTES: f64 = 4.0;
/// Bytes of a batch besides its samples, with its frame: the message's
/// header (at most 30) and the frame's 16.
pub const BATCH_BYTES: f64 = 46.0;

/// Ticks a sample of each of node `node`'s loops so that together they
/// stay within its `sample_budget`: the budget shared evenly, each source
/// sending at least one batch a second (`MAX_BATCH_AGE_US`). A source the
/// budget cannot carry gets 0 (no samples; the node still watches it).
pub fn sample_every(machine: &Machine, node: usize) -> Vec<(SampleSource, u32)> {
    let spec = &machine.nodes[node];
    let mut sources = Vec::new();
    for (ch, &a) in spec.actuators.iter().enumerate() {
        if let Some(s) = &machine.actuators[a].servo {
            sources.push((SampleSource::Servo(ch as u8), s.rate_hz, SERVO_SAMPLE_BYTES));
        }
    }
    for (i, &s) in spec.sensors.iter().enumerate() {
        let rate = machine.sensors[s].rate_hz;
        sources.push((SampleSource::Sensor(i as u8), rate, VALUE_SAMPLE_BYTES));
    }
    let share = spec.sample_budget / sources.len().max(1) as f64;
    sources
        .into_iter()
        .map(|(source, rate, bytes)| {
            // bytes / P + BATCH_BYTES ≤ share, P the sample period in s.
            let room = share - BATCH_BYTES;
            let every = if room > 0.0 {
                (bytes / room * rate).ceil().clamp(1.0, u32::MAX as f64) as u32
            } else {
                0
            };
            (source, every)
        })
        .collect()
}

/// Bytes a second node `node`'s samples take at most at the decimation
/// [`sample_every`] gives.
pub fn sample_bytes_per_s(machine: &Machine, node: usize) -> f64 {
    let spec = &machine.nodes[node];
    sample_every(machine, node)
        .iter()
        .filter(|(_, every)| *every > 0)
        .map(|&(source, every)| {
            let (rate, bytes) = match source {
                SampleSource::Servo(ch) => {
                    let a = &machine.actuators[spec.actuators[ch as usize]];
                    (
                        a.servo.as_ref().map_or(0.0, |s| s.rate_hz),
                        SERVO_SAMPLE_BYTES,
                    )
                }
                SampleSource::Sensor(i) => (
                    machine.sensors[spec.sensors[i as usize]].rate_hz,
                    VALUE_SAMPLE_BYTES,
                ),
                SampleSource::Heater(_) => (0.0, 0.0),
            };
            bytes * rate / every as f64 + BATCH_BYTES
        })
        .sum()
}

/// Node `node`'s sensor channels and the decimation of every loop's
/// samples, after its channels are configured.
pub fn setup(machine: &Machine, node: usize) -> Vec<motet_wire::HostMessage> {
    use motet_wire::control::SensorConfig;
    use motet_wire::HostMessage;
    let spec = &machine.nodes[node];
    let mut out: Vec<HostMessage> = spec
        .sensors
        .iter()
        .enumerate()
        .map(|(i, &s)| {
            HostMessage::ConfigureSensor(SensorConfig {
                sensor: i as u8,
                rate_hz: machine.sensors[s].rate_hz as f32,
            })
        })
        .collect();
    out.extend(
        sample_every(machine, node)
            .into_iter()
            .map(|(source, every)| HostMessage::Sampling { source, every }),
    );
    out
}
