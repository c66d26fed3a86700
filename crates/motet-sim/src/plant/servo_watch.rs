//! The observer's side of servo actuators: at every tick of a servo the
//! plant compares the encoder's count with the ideal trajectory there (in
//! counts, independently of the node's set point), classed by what the
//! trajectory does then (at rest, cruising, accelerating), and moves the
//! executed point to where the motor is.

use super::Plant;

/// How a servo actuator followed the trajectory, counts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FollowingStats {
    /// Ticks observed.
    pub ticks: u64,
    /// Largest |ideal − count| while the trajectory cruises.
    pub max_cruise: f64,
    /// Largest while it has cruised at one speed and direction for at
    /// least 5 ms (the loop settled after a corner or a ramp).
    pub max_settled: f64,
    /// When the joint's planned speed last changed, µs.
    pub changed_at: f64,
    /// Its planned speed at the last tick (NaN: none yet).
    pub last_rate: f64,
    /// Largest while it accelerates or decelerates.
    pub max_accel: f64,
    /// Largest while it is at rest.
    pub max_rest: f64,
    /// Sum of squares while it moves, and the ticks that did.
    pub sum_sq: f64,
    /// Ticks while moving.
    pub moving: u64,
}

/// How long a cruise lasts before it counts as settled, µs: a few of the
/// loop's time constants after the last change of the joint's speed.
pub const SETTLE_US: f64 = 5_000.0;

impl FollowingStats {
    /// Root mean square following error while moving, counts.
    pub fn rms(&self) -> f64 {
        if self.moving == 0 {
            0.0
        } else {
            (self.sum_sq / self.moving as f64).sqrt()
        }
    }
}

impl Plant {
    /// Servo actuator `index`'s encoder read `count` at host time `t`, its
    /// joint truly at `joint` (joint units).
    pub(crate) fn servo_tick(&mut self, t: f64, index: usize, count: i64, joint: f64) {
        let (spu, j) = match self.actuators.get(index) {
            Some(a) => (a.spu_signed, a.joint),
            None => return,
        };
        let at = self.ideal.at(t);
        let (ideal, accel, speed) = match at {
            Some(m) => {
                let p = self.ideal.point(m);
                let v = self.actuators[index].map.value(&p, joint);
                (v, self.ideal.accel_at(m), self.ideal.speed_at(m))
            }
            None => {
                let p = self.ideal.rest_point(t).unwrap_or(self.executed);
                (self.actuators[index].map.value(&p, joint), 0.0, 0.0)
            }
        };
        let error = (ideal * spu - count as f64).abs();
        let rate = at
            .and_then(|m| self.ideal.joint_rate(index, m))
            .unwrap_or(0.0);
        let a = &mut self.actuators[index];
        let st = &mut a.following;
        st.ticks += 1;
        // A change of the joint's planned speed, a corner's jump included.
        if !(rate - st.last_rate).abs().le(&1e-9) || accel.abs() > 1e-12 {
            st.changed_at = t;
        }
        st.last_rate = rate;
        if accel.abs() <= 1e-12 && speed.abs() > 1e-12 && t - st.changed_at >= SETTLE_US {
            st.max_settled = st.max_settled.max(error);
        }
        let slot = if accel.abs() > 1e-12 {
            &mut st.max_accel
        } else if speed.abs() > 1e-12 {
            &mut st.max_cruise
        } else {
            &mut st.max_rest
        };
        *slot = slot.max(error);
        if speed.abs() > 1e-12 || accel.abs() > 1e-12 {
            st.sum_sq += error * error;
            st.moving += 1;
        }
        a.position = count;
        a.servo_joint = Some(joint);
        self.update_joint(j);
        if let Some(m) = at {
            let d2 = self.ideal.distance2(m, &self.executed);
            if d2 > self.max_path_deviation * self.max_path_deviation {
                self.max_path_deviation = d2.sqrt();
            }
        }
        let on = self.tool_on();
        let (x, y) = (self.recorder.x(), self.recorder.y());
        let q = [self.executed[x], self.executed[y]];
        self.recorder.sample_xy(q, on);
    }
}
