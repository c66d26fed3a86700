//! Closed loops on the node: fixed-rate ticks interleaved with the steps,
//! events and graph frames of [`Node::poll`](crate::Node::poll), in time
//! order.
//!
//! One concept a file:
//! * `pid`: one PID with feed-forward, clamps and anti-windup, for every
//!   loop (a servo's position, a heater's temperature);
//! * `ticker`: a loop's fixed-rate schedule on host time;
//! * `setpoint`: a joint's value, speed and acceleration at a tick, from
//!   the queued segments;
//! * `servo`: a servo channel (encoder, PID, drive, limit switches,
//!   following-error watch, tuning tests);
//! * `sensor`: a sensor channel (a reading at a fixed rate);
//! * `heater`: a heater channel (temperature PID, target from an event
//!   track, runaway watch against its thermal model);
//! * `samples`: decimation into samples, batches, and the queue of
//!   messages upstream (samples and faults).
//!
//! [`Control`] holds a node's loops. A new kind of loop (a heater) is one
//! more list here: a `due` time for [`Control::next_tick`], an `active`
//! test for [`Control::deadline`], a `tick` in [`Control::tick`], and its
//! samples and faults through the same [`Upstream`].

pub mod heater;
pub mod pid;
pub mod samples;
pub mod sensor;
pub mod servo;
pub mod setpoint;
pub mod ticker;

pub use heater::Heater;
pub use pid::{Pid, PidGains, PidTerms};
pub use samples::{Sampler, Upstream, MAX_BATCH_AGE_US, UPSTREAM};
pub use sensor::Sensor;
pub use servo::Servo;
pub use setpoint::{JointState, SetPoint};
pub use ticker::Ticker;

use crate::board::Board;
use heapless::{Deque, Vec};
use motet_trajectory::{Point, Segment};
use motet_wire::control::{SampleSource, SensorConfig, ServoConfig, ServoGains, ServoTest};
use motet_wire::heater::HeaterConfig;
use motet_wire::{NodeMessage, Refusal};

/// Most servo channels a node runs.
pub const MAX_SERVOS: usize = 4;
/// Most sensor channels a node runs.
pub const MAX_SENSORS: usize = 2;
/// Most heater channels a node runs.
pub const MAX_HEATERS: usize = 4;

/// A node's closed loops and what they send upstream.
#[derive(Clone, Debug, Default)]
pub struct Control {
    servos: Vec<Servo, MAX_SERVOS>,
    sensors: Vec<Sensor, MAX_SENSORS>,
    upstream: Upstream,
    heaters: Vec<Heater, MAX_HEATERS>,
    /// Drive outputs of heaters a reset forgot, switched off at the next
    /// poll.
    drives_off: Vec<u8, MAX_HEATERS>,
}

impl Control {
    /// No loops.
    pub const fn new() -> Control {
        Control {
            servos: Vec::new(),
            sensors: Vec::new(),
            upstream: Upstream::new(),
            heaters: Vec::new(),
            drives_off: Vec::new(),
        }
    }

    /// The servo channels, in the order configured.
    pub fn servos(&self) -> &[Servo] {
        &self.servos
    }

    /// Whether a servo has board channel id `channel`.
    pub fn has_servo(&self, channel: u8) -> bool {
        self.servos.iter().any(|s| s.config().channel == channel)
    }

    /// Adds (or replaces, by channel id) a servo at rest at `p`.
    pub fn configure_servo(&mut self, c: ServoConfig, p: &Point) -> Result<(), Refusal> {
        let servo = Servo::new(c, p);
        match self
            .servos
            .iter_mut()
            .find(|s| s.config().channel == c.channel)
        {
            Some(s) => *s = servo,
            None => self.servos.push(servo).map_err(|_| Refusal::BadConfig)?,
        }
        Ok(())
    }

