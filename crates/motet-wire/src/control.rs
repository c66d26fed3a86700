//! Closed loops on a node: servo channels (position PID on an encoder),
//! sensor channels, their faults and the samples they send upstream.
//!
//! Units are the node's own: positions and errors in encoder counts, drive
//! in duty (−1 to 1, the sign the way the encoder counts up), time in µs of
//! the host clock (the trajectory's time). See docs/wire.md, section 3
//! ("Closed loops").

use heapless::Vec;
use motet_trajectory::JointMap;
use serde::{Deserialize, Serialize};

/// Control loop rates a node takes, Hz.
pub const LOOP_HZ: core::ops::RangeInclusive<f32> = 100.0..=50_000.0;
/// Largest |following error| limit, counts.
pub const MAX_FOLLOWING: f32 = 1.0e6;
/// Largest |counts per unit| a servo takes (as a step channel's steps).
pub const MAX_COUNTS_PER_UNIT: f64 = 1.0e6;

/// Gains of one position loop. Error `e` = set point − measured, counts;
/// output in duty. `u = kp·e + ki·∫e dt + kd·ė + kv·v + ka·a + kf·sign(v)`
/// with `v`, `a` the set point's speed (counts/s) and acceleration
/// (counts/s²), the integral term clamped to ±`integral_limit` and `u` to
/// ±`output_limit`. With a `lead` above 0, `v` and `a` are the set point's
/// mean speed and acceleration over the next `2·lead` seconds (its change
/// of value and of speed over them): the feed-forward leads the motor's
/// lag by `lead`, and a jump in the set point's speed (a corner) is fed
/// forward as the acceleration it takes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServoGains {
    /// Proportional gain, duty per count.
    pub kp: f32,
    /// Integral gain, duty per count·second.
    pub ki: f32,
    /// Derivative gain, duty per count/second (on the error's rate).
    pub kd: f32,
    /// Velocity feed-forward, duty per count/second of the set point.
    pub kv: f32,
    /// Acceleration feed-forward, duty per count/second² of the set point.
    pub ka: f32,
    /// Friction feed-forward, duty in the direction the set point moves.
    pub kf: f32,
    /// Most |integral term|, duty (0: no integral action).
    pub integral_limit: f32,
    /// Most |drive|, duty (1: full PWM).
    pub output_limit: f32,
    /// Cut-off of the low-pass filter on the error's rate, Hz (0: a
    /// quarter of the loop rate).
    pub derivative_hz: f32,
    /// How far the feed-forward looks ahead, s (0: the set point's speed
    /// and acceleration at the tick).
    pub lead: f32,
}

/// The ranges [`ServoGains::is_valid`] holds each gain to, in the order
/// of the struct's fields: what a node takes, live or at configuration.
pub const GAIN_RANGES: [(&str, f32, f32); 10] = [
    ("kp", 0.0, 1.0e3),
    ("ki", 0.0, 1.0e6),
    ("kd", 0.0, 10.0),
    ("kv", 0.0, 1.0),
    ("ka", 0.0, 0.1),
    ("kf", 0.0, 1.0),
    ("integral_limit", 0.0, 1.0),
    ("output_limit", 1.0e-3, 1.0),
    ("derivative_hz", 0.0, 25_000.0),
    ("lead", 0.0, 0.01),
];

impl ServoGains {
    /// Every gain, in the order of [`GAIN_RANGES`].
    pub fn values(&self) -> [f32; 10] {
        [
            self.kp,
            self.ki,
            self.kd,
            self.kv,
            self.ka,
            self.kf,
            self.integral_limit,
            self.output_limit,
            self.derivative_hz,
            self.lead,
        ]
    }

    /// The first gain outside its range (or not finite), by name.
    pub fn invalid(&self) -> Option<&'static str> {
        self.values()
            .iter()
            .zip(GAIN_RANGES.iter())
            .find(|(v, (_, lo, hi))| !(v.is_finite() && *v >= lo && *v <= hi))
            .map(|(_, (name, _, _))| *name)
    }

    /// Whether every gain is finite and in its range.
    pub fn is_valid(&self) -> bool {
        self.invalid().is_none()
    }
}

/// A servo channel: a joint followed by a motor with an encoder, its
/// position loop run on the node at a fixed rate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServoConfig {
    /// The board channel id (`Board::encoder`, `Board::drive`,
    /// `Board::limit`); shares the id space of step channels.
    pub channel: u8,
    /// Which joint it follows, as a step channel's map.
    pub map: JointMap,
    /// Encoder counts per joint unit, signed (negative: the encoder counts
    /// down as the joint moves up).
    pub counts_per_unit: f64,
    /// Loop rate, Hz (within [`LOOP_HZ`]).
    pub rate_hz: f32,
    /// The loop's gains.
    pub gains: ServoGains,
    /// |Following error| beyond which the node stops driving and reports a
    /// fault, counts.
    pub following_limit: f32,
}

