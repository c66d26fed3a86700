//! Simulated heaters a node drives (for the in-process simulator and the
//! simulated network nodes alike): each a heated block (its power, heat capacity
//! and loss to the room, a hot end's raised by its part-cooling fan) read
//! through a sensor that lags it, with a little noise, and the faults a
//! test or a person injects (a disconnected heater, a sensor that drops
//! out, a thermistor fallen off its block).
//!
//! The block is integrated exactly over steps of at most 10 ms (its input
//! is constant over each: the node changes the power only at its ticks),
//! the sensor's lag toward it over the same steps. Everything is
//! deterministic: the noise comes from a generator seeded by the heater.

use crate::heater_loop::{self, HeaterFault, HeaterFaultKind, ThermalPlant, HEATER_DRIVE_BASE};
use crate::Machine;
use motet_planner::AuxChannel;

/// Longest step the block is integrated over, s.
const STEP_S: f64 = 0.01;

/// A thermistor fallen off its block reads the air beside it: this share
/// of the block's rise above the room, through a lag this many times its
/// own.
const OFF_SHARE: f64 = 0.15;
const OFF_LAG: f64 = 5.0;

/// One simulated heater.
#[derive(Clone, Debug, PartialEq)]
pub struct ThermalSim {
    plant: ThermalPlant,
    /// Whether the part-cooling fan blows on it (a hot end).
    cooled: bool,
    fault: Option<HeaterFault>,
    /// Host time it has been integrated to, µs.
    t_us: f64,
    /// The block's temperature, °C.
    block: f64,
    /// What the sensor reads before noise, °C.
    sensor: f64,
    /// Power applied, 0 to 1.
    power: f64,
    /// Fan speed, 0 to 1.
    fan: f64,
    /// Fan changes to come: (host µs, speed), in time order.
    fan_changes: std::collections::VecDeque<(f64, f64)>,
    noise: u64,
}

impl ThermalSim {
    /// A heater at room temperature, off; `cooled` when the part fan
    /// blows on it; `seed` makes its noise.
    pub fn new(plant: ThermalPlant, cooled: bool, fault: Option<HeaterFault>, seed: u64) -> Self {
        ThermalSim {
            plant,
            cooled,
            fault,
            t_us: 0.0,
            block: plant.ambient_c,
            sensor: plant.ambient_c,
            power: 0.0,
            fan: 0.0,
            fan_changes: Default::default(),
            noise: seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1,
        }
    }

    /// The block's temperature now, °C.
    pub fn block_c(&self) -> f64 {
        self.block
    }

    /// The power applied now.
    pub fn power(&self) -> f64 {
        self.power
    }

    /// Whether the injected fault of `kind` has happened by host time `t_us`.
    fn failed(&self, kind: HeaterFaultKind, t_us: f64) -> bool {
        self.fault
            .is_some_and(|f| f.kind == kind && t_us >= f.at_s * 1e6)
    }

    /// The fan is set to `speed` at host time `t_us` (at or after the
    /// changes before it).
    pub fn fan_at(&mut self, t_us: f64, speed: f64) {
        if self.cooled {
            self.fan_changes.push_back((t_us, speed.clamp(0.0, 1.0)));
        }
    }

    /// Integrates to host time `t_us` at the power applied.
    pub fn advance(&mut self, t_us: f64) {
        while self.t_us < t_us {
            let fan_next = self.fan_changes.front().map_or(f64::INFINITY, |c| c.0);
            if fan_next <= self.t_us {
                self.fan = self.fan_changes.pop_front().map_or(self.fan, |c| c.1);
                continue;
            }
            let fault_next = self
                .fault
                .map_or(f64::INFINITY, |f| f.at_s * 1e6)
                .max(self.t_us);
            let mut end = t_us.min(self.t_us + STEP_S * 1e6).min(fan_next);
            if fault_next > self.t_us {
                end = end.min(fault_next);
            }
            self.step((end - self.t_us) * 1e-6, end);
            self.t_us = end;
        }
    }

    fn step(&mut self, h: f64, end_us: f64) {
        let p = &self.plant;
        let u = if self.failed(HeaterFaultKind::Disconnected, end_us) {
            0.0
        } else {
            self.power
        };
        let loss = p.loss_w_per_k + p.fan_loss_w_per_k * self.fan;
        // Exact over the step: the block relaxes toward where this power
        // holds it, with its time constant at this loss.
        let hold = p.ambient_c + p.power_w * u / loss;
        let before = self.block;
        self.block = hold + (before - hold) * (-h * loss / p.capacity_j_per_k).exp();
        let mid = 0.5 * (before + self.block);
        let (toward, lag) = if self.failed(HeaterFaultKind::ThermistorOff, end_us) {
            (
                p.ambient_c + OFF_SHARE * (mid - p.ambient_c),
                OFF_LAG * p.sensor_lag_s.max(1.0),
            )
        } else {
            (mid, p.sensor_lag_s)
        };
        self.sensor = if lag > 0.0 {
            toward + (self.sensor - toward) * (-h / lag).exp()
        } else {
            toward
        };
    }

    /// The reading at host time `t_us`, °C; `None` once the sensor has
    /// dropped out.
    pub fn read(&mut self, t_us: f64) -> Option<f32> {
        self.advance(t_us);
        if self.failed(HeaterFaultKind::SensorLost, t_us) {
            return None;
        }
        Some((self.sensor + self.next_noise()) as f32)
    }

