//! Building the virtual machine from its file: each section checked in
//! the order a reader meets it (motion settings, axes, the joints the
//! kinematics makes, actuators and their chains, tools, heaters, nodes, the
//! start),
//! with errors at their place in the file, then composed into a
//! [`Machine`]. One file per section.

mod actuators;
mod axes;
mod heaters;
mod joints;
mod motion;
mod nodes;
mod servo;
mod tools;

use crate::machine::{Machine, MachineError};
use crate::machine_file::MachineFile;
use motet_planner::ranges::ValueRange;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// Turns byte offsets into line and column for error messages.
pub(crate) struct Source<'a> {
    /// The file's path as errors print it.
    pub file: String,
    /// The whole file, which the TOML spans index.
    pub text: &'a str,
}

impl Source<'_> {
    /// An error at the start of `span` (a byte range into `text`), with
    /// its 1-based line and column in characters.
    pub fn err(&self, span: Range<usize>, message: impl Into<String>) -> MachineError {
        let at = span.start.min(self.text.len());
        let before = &self.text[..at];
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        MachineError {
            file: self.file.clone(),
            line,
            column,
            message: message.into(),
        }
    }

    /// `v` if it is in `range`, else an error at `span` that names `what`.
    pub(super) fn in_range(
        &self,
        span: Range<usize>,
        range: ValueRange,
        what: impl std::fmt::Display,
        v: f64,
    ) -> Result<f64, MachineError> {
        range
            .check(what, v)
            .map_err(|e| self.err(span, e.to_string()))
    }

    /// The file's value `v` if it is in `range`, else an error at its place
    /// that names `what`.
    pub(super) fn value(
        &self,
        v: &Spanned<f64>,
        range: ValueRange,
        what: impl std::fmt::Display,
    ) -> Result<f64, MachineError> {
        self.in_range(v.span(), range, what, *v.get_ref())
    }

    /// As [`Source::value`], or `default` where the file leaves it out.
    pub(super) fn value_or(
        &self,
        v: Option<&Spanned<f64>>,
        range: ValueRange,
        what: impl std::fmt::Display,
        default: f64,
    ) -> Result<f64, MachineError> {
        v.map_or(Ok(default), |v| self.value(v, range, what))
    }
}

/// Checks every section of `raw` in turn and composes the machine; the
/// first problem found is the error, at its place in `src`.
pub(crate) fn build(src: &Source, raw: MachineFile, file: &Path) -> Result<Machine, MachineError> {
    let m = &raw.motion;
    let kinematics =
        crate::machine_kinematics::kinematics_from(&m.kinematics, raw.geometry.as_ref())
            .map_err(|(span, message)| src.err(span, message))?;
    let settings = motion::settings(src, m)?;
    let axes = axes::axes(src, &raw, settings.profile)?;
    let mut joints = joints::joints(src, &raw, kinematics, &axes)?;
    let actuators = actuators::actuators(src, &raw, &mut joints, &axes)?;
    let tools = tools::tools(src, &raw)?;
    let mut heaters = heaters::heaters(src, &raw, &axes)?;
    let sensors = servo::sensors(src, &raw, &actuators)?;
    let nodes = nodes::nodes(src, &raw, &actuators, &tools, &sensors)?;
    let start = motion::start(src, m, &axes, kinematics, joints.kinematic_axes)?;
    let draw_feed = motion::draw_feed(src, m, &axes)?;
    let stop_horizon = motion::stop_horizon(src, m, &nodes)?;
    heaters::heater_nodes(src, &raw, &mut heaters, &nodes)?;
    let modules = crate::module::record::records(src, &raw.modules, &nodes)?;
    Ok(Machine {
        name: raw.name,
        description: raw.description,
        file: file.to_path_buf(),
        axes,
        kinematics,
        kinematic_axes: joints.kinematic_axes,
        joints: joints.joints,
        actuators,
        tools,
        nodes,
        junction_deviation: *m.junction_deviation.get_ref(),
        profile: settings.profile,
        tolerance: *m.tolerance.get_ref(),
        draw_feed,
        start,
        min_radius: *m.min_radius.get_ref(),
        lookahead: settings.lookahead,
        stop_horizon,
        heaters,
        sensors,
        modules,
    })
}
