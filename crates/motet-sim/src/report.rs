//! The run report: what the machine did, measured against its limits.

use serde::Serialize;

/// One machine axis over the job, against its limits.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AxisReport {
    /// The axis' name in the machine file (`x`, `y`, `e`...).
    pub name: String,
    /// Distance the axis moved, units.
    pub distance: f64,
    /// Fastest the plan moved it, units/s (never above `max_velocity` when
    /// the planner keeps its limits).
    pub peak_velocity: f64,
    /// Its limit from the machine file, units/s.
    pub max_velocity: f64,
    /// Largest acceleration the plan gave it, units/s².
    pub peak_acceleration: f64,
    /// Its limit from the machine file, units/s².
    pub max_acceleration: f64,
}

/// A joint that is not simply one axis (an arm's angle, a belt of a
/// CoreXY), over the job.
#[derive(Clone, Debug, Default, Serialize)]
pub struct JointReport {
    /// The joint's name in the machine file.
    pub name: String,
    /// Fastest the plan moved it, joint units/s.
    pub peak_velocity: f64,
    /// Its limit from the machine file, joint units/s (none: unbounded).
    pub max_velocity: Option<f64>,
}

/// One motor over the job, and how closely its steps followed the plan.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ActuatorReport {
    /// The actuator's name in the machine file.
    pub name: String,
    /// The node that steps it (empty when no node lists it).
    pub node: String,
    /// Steps per joint unit; negative when the chain inverts.
    pub steps_per_unit: f64,
    /// Step pulses taken.
    pub steps: u64,
    /// Final position, steps.
    pub position: i64,
    /// Largest |ideal − executed| at step instants, steps.
    pub max_deviation_steps: f64,
    /// Largest |step time − ideal crossing time|, µs.
    pub max_step_time_error_us: f64,
    /// A servo's following error, encoder counts (its `steps_per_unit`
    /// are counts; `steps` and the step figures are then 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub following: Option<FollowingReport>,
}

/// How a servo actuator followed the trajectory, as the observer measured
/// it at every tick (the encoder's count against the ideal trajectory),
/// encoder counts.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FollowingReport {
    /// Its loop's rate, Hz.
    pub loop_hz: f64,
    /// Ticks observed.
    pub ticks: u64,
    /// Largest |error| while the trajectory cruises.
    pub max_cruise_counts: f64,
    /// Largest once a cruise has held its speed for 5 ms (the loop settled
    /// after a corner's jump in speed or a ramp).
    pub max_settled_cruise_counts: f64,
    /// Largest while it accelerates or decelerates.
    pub max_accel_counts: f64,
    /// Largest at rest.
    pub max_rest_counts: f64,
    /// Root mean square while moving.
    pub rms_counts: f64,
    /// Samples the node sent upstream, lost on the way, and their bytes a
    /// second of the job (payload).
    pub samples: u64,
    /// Samples lost on the node.
    pub samples_dropped: u64,
    /// Payload bytes a second the samples took.
    pub sample_bytes_per_s: f64,
}

/// How a simulated job went; written as `report.json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    /// The machine's name.
    pub machine: String,
    /// The job, as named on the command line.
    pub job: String,
    /// Planned and executed duration, seconds.
    pub duration_s: f64,
    /// Commands read from the job.
    pub commands: usize,
    /// Motion segments the planner made of them and the nodes ran.
    pub segments: usize,
    /// Moves that end at rest (the last one always does; others only where a
    /// stop was needed: reversals, pen lifts, dwells).
    pub rests: usize,
    /// Tool output changes (pen, laser, spindle, extruder).
    pub tool_events: usize,
    /// Temperature, fan and coolant changes.
    pub aux_events: usize,
    /// Stops for the person (M0/M1, pen changes); the simulation resumes at once.
    pub pauses: usize,
    /// Distance along the path with the tool working, mm.
    pub tool_on_distance_mm: f64,
    /// Distance along the path with the tool off, mm.
    pub travel_distance_mm: f64,
    /// Every machine axis, in the machine file's order.
    pub axes: Vec<AxisReport>,
    /// Joints that are not one axis one to one, in the machine file's order.
    pub joints: Vec<JointReport>,
    /// Every actuator, in the machine file's order.
    pub actuators: Vec<ActuatorReport>,
    /// Largest distance between the executed and the commanded point at any
    /// step instant, mm (extruders excluded).
    pub max_path_deviation_mm: f64,
    /// The largest of the actuators' `max_deviation_steps`, steps (half a
    /// step is exact stepping).
    pub max_deviation_steps: f64,
    /// The largest of the actuators' `max_step_time_error_us`, µs.
    pub max_step_time_error_us: f64,
    /// Times a node ran dry while moving (0 when the host keeps up).
    pub underruns: u32,
    /// Heaters a node drives.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub heaters: Vec<crate::report_heaters::HeaterReport>,
    /// Moves with a coordinate beyond travel by less than half a step,
    /// clamped onto it when the job was checked.
    pub clamped_moves: usize,
    /// The farthest such a coordinate was beyond travel, mm (0 if none).
    pub max_clamp_mm: f64,
    /// Wall-clock seconds for planning plus simulation.
    pub wall_s: f64,
    /// Simulated seconds per wall-clock second (wall time counted as at
    /// least a microsecond, so the figure stays finite).
    pub speed_factor: f64,
    /// The plots written beside `path.png` (servo, sensor, heater), by
    /// file name.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub plots: Vec<String>,
}

