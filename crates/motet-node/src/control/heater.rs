//! A heater channel: a temperature sensor, a power output and the PID
//! between them, at a fixed rate; its target comes from the events of one
//! event track (the trajectory's timeline), and a runaway watch compares
//! what the heater does with what its thermal model says it should.
//!
//! Each tick reads the sensor at the tick's time. A reading that does not
//! come, is not a number, or is out of what a working sensor gives (below
//! `min_c`, above `max_c` by [`OVER_MAX_C`]) trips at once
//! (`SensorLost`). Then the watch: while the heater is driven, the rise
//! its model predicts for the power applied over the last tick and the
//! rise measured are summed over an exponential window; a measured rise
//! short of the prediction by more than the margin and less than half of
//! it trips (`Runaway`: a heater that is not heating, a thermistor that
//! fell off its block). A reading that falls below a target it had
//! reached by more than the hysteresis for the watch's period trips too.
//! A trip switches the heater off for good (until configured again); the
//! node's [`Control`](super::Control) switches its other heaters off with
//! it.
//!
//! The PID's output is shifted to centre its clamp on the heater's power
//! range (0 to `output_limit`), so that its anti-windup sees the real
//! limits; the model's holding power at the target is fed forward, so the
//! integral only takes up what the model misses.

use super::pid::{Pid, PidGains};
use super::samples::{Sampler, Upstream};
use super::ticker::Ticker;
use crate::board::Board;
use motet_wire::control::{FaultKind, SampleSource};
use motet_wire::heater::{HeaterConfig, OVER_MAX_C};
use motet_wire::NodeMessage;

/// One heater channel.
#[derive(Clone, Debug)]
pub struct Heater {
    config: HeaterConfig,
    pid: Pid,
    ticker: Ticker,
    /// °C; 0: off.
    target: f32,
    /// Power applied since the last tick, 0 to 1.
    power: f32,
    /// The last reading, °C.
    reading: Option<f32>,
    fault: Option<FaultKind>,
    /// Switched off with the node's other heaters: drives nothing until
    /// configured again.
    halted: bool,
    /// Since when the readings have been within the ready window of the
    /// target (host µs), and whether readiness was sent for it.
    within_since: Option<f64>,
    ready_sent: bool,
    /// The target was reached since it was set.
    reached: bool,
    /// Since when a reached target has been fallen away from (host µs).
    below_since: Option<f64>,
    /// The model's predicted rise and the measured rise over the watch's
    /// window, °C.
    predicted: f32,
    measured: f32,
    sampler: Sampler,
    /// Samples sent since configured: the first goes at once, so the host
    /// hears from a new heater at its first tick.
    sampled: bool,
}

impl Heater {
    /// A heater on `config`, off.
    pub fn new(config: HeaterConfig) -> Heater {
        let g = config.gains;
        // The PID's clamp is centred on the power range: ±half of it.
        let half = 0.5 * g.output_limit;
        Heater {
            config,
            pid: Pid::new(PidGains {
                kp: g.kp,
                ki: g.ki,
                kd: g.kd,
                integral_limit: g.integral_limit,
                output_limit: half,
                derivative_tau: g.derivative_s,
            }),
            ticker: Ticker::new(config.rate_hz),
            target: 0.0,
            power: 0.0,
            reading: None,
            fault: None,
            halted: false,
            within_since: None,
            ready_sent: false,
            reached: false,
            below_since: None,
            predicted: 0.0,
            measured: 0.0,
            sampler: Sampler::new(SampleSource::Heater(config.heater)),
            sampled: false,
        }
    }

    /// What the host configured.
    pub fn config(&self) -> &HeaterConfig {
        &self.config
    }

    /// The target, °C (0: off).
    pub fn target(&self) -> f32 {
        self.target
    }

    /// The power applied now, 0 to 1.
    pub fn power(&self) -> f32 {
        self.power
    }

    /// The last reading, °C.
    pub fn reading(&self) -> Option<f32> {
        self.reading
    }

    /// The fault that stopped it, if one did.
    pub fn fault(&self) -> Option<FaultKind> {
        self.fault
    }

    /// Whether it drives nothing more until configured again (it faulted,
    /// or another heater of the node did).
    pub fn halted(&self) -> bool {
        self.halted || self.fault.is_some()
    }

    /// The next tick's time.
    pub fn due(&self, now: f64) -> f64 {
        self.ticker.due(now)
    }

    /// Whether it asks to be polled: while the machine moves (a wait's
    /// hold is motion too), unless it drives nothing more.
    pub fn active(&self, moving: bool) -> bool {
        moving && !self.halted()
    }

    /// The sampler of its ticks.
    pub fn sampler_mut(&mut self) -> &mut Sampler {
        &mut self.sampler
    }