    /// Adds (or replaces, by index) a sensor.
    pub fn configure_sensor(&mut self, c: SensorConfig) -> Result<(), Refusal> {
        let sensor = Sensor::new(c);
        match self
            .sensors
            .iter_mut()
            .find(|s| s.config().sensor == c.sensor)
        {
            Some(s) => *s = sensor,
            None => self.sensors.push(sensor).map_err(|_| Refusal::BadConfig)?,
        }
        Ok(())
    }

    fn servo_mut(&mut self, channel: u8) -> Result<&mut Servo, Refusal> {
        self.servos
            .iter_mut()
            .find(|s| s.config().channel == channel)
            .ok_or(Refusal::BadConfig)
    }

    /// New gains for servo `channel`, if they are in range.
    pub fn set_gains(&mut self, channel: u8, gains: ServoGains) -> Result<(), Refusal> {
        if !gains.is_valid() {
            return Err(Refusal::BadConfig);
        }
        self.servo_mut(channel)?.set_gains(gains);
        Ok(())
    }

    /// A tuning test on servo `channel`.
    pub fn start_test(&mut self, channel: u8, test: ServoTest) -> Result<(), Refusal> {
        if !test.is_valid() {
            return Err(Refusal::BadConfig);
        }
        self.servo_mut(channel)?.start_test(test);
        Ok(())
    }

    /// One sample of `source` every `every` of its ticks (0: none).
    pub fn set_sampling(&mut self, source: SampleSource, every: u32) -> Result<(), Refusal> {
        let up = &mut self.upstream;
        let sampler = match source {
            SampleSource::Servo(ch) => self
                .servos
                .iter_mut()
                .find(|s| s.config().channel == ch)
                .map(|s| s.sampler_mut()),
            SampleSource::Sensor(i) => self
                .sensors
                .iter_mut()
                .find(|s| s.config().sensor == i)
                .map(|s| s.sampler_mut()),
            SampleSource::Heater(i) => self
                .heaters
                .iter_mut()
                .find(|h| h.config().heater == i)
                .map(|h| h.sampler_mut()),
        };
        sampler.ok_or(Refusal::BadConfig)?.set_every(every, up);
        Ok(())
    }

    /// The machine is at rest at `p`.
    pub fn set_position(&mut self, p: &Point) {
        for s in self.servos.iter_mut() {
            s.set_position(p);
        }
    }

    /// The next tick of any loop (infinite: no loop), with the node run
    /// up to `now`.
    pub fn next_tick(&self, now: f64) -> f64 {
        let mut t = f64::INFINITY;
        for s in self.servos.iter() {
            t = t.min(s.due(now));
        }
        for s in self.sensors.iter() {
            t = t.min(s.due(now));
        }
        for h in self.heaters.iter() {
            t = t.min(h.due(now));
        }
        t
    }

    /// The next tick a caller must poll for: of a loop that is moving,
    /// testing or settling (`moving`: segments are queued). A settled loop
    /// still ticks whenever the node is polled past its ticks.
    pub fn deadline(&self, now: f64, moving: bool) -> Option<f64> {
        let mut t = f64::INFINITY;
        for s in self.servos.iter().filter(|s| s.active(moving)) {
            t = t.min(s.due(now));
        }
        for s in self.sensors.iter().filter(|s| s.active(moving)) {
            t = t.min(s.due(now));
        }
        for h in self.heaters.iter().filter(|h| h.active(moving)) {
            t = t.min(h.due(now));
        }
        (t != f64::INFINITY).then_some(t)
    }

    /// Runs every loop's tick due at `t` (the node's time), on the first
    /// `end` of `segments`; true when one faulted.
    pub fn tick<B: Board, const Q: usize>(
        &mut self,
        t: f64,
        now: f64,
        segments: &Deque<Segment, Q>,
        end: usize,
        board: &mut B,
    ) -> bool {
        let mut faulted = false;
        for s in self.servos.iter_mut() {
            if s.due(now) <= t {
                faulted |= s.tick(t, segments, end, board, &mut self.upstream);
            }
        }
        for s in self.sensors.iter_mut() {
            if s.due(now) <= t {
                faulted |= s.tick(t, board, &mut self.upstream);
            }
        }
        let mut tripped = false;
        for h in self.heaters.iter_mut() {
            if h.due(now) <= t {
                tripped |= h.tick(t, board, &mut self.upstream);
            }
        }
        if tripped {
            // One heater ran away or lost its sensor: every heater of the
            // node goes off with it.
            for h in self.heaters.iter_mut() {
                h.halt(t, board, &mut self.upstream);
            }
        }
        faulted || tripped
    }