    /// The power from host time `t_us` on, 0 to 1.
    pub fn drive(&mut self, t_us: f64, power: f32) {
        self.advance(t_us);
        self.power = (power as f64).clamp(0.0, 1.0);
    }

    /// Noise of standard deviation `noise_c` (uniform, xorshift).
    fn next_noise(&mut self) -> f64 {
        let mut x = self.noise;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.noise = x;
        let u = (x >> 11) as f64 / (1u64 << 53) as f64;
        (u - 0.5) * 2.0 * 3f64.sqrt() * self.plant.noise_c
    }
}

/// One node's simulated heaters, by their index on it: what its board
/// reads (`Board::temperature`) and drives (`Board::drive`, from
/// [`HEATER_DRIVE_BASE`] on).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeHeat {
    sims: Vec<ThermalSim>,
    /// The heaters' indices in the machine, by their index on the node.
    heaters: Vec<usize>,
}

impl NodeHeat {
    /// Node `k`'s heaters of `machine`, cold and off.
    pub fn of_node(machine: &Machine, k: usize) -> NodeHeat {
        let heaters = heater_loop::on_node(machine, k);
        let sims = heaters
            .iter()
            .filter_map(|&h| {
                let heater = &machine.heaters[h];
                let l = heater.node_loop.as_ref()?;
                let cooled = matches!(heater.channel, AuxChannel::Hotend(_));
                Some(ThermalSim::new(l.plant, cooled, l.fault, 1 + h as u64))
            })
            .collect();
        NodeHeat { sims, heaters }
    }

    /// Whether the node drives no heater.
    pub fn is_empty(&self) -> bool {
        self.sims.is_empty()
    }

    /// Sensor `index`'s reading at host time `at_us`.
    pub fn read(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.sims.get_mut(index as usize)?.read(at_us)
    }

    /// Drive output `channel` set to `duty` at `at_us`.
    pub fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        if let Some(s) = channel
            .checked_sub(HEATER_DRIVE_BASE)
            .and_then(|i| self.sims.get_mut(i as usize))
        {
            s.drive(at_us, duty);
        }
    }

    /// The part-cooling fan (fan 0) set to `speed` at `at_us`.
    pub fn fan_at(&mut self, at_us: f64, speed: f64) {
        for s in self.sims.iter_mut() {
            s.fan_at(at_us, speed);
        }
    }

    /// The block of the machine's heater `h`, if on this node, °C.
    pub fn block_c(&self, h: usize) -> Option<f64> {
        let i = self.heaters.iter().position(|&x| x == h)?;
        Some(self.sims[i].block_c())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hotend() -> ThermalPlant {
        ThermalPlant {
            noise_c: 0.0,
            ..ThermalPlant::default_for(AuxChannel::Hotend(0))
        }
    }

    /// Full power from the room: the block follows its closed form, the
    /// sensor trails it by about the lag times the rate, and the fan's
    /// loss lowers where a power holds it.
    #[test]
    fn the_block_follows_its_closed_form() {
        let p = hotend();
        let mut s = ThermalSim::new(p, true, None, 1);
        s.drive(0.0, 1.0);
        s.advance(60e6);
        let tau = p.capacity_j_per_k / p.loss_w_per_k;
        let want = p.ambient_c + p.power_w / p.loss_w_per_k * (1.0 - (-60.0 / tau).exp());
        assert!(
            (s.block_c() - want).abs() < 1e-6,
            "{} vs {want}",
            s.block_c()
        );
        let lag = s.block_c() - s.read(60e6).unwrap() as f64;
        let rate = (p.power_w - p.loss_w_per_k * (s.block_c() - p.ambient_c)) / p.capacity_j_per_k;
        assert!(
            (lag - rate * p.sensor_lag_s).abs() < 0.1,
            "{lag} vs {}",
            rate * p.sensor_lag_s
        );
        // Holding 30 % power, with and without the fan.
        let mut still = ThermalSim::new(p, true, None, 1);
        let mut blown = ThermalSim::new(p, true, None, 1);
        blown.fan_at(0.0, 1.0);
        for x in [&mut still, &mut blown] {
            x.drive(0.0, 0.3);
            x.advance(3000e6);
        }
        let hold = |loss: f64| p.ambient_c + 0.3 * p.power_w / loss;
        assert!((still.block_c() - hold(p.loss_w_per_k)).abs() < 0.01);
        assert!((blown.block_c() - hold(p.loss_w_per_k + p.fan_loss_w_per_k)).abs() < 0.01);
    }

    #[test]
    fn faults_happen_when_injected() {
        // (fault, what 60 s at full power leaves: block, reading)
        let at = |kind| Some(HeaterFault { kind, at_s: 10.0 });
        let p = hotend();
        let mut cut = ThermalSim::new(p, false, at(HeaterFaultKind::Disconnected), 1);
        let mut lost = ThermalSim::new(p, false, at(HeaterFaultKind::SensorLost), 1);
        let mut off = ThermalSim::new(p, false, at(HeaterFaultKind::ThermistorOff), 1);
        for s in [&mut cut, &mut lost, &mut off] {
            s.drive(0.0, 1.0);
            assert!(s.read(9.9e6).is_some());
            s.advance(60e6);
        }
        assert!(
            cut.block_c() < 60.0,
            "no power after 10 s: {}",
            cut.block_c()
        );
        assert_eq!(lost.read(60e6), None);
        assert!(lost.block_c() > 150.0, "the heater heats on");
        let r = off.read(60e6).unwrap() as f64;
        assert!(
            off.block_c() > 150.0 && r < 60.0,
            "{} reads {r}",
            off.block_c()
        );
    }
}
