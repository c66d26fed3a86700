//! The DC motor of the thesis, K/((Js+b)(Ls+R)+K²), with Coulomb friction
//! and a load, integrated exactly over sub-steps with the drive held.
//!
//! State `[θ, ω, i]`: `θ' = ω`, `J ω' = K i − b ω − τ`, `L i' = V − R i −
//! K ω`, τ the Coulomb friction and the load's torque, both held over a
//! sub-step. The linear part is discretised exactly (the matrix
//! exponential of the system augmented with its inputs, by scaling and
//! squaring), so a sub-step of any length is stable; friction is what the
//! sub-step resolves. A shaft at rest stays there while the torque on it
//! is within the friction (stiction), and a shaft that would reverse
//! within a sub-step stops at zero instead.

/// The motor's constants (SI units; the load's inertia and torque as the
/// shaft sees them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorModel {
    /// Armature resistance, Ω.
    pub r: f64,
    /// Armature inductance, H.
    pub l: f64,
    /// Torque and back-EMF constant, N·m/A.
    pub k: f64,
    /// Inertia at the shaft (rotor and load), kg·m².
    pub j: f64,
    /// Viscous friction, N·m·s/rad.
    pub b: f64,
    /// Coulomb friction, N·m.
    pub coulomb: f64,
    /// A constant torque against positive θ (the load's), N·m.
    pub load: f64,
    /// Volts at duty 1.
    pub supply: f64,
}

/// One sub-step: `e^{A h}` of the augmented 5×5 system (the state's three
/// rows, with the inputs' (V, τ) effect over it), and `h`, s.
#[derive(Clone, Copy, Debug)]
struct Step {
    e: [[f64; 5]; 3],
    h: f64,
}

/// A motor's state, integrated as asked.
#[derive(Clone, Debug)]
pub struct DcMotor {
    m: MotorModel,
    /// θ (rad), ω (rad/s), i (A).
    x: [f64; 3],
    /// Host time the state is at, µs.
    t: f64,
    /// The drive, duty −1..1.
    duty: f64,
    /// The drive is cut (a limit switch opened).
    cut: bool,
    /// µs of a full sub-step, and its discretisation.
    sub_us: f64,
    full: Step,
    /// The last partial sub-step's length and discretisation.
    partial: (f64, Step),
}

impl DcMotor {
    /// A motor at rest at angle `theta` (rad) at host time `t` (µs),
    /// integrated in sub-steps of `sub_us`.
    pub fn new(m: MotorModel, theta: f64, t: f64, sub_us: f64) -> DcMotor {
        DcMotor {
            m,
            x: [theta, 0.0, 0.0],
            t,
            duty: 0.0,
            cut: false,
            sub_us,
            full: discretise(&m, sub_us * 1e-6),
            partial: (0.0, discretise(&m, 0.0)),
        }
    }

    /// Angle, rad.
    pub fn theta(&self) -> f64 {
        self.x[0]
    }

    /// Speed, rad/s.
    pub fn omega(&self) -> f64 {
        self.x[1]
    }

    /// Current, A.
    pub fn current(&self) -> f64 {
        self.x[2]
    }

    /// Host time the state is at, µs.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Sets the drive from now on.
    pub fn set_duty(&mut self, duty: f64) {
        self.duty = duty.clamp(-1.0, 1.0);
    }

    /// Cuts (or restores) the drive, as a limit switch in its line does.
    pub fn set_cut(&mut self, cut: bool) {
        self.cut = cut;
    }

    /// Volts across the armature now.
    fn volts(&self) -> f64 {
        if self.cut {
            0.0
        } else {
            self.duty * self.m.supply
        }
    }

    /// The shaft's acceleration now, rad/s².
    pub fn alpha(&self) -> f64 {
        let m = &self.m;
        let drive = m.k * self.x[2] - m.load;
        let w = self.x[1];
        let friction = if w != 0.0 {
            m.coulomb * w.signum()
        } else {
            drive.clamp(-m.coulomb, m.coulomb)
        };
        (drive - m.b * w - friction) / m.j
    }

    /// Integrates up to host time `t` (µs); earlier times change nothing.
    pub fn advance(&mut self, t: f64) {
        while self.t < t {
            let left = t - self.t;
            // Within a nanosecond of a whole sub-step counts as one: times
            // on a tick grid differ from it by rounding only.
            if left >= self.sub_us - 1e-3 {
                let s = self.full;
                self.sub_step(&s);
                self.t = if left - self.sub_us <= 1e-3 {
                    t
                } else {
                    self.t + self.sub_us
                };
            } else {
                if (self.partial.0 - left).abs() > 1e-9 {
                    self.partial = (left, discretise(&self.m, left * 1e-6));
                }
                let s = self.partial.1;
                self.sub_step(&s);
                self.t = t;
            }
        }
    }

