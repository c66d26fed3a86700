//! A simulated heater: its temperature approaches its target as a first
//! order lag, and it is ready within a few degrees of it. The S3G bot and
//! `motet serve`'s heaters both use it.

/// Room temperature, where heaters start, °C.
pub const AMBIENT_C: f64 = 25.0;

/// How close to its target a heater counts as there, °C.
pub const READY_WITHIN_C: f64 = 2.0;

/// One heater.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Heater {
    /// Temperature now, °C.
    pub temp: f64,
    /// Target, °C (0: off, cooling to ambient).
    pub target: f64,
    /// Time constant, s.
    pub tau_s: f64,
}

impl Heater {
    /// A cold heater, switched off.
    pub fn new(tau_s: f64) -> Heater {
        Heater {
            temp: AMBIENT_C,
            target: 0.0,
            tau_s,
        }
    }

    /// Lets `dt_s` seconds pass.
    pub fn advance(&mut self, dt_s: f64) {
        let goal = if self.target > 0.0 {
            self.target
        } else {
            AMBIENT_C
        };
        let k = 1.0 - (-dt_s.max(0.0) / self.tau_s).exp();
        self.temp += (goal - self.temp) * k;
        // A lag never arrives; a real controller settles on its target.
        if (goal - self.temp).abs() < 0.5 * READY_WITHIN_C {
            self.temp = goal;
        }
    }

    /// The share of full power, 0..=1, that holds this course when full
    /// power would bring the heater to `max_c`: a first-order lag toward
    /// the target is what a constant power gives, (target − ambient) /
    /// (max − ambient).
    pub fn power(&self, max_c: f64) -> f64 {
        if self.target <= 0.0 || max_c <= AMBIENT_C {
            return 0.0;
        }
        ((self.target - AMBIENT_C) / (max_c - AMBIENT_C)).clamp(0.0, 1.0)
    }

    /// Whether a wait for it is over.
    pub fn ready(&self) -> bool {
        self.target <= 0.0 || (self.temp - self.target).abs() <= READY_WITHIN_C
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn approaches_and_settles() {
        let mut h = Heater::new(2.0);
        h.target = 200.0;
        let mut last = h.temp;
        let mut t = 0.0;
        while !h.ready() {
            h.advance(0.1);
            assert!(h.temp > last, "rises toward its target");
            last = h.temp;
            t += 0.1;
            assert!(t < 60.0, "reaches its target");
        }
        // About tau · ln(175 / 2) seconds.
        assert!((t - 2.0 * (175.0f64 / 2.0).ln()).abs() < 0.5, "{t}");
    }
}
