//! One PID controller with feed-forward, an integral clamp, an output
//! clamp and anti-windup: the arithmetic every closed loop on a node
//! shares (a servo's position loop, a heater's temperature loop).
//!
//! Position form, not the thesis's incremental form: the integral is kept
//! as its term (in output units), so that its clamp is a share of the
//! output and a gain changed live changes nothing already integrated
//! (bumpless). Anti-windup by conditional integration: while the output is
//! clamped, the error does not integrate further in the direction that
//! pushes it past the clamp. The rate of the error is differenced tick to
//! tick and low-pass filtered, so an encoder's last-count flicker does not
//! reach the output at full gain.

/// A PID's gains and clamps, in the loop's own units (error in, output
/// out, seconds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidGains {
    /// Output per unit of error.
    pub kp: f32,
    /// Output per unit of error·second.
    pub ki: f32,
    /// Output per unit of error/second.
    pub kd: f32,
    /// Most |integral term|, output units (0: no integral action).
    pub integral_limit: f32,
    /// Most |output|.
    pub output_limit: f32,
    /// Time constant of the low-pass filter on the error's rate, s (0:
    /// none).
    pub derivative_tau: f32,
}

/// The terms of one update, for samples and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PidTerms {
    /// Proportional term.
    pub p: f32,
    /// Integral term (after its clamp).
    pub i: f32,
    /// Derivative term.
    pub d: f32,
    /// Feed-forward, as given.
    pub ff: f32,
    /// The output, after its clamp.
    pub out: f32,
    /// Whether the output was clamped.
    pub saturated: bool,
}

/// A PID controller's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pid {
    /// Its gains (set live with [`Pid::set_gains`]).
    gains: PidGains,
    /// The integral term, output units.
    integral: f32,
    /// The filtered rate of the error, error units per second.
    rate: f32,
    /// The error at the last update (none before the first).
    last: Option<f32>,
}

impl Pid {
    /// A controller with nothing integrated.
    pub const fn new(gains: PidGains) -> Pid {
        Pid {
            gains,
            integral: 0.0,
            rate: 0.0,
            last: None,
        }
    }

    /// Its gains.
    pub fn gains(&self) -> &PidGains {
        &self.gains
    }

    /// New gains from the next update on; the integral term is kept (and
    /// clamped to the new limit).
    pub fn set_gains(&mut self, gains: PidGains) {
        self.gains = gains;
        self.integral = clamp(self.integral, gains.integral_limit);
    }

    /// Forgets what it integrated and the last error.
    pub fn reset(&mut self) {
        self.integral = 0.0;
        self.rate = 0.0;
        self.last = None;
    }

    /// The integral term now.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// One update: `error` now, `ff` the feed-forward to add, `dt` seconds
    /// since the last update (above 0). Returns the terms; `out` is the
    /// output to apply.
    pub fn update(&mut self, error: f32, ff: f32, dt: f32) -> PidTerms {
        let g = self.gains;
        let raw = match self.last {
            Some(last) if dt > 0.0 => (error - last) / dt,
            _ => 0.0,
        };
        self.last = Some(error);
        // First-order low-pass, exact for a constant rate over the tick.
        self.rate = if g.derivative_tau > 0.0 {
            self.rate + (raw - self.rate) * (dt / (g.derivative_tau + dt))
        } else {
            raw
        };
        let p = g.kp * error;
        let d = g.kd * self.rate;
        let integrated = clamp(self.integral + g.ki * error * dt, g.integral_limit);
        let unclamped = p + integrated + d + ff;
        let limit = g.output_limit;
        // Conditional integration: while clamped, the integral may only
        // move back toward what the output can give.
        let winds = unclamped.abs() > limit && (integrated - self.integral) * unclamped > 0.0;
        if !winds {
            self.integral = integrated;
        }
        let sum = p + self.integral + d + ff;
        let out = clamp(sum, limit);
        PidTerms {
            p,
            i: self.integral,
            d,
            ff,
            out,
            saturated: out != sum,
        }
    }
}

