//! Closed-loop actuators and sensors of a machine: a servo's loop
//! (`[actuators.NAME.servo]`), the simulated motor and load behind it
//! (`[actuators.NAME.motor]`), and sensors (`[sensors.NAME]`).

use motet_trajectory::JointMap;
use motet_wire::control::{ServoConfig, ServoGains};

/// A servo actuator's loop: what its node runs.
#[derive(Clone, Debug, PartialEq)]
pub struct ServoSpec {
    /// Encoder lines per motor revolution (the chain's `encoder`).
    pub lines: u32,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// The loop's gains (units in docs/wire.md, "Closed loops").
    pub gains: ServoGains,
    /// |Following error| beyond which the node stops the drive, counts.
    pub following_limit: f64,
    /// The simulated motor, load and encoder (the simulator's plant).
    pub motor: MotorSpec,
}

impl ServoSpec {
    /// The node's configuration of a servo on board channel `channel`
    /// following `map` at `counts_per_unit`.
    pub fn config(&self, channel: u8, map: JointMap, counts_per_unit: f64) -> ServoConfig {
        ServoConfig {
            channel,
            map,
            counts_per_unit,
            rate_hz: self.rate_hz as f32,
            gains: self.gains,
            following_limit: self.following_limit as f32,
        }
    }
}

/// A simulated DC motor with its load, as the thesis models it: armature
/// `L di/dt = V − R i − K ω`, shaft `J dω/dt = K i − b ω − friction − load`
/// (J the rotor's inertia plus the load's through the chain), the drive's
/// duty times `supply` as V.
#[derive(Clone, Debug, PartialEq)]
pub struct MotorSpec {
    /// Armature resistance, Ω.
    pub resistance: f64,
    /// Armature inductance, H.
    pub inductance: f64,
    /// Torque (and back-EMF) constant, N·m/A (V·s/rad).
    pub torque_constant: f64,
    /// Rotor inertia, kg·m².
    pub inertia: f64,
    /// Viscous friction, N·m·s/rad.
    pub damping: f64,
    /// Coulomb friction, N·m.
    pub friction: f64,
    /// Supply voltage at full duty, V.
    pub supply: f64,
    /// The moving mass on a linear joint, kg (or, on an angle joint, the
    /// load's inertia about it, kg·m²).
    pub load: f64,
    /// A constant force on the load against the joint's positive direction,
    /// N (N·m on an angle joint): gravity on a z axis.
    pub load_force: f64,
    /// How far beyond the travel the limit switches sit, joint units.
    pub limit_margin: f64,
    /// Simulates a cut encoder cable from this many seconds of the job on.
    pub encoder_fails_s: Option<f64>,
}

impl Default for MotorSpec {
    /// A 24 V brushed DC servo motor of about 60 W, driving a 1 kg carriage.
    fn default() -> Self {
        MotorSpec {
            resistance: 1.2,
            inductance: 0.5e-3,
            torque_constant: 0.05,
            inertia: 1.5e-5,
            damping: 1e-5,
            friction: 0.004,
            supply: 24.0,
            load: 1.0,
            load_force: 0.0,
            limit_margin: 2.0,
            encoder_fails_s: None,
        }
    }
}

/// What a sensor measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorKind {
    /// The acceleration of a servo actuator's load along its joint,
    /// units/s² (the simulated plant's).
    Accelerometer,
}

/// One sensor (`[sensors.NAME]`), on the node that lists it.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorSpec {
    /// Its name in the machine file.
    pub name: String,
    /// What it measures.
    pub kind: SensorKind,
    /// The actuator it is mounted on (index into `Machine::actuators`).
    pub actuator: usize,
    /// Readings a second.
    pub rate_hz: f64,
    /// Noise on each reading, standard deviation in its unit (simulated).
    pub noise: f64,
}