    /// A new target from an event at host time `at`: values out of range
    /// (below 0, above `max_c`, not a number) switch the heater off.
    /// Readiness and the watch's reached target start again.
    pub fn set_target(&mut self, value: f32) {
        let valid = value.is_finite() && value > 0.0 && value <= self.config.max_c;
        self.target = if valid { value } else { 0.0 };
        self.within_since = None;
        self.ready_sent = false;
        self.reached = false;
        self.below_since = None;
    }

    /// Off now (the run stopped on its tail, the node was reset): the
    /// target goes to 0 and the power with it.
    pub fn off<B: Board>(&mut self, t: f64, board: &mut B) {
        self.set_target(0.0);
        self.power = 0.0;
        self.pid.reset();
        board.drive(self.config.drive, 0.0, t);
    }

    /// Off for good, with the node's other heaters (one of them tripped).
    pub fn halt<B: Board>(&mut self, t: f64, board: &mut B, up: &mut Upstream) {
        self.off(t, board);
        self.halted = true;
        self.sampler.flush(up);
    }

    /// Runs the tick due at `t`; true when it tripped.
    pub fn tick<B: Board>(&mut self, t: f64, board: &mut B, up: &mut Upstream) -> bool {
        self.ticker.advance(t);
        if self.halted() {
            return false;
        }
        let c = self.config;
        let dt = self.ticker.period_s();
        let reading = board.temperature(c.sensor, t);
        let temp = match reading {
            Some(v) if v.is_finite() && v >= c.min_c && v <= c.max_c + OVER_MAX_C => v,
            other => {
                let value = other.unwrap_or(f32::NAN);
                return self.trip(FaultKind::SensorLost, t, value, board, up);
            }
        };
        if let Some(last) = self.reading {
            if self.runs_away(last, temp, dt, t) {
                return self.trip(FaultKind::Runaway, t, temp, board, up);
            }
        }
        self.reading = Some(temp);
        self.power = if self.target > 0.0 {
            let half = 0.5 * c.gains.output_limit;
            let ff = c.gains.feed_forward * c.model.holding_power(self.target);
            let terms = self.pid.update(self.target - temp, ff - half, dt);
            (half + terms.out).clamp(0.0, c.gains.output_limit)
        } else {
            self.pid.reset();
            0.0
        };
        board.drive(c.drive, self.power, t);
        self.watch_ready(temp, t, up);
        let period = self.ticker.period_us();
        self.sampler
            .heater(t, period, temp, self.target, self.power, up);
        if !self.sampled && self.sampler.every() > 0 {
            self.sampled = true;
            self.sampler.flush(up);
        }
        false
    }

    /// The runaway watch over the tick from a reading of `last` to `temp`
    /// (`dt` s, at the power applied over it), at host time `t`.
    fn runs_away(&mut self, last: f32, temp: f32, dt: f32, t: f64) -> bool {
        let c = &self.config;
        let w = &c.watch;
        let keep = libm::expf(-dt / w.window_s);
        self.predicted *= keep;
        self.measured *= keep;
        if self.target > 0.0 && self.power > 0.0 {
            self.predicted += c.model.rate(last, self.power) * dt;
            self.measured += temp - last;
        }
        let short = self.predicted - self.measured;
        if short > w.margin_c && self.measured < 0.5 * self.predicted {
            return true;
        }
        if self.target <= 0.0 {
            return false;
        }
        if (temp - self.target).abs() <= c.ready.window_c {
            self.reached = true;
        }
        if self.reached && temp < self.target - w.hysteresis_c {
            let since = *self.below_since.get_or_insert(t);
            return (t - since) * 1e-6 >= w.period_s as f64;
        }
        self.below_since = None;
        false
    }

    /// Readiness: within the window of the target for the residency.
    fn watch_ready(&mut self, temp: f32, t: f64, up: &mut Upstream) {
        let rule = self.config.ready;
        if self.target <= 0.0 || (temp - self.target).abs() > rule.window_c {
            self.within_since = None;
            return;
        }
        let since = *self.within_since.get_or_insert(t);
        if !self.ready_sent && (t - since) * 1e-6 >= rule.residency_s as f64 {
            self.ready_sent = true;
            // The samples up to it go first, so the host's record reaches
            // the moment the wait ends.
            self.sampler.flush(up);
            up.urgent(NodeMessage::HeaterReady {
                heater: self.config.heater,
                at: t,
                target: self.target,
            });
        }
    }

    fn trip<B: Board>(
        &mut self,
        kind: FaultKind,
        t: f64,
        value: f32,
        board: &mut B,
        up: &mut Upstream,
    ) -> bool {
        self.power = 0.0;
        board.drive(self.config.drive, 0.0, t);
        self.fault = Some(kind);
        self.sampler.flush(up);
        up.fault(SampleSource::Heater(self.config.heater), kind, t, value);
        true
    }
}