    fn sub_step(&mut self, s: &Step) {
        let m = self.m;
        let v = self.volts();
        let [theta, w, i] = self.x;
        let drive = m.k * i - m.load;
        if w == 0.0 && m.coulomb > 0.0 && drive.abs() <= m.coulomb {
            // Held by friction: only the current moves, exactly; the
            // shaft breaks free at a later sub-step if the torque grows.
            let i1 = v / m.r + (i - v / m.r) * (-s.h * m.r / m.l).exp();
            self.x = [theta, 0.0, i1];
            return;
        }
        let dir = if w != 0.0 { w.signum() } else { drive.signum() };
        let tau = m.load + m.coulomb * dir;
        let u = [v, tau];
        let mut next = [0.0; 3];
        for (r, n) in next.iter_mut().enumerate() {
            let e = &s.e[r];
            *n = e[0] * theta + e[1] * w + e[2] * i + e[3] * u[0] + e[4] * u[1];
        }
        // Friction opposes motion; it never reverses it within a sub-step.
        if next[1] * dir < 0.0 {
            next[1] = 0.0;
        }
        self.x = next;
    }
}

/// `e^{A h}` for the augmented system `[x; u]' = [A B; 0 0] [x; u]`, the
/// rows of `x`.
fn discretise(m: &MotorModel, h: f64) -> Step {
    // A (3×3) and B (3×2) of θ, ω, i with inputs V and τ.
    let mut a = [[0.0; 5]; 5];
    a[0][1] = 1.0;
    a[1][1] = -m.b / m.j;
    a[1][2] = m.k / m.j;
    a[1][4] = -1.0 / m.j;
    a[2][1] = -m.k / m.l;
    a[2][2] = -m.r / m.l;
    a[2][3] = 1.0 / m.l;
    let e = expm(a, h);
    Step {
        e: [e[0], e[1], e[2]],
        h,
    }
}

type M5 = [[f64; 5]; 5];

fn mul(a: &M5, b: &M5) -> M5 {
    let mut c = [[0.0; 5]; 5];
    for i in 0..5 {
        for k in 0..5 {
            let aik = a[i][k];
            if aik != 0.0 {
                for j in 0..5 {
                    c[i][j] += aik * b[k][j];
                }
            }
        }
    }
    c
}

/// `e^{A h}` by scaling and squaring with a Taylor series.
fn expm(a: M5, h: f64) -> M5 {
    let norm = a
        .iter()
        .map(|r| r.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
        * h;
    let squarings = if norm > 0.5 {
        (norm / 0.5).log2().ceil() as u32
    } else {
        0
    };
    let scale = h / f64::from(1u32 << squarings.min(30));
    let mut x = [[0.0; 5]; 5];
    for (i, r) in a.iter().enumerate() {
        for (j, v) in r.iter().enumerate() {
            x[i][j] = v * scale;
        }
    }
    let mut e = [[0.0; 5]; 5];
    let mut term = [[0.0; 5]; 5];
    for i in 0..5 {
        e[i][i] = 1.0;
        term[i][i] = 1.0;
    }
    for n in 1..=14 {
        term = mul(&term, &x);
        for row in term.iter_mut() {
            for v in row.iter_mut() {
                *v /= n as f64;
            }
        }
        for i in 0..5 {
            for j in 0..5 {
                e[i][j] += term[i][j];
            }
        }
    }
    for _ in 0..squarings.min(30) {
        e = mul(&e, &e);
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> MotorModel {
        MotorModel {
            r: 1.2,
            l: 0.5e-3,
            k: 0.05,
            j: 4e-5,
            b: 1e-5,
            coulomb: 0.0,
            load: 0.0,
            supply: 24.0,
        }
    }

    /// At a constant voltage the motor settles at the speed where back-EMF
    /// and losses balance: V K / (R b + K²).
    #[test]
    fn reaches_its_steady_speed() {
        let m = model();
        let mut motor = DcMotor::new(m, 0.0, 0.0, 25.0);
        motor.set_duty(0.5);
        motor.advance(2e6);
        let want = 12.0 * m.k / (m.r * m.b + m.k * m.k);
        assert!(
            (motor.omega() - want).abs() < 1e-6 * want,
            "{} vs {want}",
            motor.omega()
        );
        // The same whatever the sub-steps: the discretisation is exact.
        let mut coarse = DcMotor::new(m, 0.0, 0.0, 1000.0);
        coarse.set_duty(0.5);
        let mut fine = DcMotor::new(m, 0.0, 0.0, 5.0);
        fine.set_duty(0.5);
        coarse.advance(30_000.0);
        fine.advance(30_000.0);
        assert!(
            (coarse.theta() - fine.theta()).abs() < 1e-9,
            "{} {}",
            coarse.theta(),
            fine.theta()
        );
    }

    /// Friction holds a shaft whose torque is below it, and a cut drive
    /// lets it coast to a stop.
    #[test]
    fn friction_holds_and_stops() {
        let m = MotorModel {
            coulomb: 0.02,
            ..model()
        };
        let mut motor = DcMotor::new(m, 1.0, 0.0, 25.0);
        // 0.02 N·m takes 0.4 A, 0.48 V: a 1 % duty (0.24 V) holds still.
        motor.set_duty(0.01);
        motor.advance(100_000.0);
        assert_eq!((motor.theta(), motor.omega()), (1.0, 0.0));
        motor.set_duty(0.5);
        motor.advance(200_000.0);
        assert!(motor.omega() > 100.0);
        motor.set_cut(true);
        motor.advance(2_000_000.0);
        assert_eq!(motor.omega(), 0.0);
        let at = motor.theta();
        motor.advance(3_000_000.0);
        assert_eq!(motor.theta(), at, "stays stopped");
    }
}
