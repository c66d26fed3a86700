//! The run report: what the machine did, measured against its limits.

use serde::Serialize;

#[derive(Clone, Debug, Default, Serialize)]
pub struct AxisReport {
    pub name: String,
    /// Distance the axis moved, units.
    pub distance: f64,
    pub peak_velocity: f64,
    pub max_velocity: f64,
    pub peak_acceleration: f64,
    pub max_acceleration: f64,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct JointReport {
    pub name: String,
    pub peak_velocity: f64,
    pub max_velocity: Option<f64>,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct ActuatorReport {
    pub name: String,
    pub node: String,
    pub steps_per_unit: f64,
    /// Step pulses taken.
    pub steps: u64,
    /// Final position, steps.
    pub position: i64,
    /// Largest |ideal − executed| at step instants, steps.
    pub max_deviation_steps: f64,
    /// Largest |step time − ideal crossing time|, µs.
    pub max_step_time_error_us: f64,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    pub machine: String,
    pub job: String,
    /// Planned and executed duration, seconds.
    pub duration_s: f64,
    pub commands: usize,
    pub segments: usize,
    /// Moves that end at rest (the last one always does; others only where a
    /// stop was needed: reversals, pen lifts, dwells).
    pub rests: usize,
    pub tool_events: usize,
    /// Temperature, fan and coolant changes.
    pub aux_events: usize,
    /// Stops for the person (M0/M1, pen changes); the simulation resumes at once.
    pub pauses: usize,
    /// Distance along the path with the tool working, mm.
    pub tool_on_distance_mm: f64,
    /// Distance along the path with the tool off, mm.
    pub travel_distance_mm: f64,
    pub axes: Vec<AxisReport>,
    pub joints: Vec<JointReport>,
    pub actuators: Vec<ActuatorReport>,
    /// Largest distance between the executed and the commanded point at any
    /// step instant, mm (extruders excluded).
    pub max_path_deviation_mm: f64,
    pub max_deviation_steps: f64,
    pub max_step_time_error_us: f64,
    /// Times a node ran dry while moving (0 when the host keeps up).
    pub underruns: u32,
    /// Wall-clock seconds for planning plus simulation.
    pub wall_s: f64,
    /// Simulated seconds per wall-clock second.
    pub speed_factor: f64,
}

impl Report {
    /// A few lines for the terminal.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let dur = self.duration_s;
        let hms = format!(
            "{}h{:02}m{:05.2}s",
            (dur / 3600.0) as u64,
            ((dur % 3600.0) / 60.0) as u64,
            dur % 60.0
        );
        s += &format!(
            "{} on {}: {} ({} commands, {} segments)\n",
            self.job, self.machine, hms, self.commands, self.segments
        );
        s += &format!(
            "  path: {:.1} mm with the tool on, {:.1} mm travel\n",
            self.tool_on_distance_mm, self.travel_distance_mm
        );
        for a in &self.axes {
            s += &format!(
                "  axis {:<2} peak {:>8.2}/{:<8} u/s  {:>9.1}/{:<8} u/s²\n",
                a.name, a.peak_velocity, a.max_velocity, a.peak_acceleration, a.max_acceleration
            );
        }
        for a in &self.actuators {
            s += &format!(
                "  actuator {:<10} on {:<8} {:>12} steps\n",
                a.name, a.node, a.steps
            );
        }
        s += &format!(
            "  executed vs commanded: {:.4} mm max ({:.3} steps); step timing error {:.4} µs max\n",
            self.max_path_deviation_mm, self.max_deviation_steps, self.max_step_time_error_us
        );
        s += &format!(
            "  simulated in {:.2} s wall ({:.0}x real time)",
            self.wall_s, self.speed_factor
        );
        s
    }
}
