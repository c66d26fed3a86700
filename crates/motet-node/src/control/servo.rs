//! A servo channel: a joint followed by a motor and its encoder, the
//! position loop closed on the node at a fixed rate.
//!
//! Each tick reads the encoder and the limit switches at the tick's time,
//! takes the set point from the queued segments (value for the error,
//! speed and acceleration for the feed-forward, at the tick or over a
//! window ahead of it), runs the PID and sets the drive. A following error beyond the limit, an open limit switch or an
//! encoder that gives no reading stops the drive at once (0) and reports a
//! fault; the servo drives nothing more until it is configured again.

use super::pid::{Pid, PidGains};
use super::samples::{Sampler, Upstream};
use super::setpoint::SetPoint;
use super::ticker::Ticker;
use crate::board::Board;
use heapless::Deque;
use motet_trajectory::{Point, Segment};
use motet_wire::control::{FaultKind, SampleSource, ServoConfig, ServoGains, ServoTest};

/// Ticks at rest, error within [`QUIET_COUNTS`] and the count unchanged,
/// after which a servo with nothing queued is settled: it still ticks
/// when polled, but no longer asks to be (`Node::next_deadline`).
const QUIET_TICKS: u32 = 256;
/// |Following error| a settled servo stays within, counts.
const QUIET_COUNTS: f32 = 1.5;

/// |Following error| within which a servo held at rest takes its error
/// as none, counts.
const REST_BAND_COUNTS: f32 = 1.0;

/// A tuning test under way.
#[derive(Clone, Copy, Debug)]
struct Running {
    test: ServoTest,
    /// Host time it ends, µs (set at its first tick).
    until: Option<f64>,
    /// The relay's output now.
    high: bool,
}

/// One servo channel.
#[derive(Clone, Debug)]
pub struct Servo {
    config: ServoConfig,
    pid: Pid,
    ticker: Ticker,
    setpoint: SetPoint,
    /// The set point a feed-forward lead ahead, for the feed-forward.
    ahead: SetPoint,
    /// Encoder count where the joint is 0 (set at the first tick after
    /// the position was set).
    offset: Option<f64>,
    fault: Option<FaultKind>,
    test: Option<Running>,
    /// The loop is open: a test ended; `SetPosition` closes it again.
    open: bool,
    quiet: u32,
    last_count: Option<i64>,
    /// The last following error, counts.
    error: f32,
    sampler: Sampler,
}

/// The PID gains of a servo's gains at its loop rate.
fn pid_gains(g: &ServoGains, rate_hz: f32) -> PidGains {
    let hz = if g.derivative_hz > 0.0 {
        g.derivative_hz
    } else {
        rate_hz / 4.0
    };
    PidGains {
        kp: g.kp,
        ki: g.ki,
        kd: g.kd,
        integral_limit: g.integral_limit,
        output_limit: g.output_limit,
        derivative_tau: 1.0 / (2.0 * core::f32::consts::PI * hz),
    }
}

impl Servo {
    /// A servo on `config`, at rest at `p` (its encoder's offset found at
    /// its first tick).
    pub fn new(config: ServoConfig, p: &Point) -> Servo {
        Servo {
            config,
            pid: Pid::new(pid_gains(&config.gains, config.rate_hz)),
            ticker: Ticker::new(config.rate_hz),
            setpoint: SetPoint::at_rest(config.map, p),
            ahead: SetPoint::at_rest(config.map, p),
            offset: None,
            fault: None,
            test: None,
            open: false,
            quiet: 0,
            last_count: None,
            error: 0.0,
            sampler: Sampler::new(SampleSource::Servo(config.channel)),
        }
    }

    /// What the host configured.
    pub fn config(&self) -> &ServoConfig {
        &self.config
    }

    /// The fault that stopped it, if one did.
    pub fn fault(&self) -> Option<FaultKind> {
        self.fault
    }

    /// The following error at the last tick, counts.
    pub fn following_error(&self) -> f32 {
        self.error
    }

    /// The next tick's time.
    pub fn due(&self, now: f64) -> f64 {
        self.ticker.due(now)
    }

    /// Whether it asks to be polled: not faulted, and moving, testing or
    /// not yet settled.
    pub fn active(&self, moving: bool) -> bool {
        self.fault.is_none() && (moving || self.test.is_some() || self.quiet < QUIET_TICKS)
    }

    /// New gains from the next tick on.
    pub fn set_gains(&mut self, gains: ServoGains) {
        if gains.lead < self.config.gains.lead {
            // A shorter window: looked at again from the set point on, as
            // it only ever moves forward in time.
            self.ahead = self.setpoint;
        }
        self.config.gains = gains;
        self.pid.set_gains(pid_gains(&gains, self.config.rate_hz));
    }

    /// The machine is at rest at `p`: the joint holds there, the encoder's
    /// offset is found again at the next tick, and a loop a test left open
    /// closes.
    pub fn set_position(&mut self, p: &Point) {
        self.setpoint.set_position(p);
        self.ahead.set_position(p);
        self.offset = None;
        self.open = false;
        self.quiet = 0;
        self.pid.reset();
    }

    /// Starts a tuning test at its next tick, its error measured from
    /// where the motor is then.
    pub fn start_test(&mut self, test: ServoTest) {
        self.offset = None;
        self.test = Some(Running {
            test,
            until: None,
            high: true,
        });
        self.quiet = 0;
    }

