//! Heaters a node drives (`[nodes.NAME] heaters = [...]`): the loop, the
//! thermal model and the runaway watch as the machine file gives them,
//! their defaults, and what the host sends and says about them.
//!
//! The defaults are derived, not guessed: each channel kind has a model
//! of a common heater (a 40 W cartridge in an aluminium block, a 220 W
//! bed), and the gains come from that model by Ziegler–Nichols' reaction
//! curve ([`reaction_curve_gains`]); the runaway watch's window and margin
//! from the model's heating rate and sensor lag ([`default_watch`]).

use crate::machine::Machine;
use motet_planner::AuxChannel;
use motet_wire::control::{FaultKind, SampleSource};
use motet_wire::heater::{
    HeaterConfig, HeaterGains, ReadyRule, RunawayWatch, ThermalModel, OVER_MAX_C,
};
use motet_wire::HostMessage;

/// Event tracks from here on are heaters' (the machine's heater `i` on
/// track `HEATER_TRACK_BASE + i`); tools take the tracks below.
pub const HEATER_TRACK_BASE: u8 = 128;

/// A node's heater `i` drives its board's output `HEATER_DRIVE_BASE + i`:
/// past the step and servo channels (`motet_node::MAX_CHANNELS`).
pub const HEATER_DRIVE_BASE: u8 = 8;

/// Loop rate when the file gives none, Hz.
pub const DEFAULT_RATE_HZ: f64 = 10.0;

/// Samples a second the host asks of each heater, for its plot.
pub const SAMPLES_PER_S: f64 = 2.0;

/// A heater as a lumped heat capacity: the runaway watch's model on the
/// node, and the simulator's plant (which adds the part-cooling fan, the
/// sensor's lag and noise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThermalPlant {
    /// W at full power.
    pub power_w: f64,
    /// J/K.
    pub capacity_j_per_k: f64,
    /// W/K to the room.
    pub loss_w_per_k: f64,
    /// W/K more with the part-cooling fan (fan 0) at full speed.
    pub fan_loss_w_per_k: f64,
    /// s the sensor lags the heated block (a first-order lag).
    pub sensor_lag_s: f64,
    /// °C.
    pub ambient_c: f64,
    /// °C of noise on each reading (simulator only).
    pub noise_c: f64,
}

impl ThermalPlant {
    /// The plant of a common heater on `channel`: a hot end's 40 W
    /// cartridge in an aluminium block with its nozzle (13 J/K, 0.07 W/K
    /// to the room, a part-cooling fan adding 0.05 W/K, a thermistor 2 s
    /// behind), a 220 W bed under a steel sheet (600 J/K, 1.8 W/K, sensor
    /// 4 s behind), a 300 W chamber.
    pub fn default_for(channel: AuxChannel) -> ThermalPlant {
        let base = ThermalPlant {
            power_w: 40.0,
            capacity_j_per_k: 13.0,
            loss_w_per_k: 0.07,
            fan_loss_w_per_k: 0.05,
            sensor_lag_s: 2.0,
            ambient_c: crate::heater::AMBIENT_C,
            noise_c: 0.05,
        };
        match channel {
            AuxChannel::Bed => ThermalPlant {
                power_w: 220.0,
                capacity_j_per_k: 600.0,
                loss_w_per_k: 1.8,
                fan_loss_w_per_k: 0.0,
                sensor_lag_s: 4.0,
                ..base
            },
            AuxChannel::Chamber => ThermalPlant {
                power_w: 300.0,
                capacity_j_per_k: 20_000.0,
                loss_w_per_k: 5.0,
                fan_loss_w_per_k: 0.0,
                sensor_lag_s: 10.0,
                ..base
            },
            _ => base,
        }
    }

    /// As the node's watch and feed-forward see it (no fan, no lag).
    pub fn model(&self) -> ThermalModel {
        ThermalModel {
            heat_rate: (self.power_w / self.capacity_j_per_k) as f32,
            loss: (self.loss_w_per_k / self.capacity_j_per_k) as f32,
            ambient_c: self.ambient_c as f32,
        }
    }

    /// Where full power holds it with the fan off, °C.
    pub fn full_power_c(&self) -> f64 {
        self.ambient_c + self.power_w / self.loss_w_per_k
    }
}

/// A fault the simulator injects into a heater.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeaterFaultKind {
    /// Its power no longer reaches the block (a cut wire, a dead MOSFET).
    Disconnected,
    /// Its sensor gives no reading (an unplugged thermistor).
    SensorLost,
    /// Its thermistor fell out of the block: it reads the air beside it.
    ThermistorOff,
}

impl HeaterFaultKind {
    /// By the name the machine file and `--heater-fault` use.
    pub fn parse(name: &str) -> Option<HeaterFaultKind> {
        Some(match name {
            "disconnected" => HeaterFaultKind::Disconnected,
            "sensor-lost" => HeaterFaultKind::SensorLost,
            "thermistor-off" => HeaterFaultKind::ThermistorOff,
            _ => return None,
        })
    }

    /// The names [`HeaterFaultKind::parse`] takes.
    pub const NAMES: &'static str = "disconnected, sensor-lost or thermistor-off";
}

