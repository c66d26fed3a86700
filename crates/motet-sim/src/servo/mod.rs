//! The simulated plant behind servo channels: a DC motor and its load
//! through the actuator's chain, a quadrature encoder (×4, its lines), and
//! normally-closed limit switches at the travel's ends that cut the drive.
//!
//! Closed loop means the plant answers the node as it polls: the board a
//! node polls (`Collector` in `run.rs`, [`ServoBoard`] on a networked
//! simulated node) integrates each motor up to the time of every encoder
//! read and drive change the node makes, so the loop sees the motor where
//! it is at its tick.

pub mod motor;

use motet_host::{Machine, MotorSpec, ServoSpec};
use motet_node::Board;
use motet_trajectory::{Point, Unit};
use motor::{DcMotor, MotorModel};

/// Sub-steps of the motor per loop tick.
pub const SUB_STEPS: f64 = 4.0;

/// One servo actuator's motor, encoder and switches.
#[derive(Clone, Debug)]
pub struct ServoPlant {
    motor: DcMotor,
    /// Encoder counts per radian of the motor.
    counts_per_rad: f64,
    /// Encoder counts per joint unit (signed, as the chain gives).
    counts_per_unit: f64,
    /// Joint units per radian of the motor (signed: the chain's direction).
    units_per_rad: f64,
    /// The switches' places, joint units (infinite: none).
    switches: [f64; 2],
    /// Host time from which the encoder gives nothing, µs.
    fails_at: f64,
}

impl ServoPlant {
    /// The plant of `machine`'s actuator `a` (a servo), at rest at `start`,
    /// at host time 0; `t0_us` is when the job's trajectory starts (for a
    /// simulated encoder failure).
    pub fn new(machine: &Machine, a: usize, start: &Point, t0_us: f64) -> Option<ServoPlant> {
        let act = &machine.actuators[a];
        let spec: &ServoSpec = act.servo.as_ref()?;
        let joint = &machine.joints[act.joint];
        let counts_per_rev = 4.0 * spec.lines as f64;
        let counts_per_rad = counts_per_rev / std::f64::consts::TAU;
        let units_per_rad = counts_per_rad / act.steps_per_unit;
        let m: &MotorSpec = &spec.motor;
        // The load through the chain: metres (or radians) per motor radian.
        let lever = match joint.unit {
            Unit::Degree => units_per_rad.abs().to_radians(),
            _ => units_per_rad.abs() * 1e-3,
        };
        let model = MotorModel {
            r: m.resistance,
            l: m.inductance,
            k: m.torque_constant,
            j: m.inertia + m.load * lever * lever,
            b: m.damping,
            coulomb: m.friction,
            load: m.load_force * lever * units_per_rad.signum(),
            supply: m.supply,
        };
        let value = joint.map.value(start, 0.0);
        let theta = value / units_per_rad;
        let sub_us = 1e6 / spec.rate_hz / SUB_STEPS;
        // Switches at the travel's ends, on a joint that is one axis.
        let switches = match machine.joints[act.joint].map {
            motet_trajectory::JointMap::Linear { coeffs } => {
                let axes: Vec<usize> = (0..coeffs.len()).filter(|&i| coeffs[i] != 0.0).collect();
                match axes.as_slice() {
                    [i] if coeffs[*i] == 1.0 && machine.axes[*i].travel[0].is_finite() => {
                        let t = machine.axes[*i].travel;
                        [t[0] - m.limit_margin, t[1] + m.limit_margin]
                    }
                    _ => [f64::NEG_INFINITY, f64::INFINITY],
                }
            }
            _ => [f64::NEG_INFINITY, f64::INFINITY],
        };
        Some(ServoPlant {
            motor: DcMotor::new(model, theta, 0.0, sub_us),
            counts_per_rad,
            counts_per_unit: act.steps_per_unit,
            units_per_rad,
            switches,
            fails_at: m.encoder_fails_s.map_or(f64::INFINITY, |s| t0_us + s * 1e6),
        })
    }

    /// Integrates up to host time `t`, µs.
    pub fn advance(&mut self, t: f64) {
        self.motor.advance(t);
        let open = self.limit_open();
        self.motor.set_cut(open);
    }

    /// The joint's value now, joint units.
    pub fn joint(&self) -> f64 {
        self.motor.theta() * self.units_per_rad
    }

    /// The joint's value in encoder counts now (unquantised).
    pub fn joint_counts(&self) -> f64 {
        self.joint() * self.counts_per_unit
    }

    /// The load's acceleration along the joint now, joint units/s².
    pub fn acceleration(&self) -> f64 {
        self.motor.alpha() * self.units_per_rad
    }