/// `v` within ±`limit` (a NaN becomes 0, so no NaN reaches an output).
fn clamp(v: f32, limit: f32) -> f32 {
    if v > limit {
        limit
    } else if v < -limit {
        -limit
    } else if v.is_nan() {
        0.0
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gains() -> PidGains {
        PidGains {
            kp: 0.5,
            ki: 10.0,
            kd: 0.01,
            integral_limit: 0.3,
            output_limit: 1.0,
            derivative_tau: 0.0,
        }
    }

    #[test]
    fn terms_add_up() {
        // (error sequence, ff, expected p, i, d, out of the last update)
        let dt = 0.001;
        let cases: &[(&[f32], f32, [f32; 4])] = &[
            (&[1.0], 0.0, [0.5, 0.01, 0.0, 0.51]),
            // Clamped: the integral holds instead of winding up.
            (&[1.0, 2.0], 0.1, [1.0, 0.01, 10.0, 1.0]),
            (&[0.0, 0.0], 0.25, [0.0, 0.0, 0.0, 0.25]),
            (&[-1.0], -0.2, [-0.5, -0.01, 0.0, -0.71]),
        ];
        for (errors, ff, want) in cases {
            let mut pid = Pid::new(gains());
            let mut t = PidTerms::default();
            for e in errors.iter() {
                t = pid.update(*e, *ff, dt);
            }
            let got = [t.p, t.i, t.d, t.out];
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() < 1e-5, "{errors:?}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn integral_is_clamped() {
        let mut pid = Pid::new(PidGains {
            kp: 0.0,
            output_limit: 10.0,
            ..gains()
        });
        for _ in 0..10_000 {
            pid.update(1.0, 0.0, 0.001);
        }
        assert_eq!(pid.integral(), 0.3);
        for _ in 0..10_000 {
            pid.update(-1.0, 0.0, 0.001);
        }
        assert_eq!(pid.integral(), -0.3);
    }

    /// While the output is clamped the integral does not wind up: once the
    /// error reverses, the output follows at once instead of after the
    /// integral unwinds.
    #[test]
    fn no_windup_while_saturated() {
        let g = PidGains {
            kp: 2.0,
            integral_limit: 1.0,
            ..gains()
        };
        let mut pid = Pid::new(g);
        for _ in 0..1000 {
            let t = pid.update(5.0, 0.0, 0.001);
            assert!(t.saturated);
        }
        assert!(pid.integral() < 0.06, "wound up to {}", pid.integral());
        let t = pid.update(-0.2, 0.0, 0.001);
        assert!(t.out < 0.0, "output follows the reversed error: {t:?}");
        // Without the clamp's condition it would have integrated to its
        // limit and held the output positive.
        let mut windup = Pid::new(g);
        windup.integral = 1.0;
        assert!(windup.update(-0.2, 0.0, 0.001).out > 0.0);
    }

    #[test]
    fn output_is_clamped_and_never_nan() {
        let mut pid = Pid::new(gains());
        assert_eq!(pid.update(100.0, 0.0, 0.001).out, 1.0);
        assert_eq!(pid.update(-100.0, 0.0, 0.001).out, -1.0);
        assert_eq!(pid.update(f32::NAN, 0.0, 0.001).out, 0.0);
    }

    #[test]
    fn derivative_is_filtered() {
        let mut raw = Pid::new(gains());
        let mut filtered = Pid::new(PidGains {
            derivative_tau: 0.01,
            ..gains()
        });
        raw.update(0.0, 0.0, 0.001);
        filtered.update(0.0, 0.0, 0.001);
        let a = raw.update(1.0, 0.0, 0.001).d;
        let b = filtered.update(1.0, 0.0, 0.001).d;
        // One tick of a 10 ms filter passes 1/11 of a step in the rate.
        assert!(
            (a - 10.0).abs() < 1e-4 && (b - 10.0 / 11.0).abs() < 1e-4,
            "{a} {b}"
        );
    }

    #[test]
    fn gains_change_bumplessly() {
        let mut pid = Pid::new(gains());
        for _ in 0..20 {
            pid.update(1.0, 0.0, 0.001);
        }
        let i = pid.integral();
        pid.set_gains(PidGains {
            ki: 1000.0,
            ..gains()
        });
        assert_eq!(pid.integral(), i, "what was integrated stays");
        pid.set_gains(PidGains {
            integral_limit: 0.1,
            ..gains()
        });
        assert_eq!(pid.integral(), 0.1, "and is clamped to a lower limit");
    }
}