/// A fault injected at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeaterFault {
    /// What goes wrong.
    pub kind: HeaterFaultKind,
    /// When, s from the job's start.
    pub at_s: f64,
}

/// A heater a node drives: which node and which of its heaters, the loop,
/// the model, the watch.
#[derive(Clone, Debug, PartialEq)]
pub struct HeaterLoop {
    /// Index into [`Machine::nodes`].
    pub node: usize,
    /// Its index on that node (its place in the node's `heaters`).
    pub index: u8,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// The loop's gains.
    pub gains: HeaterGains,
    /// The thermal model (and simulated plant).
    pub plant: ThermalPlant,
    /// When the node trips it.
    pub watch: RunawayWatch,
    /// A reading below this is a lost sensor, °C.
    pub min_c: f64,
    /// When a wait for it is over.
    pub ready: ReadyRule,
    /// A fault the simulator injects.
    pub fault: Option<HeaterFault>,
}

/// Gains from the plant by Ziegler–Nichols' reaction curve: the step
/// response of the model through its sensor read as a first-order lag
/// with dead time (gain `K` = power/loss °C per unit power, time constant
/// `T` = capacity/loss, dead time `L` = the sensor's lag and half a tick),
/// then `kp = 1.2·T/(K·L)`, `ki = kp/(2L)`, `kd = kp·L/2`; the derivative
/// filtered at `L/4`. The integral may take up 30 % of full power: what
/// the model's holding power (fed forward in full) misses.
pub fn reaction_curve_gains(plant: &ThermalPlant, rate_hz: f64) -> HeaterGains {
    let k = plant.power_w / plant.loss_w_per_k;
    let tau = plant.capacity_j_per_k / plant.loss_w_per_k;
    let l = plant.sensor_lag_s + 0.5 / rate_hz;
    let kp = 1.2 * tau / (k * l);
    HeaterGains {
        kp: kp as f32,
        ki: (kp / (2.0 * l)) as f32,
        kd: (kp * 0.5 * l) as f32,
        integral_limit: 0.3,
        output_limit: 1.0,
        derivative_s: (0.25 * l) as f32,
        feed_forward: 1.0,
    }
}

/// The runaway watch from the plant: a window of five sensor lags (at
/// least 5 s), and a margin of twice what full power heats over one
/// sensor lag (at least 2 °C): a healthy heater's reading trails its
/// block by about that at full power, so only a heater that heats much
/// less than its model says trips. A reached target may be left by 4 °C
/// (a hot end; 2 °C otherwise) for 20 s, as Marlin's thermal protection.
pub fn default_watch(plant: &ThermalPlant, channel: AuxChannel) -> RunawayWatch {
    let rate = plant.power_w / plant.capacity_j_per_k;
    RunawayWatch {
        window_s: (5.0 * plant.sensor_lag_s).max(5.0) as f32,
        margin_c: (2.0 * rate * plant.sensor_lag_s).max(2.0) as f32,
        hysteresis_c: if matches!(channel, AuxChannel::Hotend(_)) {
            4.0
        } else {
            2.0
        },
        period_s: 20.0,
    }
}

/// The ready rule when the file gives none: within 1 °C for 10 s
/// (Marlin's `TEMP_WINDOW` and `TEMP_RESIDENCY_TIME`).
pub const DEFAULT_READY: ReadyRule = ReadyRule {
    window_c: 1.0,
    residency_s: 10.0,
};

/// The machine's heater `h` as its node is configured with it (`None`: no
/// node drives it).
pub fn config(machine: &Machine, h: usize) -> Option<HeaterConfig> {
    let heater = &machine.heaters[h];
    let l = heater.node_loop.as_ref()?;
    Some(HeaterConfig {
        heater: l.index,
        sensor: l.index,
        drive: HEATER_DRIVE_BASE + l.index,
        track: HEATER_TRACK_BASE + h as u8,
        rate_hz: l.rate_hz as f32,
        gains: l.gains,
        max_c: heater.max_c as f32,
        min_c: l.min_c as f32,
        model: l.plant.model(),
        watch: l.watch,
        ready: l.ready,
    })
}

/// Ticks a sample of a loop at `rate_hz` for [`SAMPLES_PER_S`].
pub fn sample_every(rate_hz: f64) -> u32 {
    (rate_hz / SAMPLES_PER_S).round().max(1.0) as u32
}

/// The messages that configure node `node`'s heaters and their samples.
pub fn setup(machine: &Machine, node: usize) -> Vec<HostMessage> {
    let mut out = vec![];
    for h in on_node(machine, node) {
        let (Some(c), Some(l)) = (config(machine, h), &machine.heaters[h].node_loop) else {
            continue;
        };
        out.push(HostMessage::ConfigureHeater(c));
        out.push(HostMessage::Sampling {
            source: SampleSource::Heater(c.heater),
            every: sample_every(l.rate_hz),
        });
    }
    out
}

