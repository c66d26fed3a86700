//! Checks a bot's executed points against motet's plan of the same job:
//! each point's step position against the planned position at its time on
//! the bot's motion clock. Written apart from [`crate::points`] (it reads
//! the machine's actuators, not the axis map) so that it checks that code.

use crate::bot::Executed;
use motet_host::Machine;
use motet_planner::{Command, Planned, Planner};
use motet_trajectory::Segment;

/// The planned path of a job on a machine, in bot steps.
pub struct PlannedPath {
    segments: Vec<Segment>,
    /// Per bot axis X Y Z A B: the machine axis and its steps per unit.
    axes: [Option<(usize, f64)>; 5],
}

impl PlannedPath {
    /// Plans `commands` on `machine` as the driver does (from its start at
    /// time 0).
    pub fn plan(
        machine: &Machine,
        commands: &[Command],
    ) -> Result<PlannedPath, motet_planner::PlanError> {
        let mut p = Planner::new(machine.limits(), machine.start, 0.0);
        let mut segments = Vec::new();
        let mut take = |p: &mut Planner| {
            while let Some(x) = p.pop() {
                if let Planned::Segment(s) = x {
                    segments.push(s);
                }
            }
        };
        for c in commands {
            p.push(c)?;
            take(&mut p);
        }
        p.finish();
        take(&mut p);
        let mut axes = [None; 5];
        for a in &machine.actuators {
            let slot = ["x", "y", "z", "e", "b"]
                .iter()
                .position(|n| *n == machine.joints[a.joint].name);
            if let (Some(slot), Some(axis)) = (slot, machine.axis(&machine.joints[a.joint].name)) {
                axes[slot] = Some((axis, a.steps_per_unit));
            }
        }
        Ok(PlannedPath { segments, axes })
    }

    /// The plan's duration, µs.
    pub fn duration_us(&self) -> f64 {
        self.segments.last().map_or(0.0, |s| s.t1())
    }

    /// Planned position at `t` µs, in (unrounded) steps per bot axis.
    pub fn steps_at(&self, t: f64) -> [f64; 5] {
        let i = self.segments.partition_point(|s| s.t0 <= t);
        let p = match i {
            0 => self.segments.first().map(|s| s.start),
            i => Some(self.segments[i - 1].position_at(t)),
        };
        std::array::from_fn(|k| match (self.axes[k], p) {
            (Some((axis, spu)), Some(p)) => p[axis] * spu,
            _ => 0.0,
        })
    }

    /// The largest distance, in steps on any axis, between an executed
    /// point and the plan at its time.
    pub fn max_deviation(&self, executed: &[Executed]) -> f64 {
        executed
            .iter()
            .map(|e| {
                let want = self.steps_at(e.clock_us as f64);
                (0..5)
                    .map(|k| (e.steps[k] as f64 - want[k]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max)
    }
}
