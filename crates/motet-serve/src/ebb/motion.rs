//! The AxiDraw's step geometry on the motet machine's own kinematics.
//!
//! The EBB counts motor steps; the AxiDraw mixes its two motors as CoreXY
//! does: motor1 = x + y, motor2 = x − y, 2032 steps per inch of x or y at
//! 1/16 microstepping (2874 steps per inch along a motor's own diagonal).
//! The adapter keeps each motor's position as an exact integer count of
//! 1/16 microsteps since it began and turns that cumulative count into a
//! tool point in mm (x right, y away from home, as the AxiDraw draws an
//! SVG page), so no rounding builds up over a plot. The point goes to the
//! machine as a move in its own axes; its kinematics (cartesian, CoreXY,
//! five-bar) does the rest.

/// Millimetres per 1/16 microstep along x or y.
pub const MM_PER_STEP: f64 = 25.4 / 2032.0;

/// Both motors' step counts and how they map to the page.
#[derive(Clone, Debug, Default)]
pub struct Steps {
    /// Each motor's position in 1/16 microsteps since the adapter began.
    micro: [i64; 2],
    /// The global step counters `QS` reports, in the current step mode;
    /// cleared by `CS` and `EM`.
    pub counters: [i64; 2],
    /// 1/16 microsteps per step in the current mode (1, 2, 4, 8, 16).
    pub factor: i64,
    /// The rate accumulators `LM`/`LT`/`T3` carry between moves.
    pub accum: [i64; 2],
}

impl Steps {
    /// At the start: 1/16 microstepping, everything zero.
    pub fn new() -> Steps {
        Steps {
            factor: 1,
            ..Steps::default()
        }
    }

    /// The tool point, mm from where the adapter began: (x, y).
    pub fn point(&self) -> (f64, f64) {
        let [m1, m2] = self.micro;
        (
            (m1 + m2) as f64 / 2.0 * MM_PER_STEP,
            (m1 - m2) as f64 / 2.0 * MM_PER_STEP,
        )
    }

    /// The point after moving `d` steps (current mode), without moving.
    pub fn point_after(&self, d: [i64; 2]) -> (f64, f64) {
        let mut next = self.clone();
        next.take(d);
        next.point()
    }

    /// Takes `d` steps (current mode) on each motor.
    pub fn take(&mut self, d: [i64; 2]) {
        for (k, dk) in d.into_iter().enumerate() {
            self.micro[k] += dk * self.factor;
            self.counters[k] += dk;
        }
    }

    /// Sets the counts to the nearest steps of a point the machine rests at
    /// (after an emergency stop cut moves short).
    pub fn settle_at(&mut self, x: f64, y: f64) {
        let m1 = ((x + y) / MM_PER_STEP).round() as i64;
        let m2 = ((x - y) / MM_PER_STEP).round() as i64;
        for (k, m) in [m1, m2].into_iter().enumerate() {
            let d = (m - self.micro[k]) / self.factor;
            self.micro[k] += d * self.factor;
            self.counters[k] += d;
        }
    }

    /// `EM`'s step mode: 1 = 1/16 … 5 = full steps; the counters clear.
    pub fn set_mode(&mut self, mode: i64) {
        if (1..=5).contains(&mode) {
            self.factor = 1 << (mode - 1);
        }
        self.counters = [0, 0];
    }

    /// The steps to `HM`'s target (counter values), and its duration in
    /// seconds at `rate` steps/s on the axis that moves most.
    pub fn home_move(&self, rate: i64, to: [i64; 2]) -> ([i64; 2], f64) {
        let d = [to[0] - self.counters[0], to[1] - self.counters[1]];
        let most = d[0].abs().max(d[1].abs()) as f64;
        (d, most / rate as f64)
    }
}