/// A duration as `1h02m03.45s`; durations that are not finite numbers
/// (which the planner never produces) as `?`.
pub fn format_duration(seconds: f64) -> String {
    if !seconds.is_finite() {
        return "?".into();
    }
    let sign = if seconds < 0.0 { "-" } else { "" };
    // Hundredths, rounded once, so 59.999 s is 1m00.00s and not 0m60.00s.
    let cs = (seconds.abs() * 100.0).round();
    let h = (cs / 360_000.0).floor();
    let m = ((cs - h * 360_000.0) / 6_000.0).floor();
    let s = (cs - h * 360_000.0 - m * 6_000.0) / 100.0;
    format!("{sign}{h:.0}h{m:02.0}m{s:05.2}s")
}

/// A number for the summary: `?` when it is not finite.
fn finite(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        "?".into()
    }
}

impl Report {
    /// A few lines for the terminal.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let hms = format_duration(self.duration_s);
        s += &format!(
            "{} on {}: {} ({} commands, {} segments)\n",
            self.job, self.machine, hms, self.commands, self.segments
        );
        s += &format!(
            "  path: {} mm with the tool on, {} mm travel\n",
            finite(self.tool_on_distance_mm, 1),
            finite(self.travel_distance_mm, 1)
        );
        for a in &self.axes {
            s += &format!(
                "  axis {:<2} peak {:>8}/{:<8} u/s  {:>9}/{:<8} u/s²\n",
                a.name,
                finite(a.peak_velocity, 2),
                motet_planner::ranges::number(a.max_velocity),
                finite(a.peak_acceleration, 1),
                motet_planner::ranges::number(a.max_acceleration)
            );
        }
        for a in &self.actuators {
            match &a.following {
                Some(f) => {
                    s += &format!(
                        "  actuator {:<10} on {:<8} servo at {} Hz: following error {} counts max cruising ({} settled), {} accelerating, {} at rest, {} rms\n",
                        a.name,
                        a.node,
                        finite(f.loop_hz, 0),
                        finite(f.max_cruise_counts, 2),
                        finite(f.max_settled_cruise_counts, 2),
                        finite(f.max_accel_counts, 2),
                        finite(f.max_rest_counts, 2),
                        finite(f.rms_counts, 2)
                    );
                }
                None => {
                    s += &format!(
                        "  actuator {:<10} on {:<8} {:>12} steps\n",
                        a.name, a.node, a.steps
                    )
                }
            }
        }
        s += &format!(
            "  executed vs commanded: {} mm max ({} steps); step timing error {} µs max\n",
            finite(self.max_path_deviation_mm, 4),
            finite(self.max_deviation_steps, 3),
            finite(self.max_step_time_error_us, 4)
        );
        if self.clamped_moves > 0 {
            s += &format!(
                "  {} move(s) clamped onto the travel, by {} mm at most (less than half a step)\n",
                self.clamped_moves,
                motet_planner::ranges::number(self.max_clamp_mm)
            );
        }
        s += &crate::report_heaters::summary(&self.heaters);
        s += &format!(
            "  simulated in {} s wall ({}x real time)",
            finite(self.wall_s, 2),
            finite(self.speed_factor, 0)
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_print_as_hours_minutes_seconds_or_not_at_all() {
        for (s, want) in [
            (0.0, "0h00m00.00s"),
            (59.999, "0h01m00.00s"),
            (3600.0, "1h00m00.00s"),
            (93_610.5, "26h00m10.50s"),
            (30.0 * 86_400.0, "720h00m00.00s"),
            (1e-300, "0h00m00.00s"),
            (-61.0, "-0h01m01.00s"),
            (f64::NAN, "?"),
            (f64::INFINITY, "?"),
        ] {
            assert_eq!(format_duration(s), want, "{s}");
        }
    }

    #[test]
    fn a_summary_never_prints_nan_or_infinity() {
        let r = Report {
            duration_s: f64::NAN,
            tool_on_distance_mm: f64::INFINITY,
            speed_factor: f64::INFINITY,
            max_deviation_steps: f64::NAN,
            axes: vec![AxisReport {
                name: "x".into(),
                peak_velocity: f64::NAN,
                max_velocity: 1e-300,
                ..Default::default()
            }],
            ..Default::default()
        };
        let s = r.summary();
        assert!(!s.contains("NaN") && !s.contains("inf"), "{s}");
        assert!(s.contains("1e-300"), "{s}");
    }
}