    /// The sampler of its ticks.
    pub fn sampler_mut(&mut self) -> &mut Sampler {
        &mut self.sampler
    }

    /// Segments from the queue's head it is done with (all, once it
    /// faulted: it follows none any more).
    pub fn segments_done(&self) -> usize {
        if self.fault.is_some() {
            usize::MAX
        } else {
            self.setpoint.segments_done()
        }
    }

    /// The queue dropped `n` segments from its head.
    pub fn drop_segments(&mut self, n: usize) {
        self.setpoint.drop_segments(n);
        self.ahead.drop_segments(n);
    }

    /// Runs the tick due at `t` on the first `end` of `segments`; true when
    /// it faulted.
    pub fn tick<B: Board, const Q: usize>(
        &mut self,
        t: f64,
        segments: &Deque<Segment, Q>,
        end: usize,
        board: &mut B,
        up: &mut Upstream,
    ) -> bool {
        self.ticker.advance(t);
        if self.fault.is_some() {
            return false;
        }
        let ch = self.config.channel;
        let Some(count) = board.encoder(ch, t) else {
            return self.trip(FaultKind::SensorLost, t, 0.0, board, up);
        };
        if board.limit(ch, t) {
            return self.trip(FaultKind::Limit, t, self.error, board, up);
        }
        let cpu = self.config.counts_per_unit;
        let offset = *self
            .offset
            .get_or_insert_with(|| count as f64 - self.setpoint.hold() * cpu);
        let measured = count as f64 - offset;
        let state = self.setpoint.state(t, segments, end);
        // The feed-forward's window: from this tick to twice the lead on.
        let lead = self.config.gains.lead as f64 * 1e6;
        let later = self.ahead.state(t + 2.0 * lead, segments, end);
        let error = (state.value * cpu - measured) as f32;
        self.error = error;
        let moved = self.last_count != Some(count);
        self.last_count = Some(count);
        let drive = if let Some(run) = self.test.as_mut() {
            let until = *run.until.get_or_insert(t + test_ms(&run.test) as f64 * 1e3);
            if t >= until {
                self.test = None;
                self.open = true;
                Some(0.0)
            } else {
                Some(test_drive(run, error))
            }
        } else if self.open {
            None
        } else {
            if error.abs() > self.config.following_limit {
                return self.trip(FaultKind::Following, t, error, board, up);
            }
            let g = &self.config.gains;
            // Over the window, the set point's mean speed and acceleration:
            // what the motor, whose current lags its drive, must be given
            // now to be there at the tick in the window's middle. A jump
            // in speed (a corner) is fed forward as the acceleration it
            // takes over the window, instead of being left to the error.
            let w = 2.0 * lead * 1e-6;
            let (v, a) = if lead > 0.0 {
                (
                    ((later.value - state.value) / w * cpu) as f32,
                    ((later.speed - state.speed) / w * cpu) as f32,
                )
            } else {
                ((state.speed * cpu) as f32, (state.accel * cpu) as f32)
            };
            let friction = if v > 0.0 {
                g.kf
            } else if v < 0.0 {
                -g.kf
            } else {
                0.0
            };
            let ff = g.kv * v + g.ka * a + friction;
            // An encoder tells nothing finer than its count: held at rest,
            // an error within one count is none. Otherwise the loop hunts
            // across a count's edge, the derivative kicking at every flip
            // of the last count, and the servo never settles.
            let resting = state.speed == 0.0 && v == 0.0 && a == 0.0;
            let e = if resting && error.abs() < REST_BAND_COUNTS {
                0.0
            } else {
                error
            };
            Some(self.pid.update(e, ff, self.ticker.period_s()).out)
        };
        if let Some(d) = drive {
            board.drive(ch, d, t);
        }
        let still = state.speed == 0.0 && !moved && error.abs() <= QUIET_COUNTS;
        self.quiet = if still || self.open {
            self.quiet.saturating_add(1)
        } else {
            0
        };
        let period = self.ticker.period_us();
        self.sampler.servo(t, period, measured as i64, error, up);
        if self.quiet == QUIET_TICKS {
            // Settled: what was gathered goes now, not a second later.
            self.sampler.flush(up);
        }
        false
    }

    fn trip<B: Board>(
        &mut self,
        kind: FaultKind,
        t: f64,
        value: f32,
        board: &mut B,
        up: &mut Upstream,
    ) -> bool {
        board.drive(self.config.channel, 0.0, t);
        self.fault = Some(kind);
        self.test = None;
        self.sampler.flush(up);
        up.fault(SampleSource::Servo(self.config.channel), kind, t, value);
        true
    }
}

fn test_ms(test: &ServoTest) -> u32 {
    match *test {
        ServoTest::Relay { duration_ms, .. } | ServoTest::Step { duration_ms, .. } => duration_ms,
    }
}

/// The drive a test gives at this tick, the error from where it started.
fn test_drive(run: &mut Running, error: f32) -> f32 {
    match run.test {
        ServoTest::Step { duty, .. } => duty,
        ServoTest::Relay {
            amplitude,
            hysteresis,
            ..
        } => {
            // Behind the start (error above the band): drive up; past it:
            // down; inside the band the relay keeps its side.
            if error > hysteresis {
                run.high = true;
            } else if error < -hysteresis {
                run.high = false;
            }
            if run.high {
                amplitude
            } else {
                -amplitude
            }
        }
    }
}
