//! The planned acceleration along each sensor's axis, recorded from the
//! segments the nodes run: what a sensor's readings (an accelerometer on
//! a servo's load) are plotted against, on the same clock. The simulator
//! and a networked run record it alike.

use crate::machine::Machine;
use crate::samples::{SamplePoint, Series};
use motet_trajectory::{JointMap, Segment, PIECES};

/// Per machine sensor, the planned acceleration of its actuator's axis
/// (units/s²), a step at every profile piece.
#[derive(Clone, Debug, Default)]
pub struct SensorPlan {
    /// One per machine sensor, by its index.
    pub series: Vec<Series>,
    /// Per machine sensor, the axis its actuator moves (none for a joint
    /// that is not one axis).
    axes: Vec<Option<usize>>,
}

impl SensorPlan {
    /// Nothing planned yet, for `machine`'s sensors.
    pub fn new(machine: &Machine) -> SensorPlan {
        let axes = machine
            .sensors
            .iter()
            .map(|s| {
                let a = &machine.actuators[s.actuator];
                match machine.joints[a.joint].map {
                    JointMap::Linear { coeffs } => coeffs.iter().position(|&c| c != 0.0),
                    _ => None,
                }
            })
            .collect();
        let series = machine
            .sensors
            .iter()
            .enumerate()
            .map(|(i, s)| {
                Series::new(
                    0,
                    motet_wire::control::SampleSource::Sensor(i as u8),
                    format!("planned acceleration ({})", s.name),
                )
            })
            .collect();
        SensorPlan { series, axes }
    }

    /// The planned acceleration of machine sensor `k`.
    pub fn get(&self, k: usize) -> Option<&Series> {
        self.series.get(k)
    }

    /// A segment the nodes run: its acceleration along each sensor's axis,
    /// piece by piece.
    pub fn segment(&mut self, seg: &Segment) {
        for (series, axis) in self.series.iter_mut().zip(&self.axes) {
            let Some(i) = *axis else { continue };
            let flat = |t_us, value| SamplePoint {
                t_us,
                value,
                lo: value,
                hi: value,
            };
            if seg.profile.length() <= 0.0 {
                // A dwell: standing still.
                series.push(flat(seg.t0, 0.0));
                series.push(flat(seg.t1(), 0.0));
                continue;
            }
            let u = seg.axis_rate(i);
            for k in 0..PIECES {
                let p = seg.profile.piece(k);
                if p.duration <= 0.0 {
                    continue;
                }
                let t0 = seg.t0 + p.t0 * 1e6;
                let t1 = t0 + p.duration * 1e6;
                for (t, a) in [(t0, p.a), (t1, p.a + p.j * p.duration)] {
                    series.push(flat(t, a * u));
                }
            }
        }
    }
}