impl ServoConfig {
    /// Whether a node takes it (values in range; the map checked apart).
    pub fn is_valid(&self) -> bool {
        let cpu = self.counts_per_unit.abs();
        cpu.is_finite()
            && cpu > 0.0
            && cpu <= MAX_COUNTS_PER_UNIT
            && LOOP_HZ.contains(&self.rate_hz)
            && self.gains.is_valid()
            && self.following_limit.is_finite()
            && self.following_limit >= 1.0
            && self.following_limit <= MAX_FOLLOWING
            && self.map.is_valid()
    }
}

/// A sensor channel: a reading the node takes at a fixed rate
/// (`Board::sensor`), averaged over each sample's window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorConfig {
    /// The board's sensor index.
    pub sensor: u8,
    /// Readings a second (within [`LOOP_HZ`]).
    pub rate_hz: f32,
}

/// What a sample or a fault comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SampleSource {
    /// A servo channel, by board channel id.
    Servo(u8),
    /// A sensor channel, by sensor index.
    Sensor(u8),
    /// A heater loop, by heater index.
    Heater(u8),
}

/// A test a servo runs at rest, for tuning: the loop is open while it
/// runs, and the servo drives nothing once it ends (until `SetPosition`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum ServoTest {
    /// Relay feedback (Åström–Hägglund): drive ±`amplitude` by the sign of
    /// the error from where the test started, switching only once the
    /// error crosses ±`hysteresis` counts.
    Relay {
        /// Drive, duty.
        amplitude: f32,
        /// Counts.
        hysteresis: f32,
        /// How long, ms.
        duration_ms: u32,
    },
    /// A step of the drive: `duty` from the start, for `duration_ms`.
    Step {
        /// Drive, duty.
        duty: f32,
        /// How long, ms.
        duration_ms: u32,
    },
}

impl ServoTest {
    /// Whether a node runs it: drive within ±1, a duration of at most a
    /// minute, a hysteresis of at most the largest following limit.
    pub fn is_valid(&self) -> bool {
        let (duty, ms, hyst) = match *self {
            ServoTest::Relay {
                amplitude,
                hysteresis,
                duration_ms,
            } => (amplitude, duration_ms, hysteresis),
            ServoTest::Step { duty, duration_ms } => (duty, duration_ms, 0.0),
        };
        duty.is_finite()
            && duty.abs() <= 1.0
            && duty != 0.0
            && ms > 0
            && ms <= 60_000
            && hyst.is_finite()
            && (0.0..=MAX_FOLLOWING).contains(&hyst)
    }
}

/// Why a loop stopped driving.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FaultKind {
    /// |Following error| passed the servo's `following_limit` (its value:
    /// the error, counts).
    Following,
    /// A limit switch opened (tripped, or its wire broke).
    Limit,
    /// A sensor gave no reading (the encoder of a servo, the reading of a
    /// sensor or heater), or a heater's reading out of what a working
    /// sensor gives (below its `min_c`, above its `max_c` by
    /// `heater::OVER_MAX_C`; its value: the reading, NaN for none).
    SensorLost,
    /// A heater did not heat as its model says for the power applied, or
    /// fell away from a target it had reached (its value: the reading,
    /// °C). Every heater of the node is switched off.
    Runaway,
}

/// One servo sample: where the motor was at the window's end, and the
/// least and most following error over the window.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ServoSample {
    /// Counts since the sample before (the first: since the batch's base).
    pub delta: i32,
    /// Least following error over the window, 1/16 count (saturating).
    pub error_lo: i16,
    /// Most following error over the window, 1/16 count (saturating).
    pub error_hi: i16,
}

/// Most servo samples a batch holds.
pub const SERVO_SAMPLES: usize = 32;
/// Most values a batch holds.
pub const VALUE_SAMPLES: usize = 40;

/// The samples of one batch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum SampleData {
    /// A servo's: measured counts and following error.
    Servo {
        /// The count the first sample's delta is from.
        base: i64,
        /// In time order.
        samples: Vec<ServoSample, SERVO_SAMPLES>,
    },
    /// A sensor's or a heater's readings, each the mean over its window.
    Values(Vec<f32, VALUE_SAMPLES>),
}

/// Samples of one source, evenly spaced in host time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleBatch {
    /// What they come from.
    pub source: SampleSource,
    /// Host time of the first sample (its window's end), µs.
    pub t0: f64,
    /// Between samples, µs.
    pub period_us: f32,
    /// Samples lost since the batch before (the node's queue upstream was
    /// full).
    pub dropped: u16,
    /// The samples.
    pub data: SampleData,
}

impl SampleBatch {
    /// Samples it holds.
    pub fn len(&self) -> usize {
        match &self.data {
            SampleData::Servo { samples, .. } => samples.len(),
            SampleData::Values(v) => v.len(),
        }
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