/// The machine's heaters node `node` drives, by their index on it.
pub fn on_node(machine: &Machine, node: usize) -> Vec<usize> {
    let mut hs: Vec<(u8, usize)> = machine
        .heaters
        .iter()
        .enumerate()
        .filter_map(|(i, h)| {
            let l = h.node_loop.as_ref()?;
            (l.node == node).then_some((l.index, i))
        })
        .collect();
    hs.sort();
    hs.into_iter().map(|(_, i)| i).collect()
}

/// The machine's heater that node `node` drives as its heater `index`.
pub fn by_source(machine: &Machine, node: usize, index: u8) -> Option<usize> {
    machine.heaters.iter().position(|h| {
        h.node_loop
            .as_ref()
            .is_some_and(|l| l.node == node && l.index == index)
    })
}

/// The machine's node-driven heater on `channel`, if any.
pub fn by_channel(machine: &Machine, channel: AuxChannel) -> Option<usize> {
    machine
        .heaters
        .iter()
        .position(|h| h.channel == channel && h.node_loop.is_some())
}

/// Whether any heater is driven by a node.
pub fn any(machine: &Machine) -> bool {
    machine.heaters.iter().any(|h| h.node_loop.is_some())
}

/// A temperature a job sets on a node-driven heater, checked against the
/// heater's `max` (a node would switch a heater off at a higher target).
pub fn check_target(machine: &Machine, channel: AuxChannel, value: f32) -> Result<(), String> {
    let Some(h) = by_channel(machine, channel) else {
        return Ok(());
    };
    let heater = &machine.heaters[h];
    if value < 0.0 || value as f64 > heater.max_c || value.is_nan() {
        return Err(format!(
            "heater {}: target {} °C is outside 0 to its max {} °C",
            heater.name, value, heater.max_c
        ));
    }
    Ok(())
}

/// A heater's fault as the person reads it: the node, the heater, what it
/// saw and when (s from the trajectory's start `t0_us`), and what was done.
pub fn fault_text(
    machine: &Machine,
    node: usize,
    index: u8,
    kind: FaultKind,
    at_us: f64,
    value: f32,
    t0_us: f64,
) -> String {
    let node_name = machine.nodes.get(node).map_or("?", |n| n.name.as_str());
    let h = by_source(machine, node, index);
    let name = h.map_or_else(|| format!("{index}"), |h| machine.heaters[h].name.clone());
    let at = (at_us - t0_us) * 1e-6;
    let seen = match kind {
        FaultKind::SensorLost if value.is_nan() => {
            format!("temperature sensor gave no reading at {at:.1} s")
        }
        FaultKind::SensorLost => {
            let (min, max) = h
                .and_then(|h| {
                    let l = machine.heaters[h].node_loop.as_ref()?;
                    Some((l.min_c, machine.heaters[h].max_c + OVER_MAX_C as f64))
                })
                .unwrap_or((f64::NAN, f64::NAN));
            format!(
                "temperature sensor read {value:.1} °C at {at:.1} s, outside what a working sensor reads ({min} to {max} °C)"
            )
        }
        FaultKind::Runaway => format!(
            "thermal runaway at {at:.1} s: reading {value:.1} °C, heating less than its model says for the power applied or fallen away from its target (heater disconnected, or thermistor off its block)"
        ),
        other => format!("{other:?} at {at:.1} s"),
    };
    format!("node {node_name}: heater {name}: {seen}; every heater of the node was switched off")
}

/// Whether `m` is a heater's (its samples, its readiness, its trip),
/// which the heaters' watch takes, not the servos' and sensors'.
pub fn is_heater_message(m: &motet_wire::NodeMessage) -> bool {
    use motet_wire::NodeMessage;
    match m {
        NodeMessage::Samples(b) => matches!(b.source, motet_wire::control::SampleSource::Heater(_)),
        NodeMessage::Fault { source, .. } => {
            matches!(source, motet_wire::control::SampleSource::Heater(_))
        }
        NodeMessage::HeaterReady { .. } => true,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The derived gains are the reaction curve's for the hot end's model
    /// (K = 571 °C per unit power, T = 186 s, L = 2.05 s).
    #[test]
    fn gains_follow_the_reaction_curve() {
        let p = ThermalPlant::default_for(AuxChannel::Hotend(0));
        let g = reaction_curve_gains(&p, 10.0);
        let (k, tau, l) = (40.0 / 0.07, 13.0 / 0.07, 2.05);
        let kp = 1.2 * tau / (k * l);
        for (got, want) in [
            (g.kp as f64, kp),
            (g.ki as f64, kp / (2.0 * l)),
            (g.kd as f64, kp * l / 2.0),
        ] {
            assert!((got - want).abs() < 1e-6 * want, "{got} vs {want}");
        }
        assert!((g.kp - 0.1904).abs() < 1e-3, "{}", g.kp);
        let w = default_watch(&p, AuxChannel::Hotend(0));
        assert_eq!(w.window_s, 10.0);
        assert!((w.margin_c - 2.0 * 40.0 / 13.0 * 2.0).abs() < 1e-4);
        let bed = ThermalPlant::default_for(AuxChannel::Bed);
        assert_eq!(default_watch(&bed, AuxChannel::Bed).margin_c, 2.9333334);
        assert!(bed.full_power_c() > 120.0 && p.full_power_c() > 275.0);
    }
}