    /// The quadrature count now (×4 decoding: whole counts of the angle).
    pub fn count(&self) -> i64 {
        (self.motor.theta() * self.counts_per_rad).floor() as i64
    }

    /// Whether a limit switch is open.
    pub fn limit_open(&self) -> bool {
        let j = self.joint();
        j < self.switches[0] || j > self.switches[1]
    }

    /// The encoder's reading at host time `t` (integrated up to it).
    pub fn read(&mut self, t: f64) -> Option<i64> {
        self.advance(t);
        (t < self.fails_at).then(|| self.count())
    }

    /// Sets the drive from host time `t` on.
    pub fn drive(&mut self, duty: f32, t: f64) {
        self.advance(t);
        self.motor.set_duty(duty as f64);
    }

    /// The motor (its state, for tests and the tuner).
    pub fn motor(&self) -> &DcMotor {
        &self.motor
    }
}

/// A node's servo plants by board channel id, and its sensors (each the
/// channel of the servo it is mounted on, with its noise).
#[derive(Clone, Debug, Default)]
pub struct ServoPlants {
    /// By channel id; `None` for a step channel.
    pub servos: Vec<Option<ServoPlant>>,
    /// By sensor index: (the servo's channel, noise).
    pub sensors: Vec<(usize, f64)>,
    /// The noise generator's state.
    seed: u64,
}

impl ServoPlants {
    /// The plants of node `node` of `machine`, at rest at `start`.
    pub fn of_node(machine: &Machine, node: usize, start: &Point, t0_us: f64) -> ServoPlants {
        let spec = &machine.nodes[node];
        let servos = spec
            .actuators
            .iter()
            .map(|&a| ServoPlant::new(machine, a, start, t0_us))
            .collect();
        let sensors = spec
            .sensors
            .iter()
            .map(|&s| {
                let sensor = &machine.sensors[s];
                let ch = spec
                    .actuators
                    .iter()
                    .position(|&a| a == sensor.actuator)
                    .unwrap_or(usize::MAX);
                (ch, sensor.noise)
            })
            .collect();
        ServoPlants {
            servos,
            sensors,
            seed: 0x9e37_79b9_7f4a_7c15 ^ node as u64,
        }
    }

    /// One servo on channel 0 and no sensor.
    pub fn single(plant: Option<ServoPlant>) -> ServoPlants {
        ServoPlants {
            servos: vec![plant],
            sensors: Vec::new(),
            seed: 1,
        }
    }

    /// Whether the node has any servo.
    pub fn any(&self) -> bool {
        self.servos.iter().any(|s| s.is_some())
    }

    /// The plant of channel `ch`.
    pub fn get_mut(&mut self, ch: u8) -> Option<&mut ServoPlant> {
        self.servos.get_mut(ch as usize)?.as_mut()
    }

    /// Sensor `index`'s reading at host time `t`: its servo's load
    /// acceleration plus noise.
    pub fn sensor(&mut self, index: u8, t: f64) -> Option<f32> {
        let &(ch, noise) = self.sensors.get(index as usize)?;
        let a = {
            let p = self.servos.get_mut(ch)?.as_mut()?;
            p.advance(t);
            p.acceleration()
        };
        Some((a + noise * self.gaussian()) as f32)
    }

    /// A standard normal deviate (the sum of four uniforms, scaled).
    fn gaussian(&mut self) -> f64 {
        let mut sum = 0.0;
        for _ in 0..4 {
            self.seed ^= self.seed << 13;
            self.seed ^= self.seed >> 7;
            self.seed ^= self.seed << 17;
            sum += (self.seed >> 11) as f64 / (1u64 << 53) as f64;
        }
        (sum - 2.0) * 3f64.sqrt()
    }
}

/// A board of servo plants only (steps and tools go nowhere): what a
/// networked simulated node's servo channels drive.
impl Board for ServoPlants {
    fn step(&mut self, _: u8, _: bool, _: f64) {}
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
    fn encoder(&mut self, channel: u8, at_us: f64) -> Option<i64> {
        self.get_mut(channel)?.read(at_us)
    }
    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        if let Some(p) = self.get_mut(channel) {
            p.drive(duty, at_us);
        }
    }
    fn limit(&mut self, channel: u8, at_us: f64) -> bool {
        match self.get_mut(channel) {
            Some(p) => {
                p.advance(at_us);
                p.limit_open()
            }
            None => false,
        }
    }
    fn sensor(&mut self, index: u8, at_us: f64) -> Option<f32> {
        ServoPlants::sensor(self, index, at_us)
    }
}

/// The name the module docs use for it.
pub type ServoBoard = ServoPlants;