    /// Segments from the queue's head every servo is done with
    /// (`usize::MAX`: no servo).
    pub fn segments_done(&self) -> usize {
        self.servos
            .iter()
            .map(|s| s.segments_done())
            .min()
            .unwrap_or(usize::MAX)
    }

    /// The queue dropped `n` segments from its head.
    pub fn drop_segments(&mut self, n: usize) {
        for s in self.servos.iter_mut() {
            s.drop_segments(n);
        }
    }

    /// The oldest message waiting to go upstream.
    pub fn take_upstream(&mut self) -> Option<NodeMessage> {
        self.upstream.take()
    }

    /// Messages waiting to go upstream.
    pub fn upstream_len(&self) -> usize {
        self.upstream.len()
    }
}

impl Control {
    /// The heater channels, in the order configured.
    pub fn heaters(&self) -> &[Heater] {
        &self.heaters
    }

    /// Whether `drive` is a heater's drive output.
    pub fn has_heater_drive(&self, drive: u8) -> bool {
        self.heaters.iter().any(|h| h.config().drive == drive)
    }

    /// Adds (or replaces, by index) a heater, off: its drive output
    /// neither a servo's channel nor another heater's.
    pub fn configure_heater(&mut self, c: HeaterConfig) -> Result<(), Refusal> {
        let taken = self.has_servo(c.drive)
            || self
                .heaters
                .iter()
                .any(|h| h.config().heater != c.heater && h.config().drive == c.drive);
        if !c.is_valid() || taken {
            return Err(Refusal::BadConfig);
        }
        let heater = Heater::new(c);
        match self
            .heaters
            .iter_mut()
            .find(|h| h.config().heater == c.heater)
        {
            Some(h) => {
                // The replaced heater's output is off until the new one
                // drives it.
                let _ = self.drives_off.push(h.config().drive);
                *h = heater;
            }
            None => self.heaters.push(heater).map_err(|_| Refusal::BadConfig)?,
        }
        Ok(())
    }

    /// An event on `track` at host time `t`: a new target for each heater
    /// on it.
    pub fn set_target(&mut self, track: u8, value: f32) {
        for h in self
            .heaters
            .iter_mut()
            .filter(|h| h.config().track == track)
        {
            h.set_target(value);
        }
    }

    /// Every heater off at host time `t` (the run stopped on its tail).
    pub fn heaters_off<B: Board>(&mut self, t: f64, board: &mut B) {
        for h in self.heaters.iter_mut() {
            h.off(t, board);
        }
    }

    /// The drive outputs of the heaters, for a node about to forget them
    /// ([`Control::switch_off_later`] on the new state).
    pub fn heater_drives(&self) -> Vec<u8, MAX_HEATERS> {
        self.heaters
            .iter()
            .map(|h| h.config().drive)
            .chain(self.drives_off.iter().copied())
            .take(MAX_HEATERS)
            .collect()
    }

    /// Drive outputs to switch off at the next poll.
    pub fn switch_off_later(&mut self, drives: Vec<u8, MAX_HEATERS>) {
        self.drives_off = drives;
    }

    /// Switches off the outputs of heaters forgotten or replaced, at host
    /// time `t`.
    pub fn forgotten_off<B: Board>(&mut self, t: f64, board: &mut B) {
        for d in self.drives_off.iter() {
            if !self.heaters.iter().any(|h| h.config().drive == *d) {
                board.drive(*d, 0.0, t);
            }
        }
        self.drives_off.clear();
    }
}
