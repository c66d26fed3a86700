//! `[tools.*]`: each tool's kind, settle time and on value.

use super::Source;
use crate::machine::{MachineError, Tool};
use crate::machine_file::MachineFile;
use motet_planner::ranges;
use motet_planner::ToolKind;

/// The machine's tools, in the file's order.
pub(super) fn tools(src: &Source, raw: &MachineFile) -> Result<Vec<Tool>, MachineError> {
    let mut tools = Vec::new();
    for (name, t) in &raw.tools {
        let t = t.get_ref();
        let kind = match t.kind.get_ref().as_str() {
            "pen" => ToolKind::Pen,
            "laser" => ToolKind::Laser,
            "spindle" => ToolKind::Spindle,
            other => {
                return Err(src.err(
                    t.kind.span(),
                    format!("tool {name}: unknown kind `{other}`; expected pen, laser or spindle"),
                ))
            }
        };
        let default_settle = match kind {
            ToolKind::Pen => 0.15,
            ToolKind::Spindle => 1.0,
            ToolKind::Laser => 0.0,
        };
        let settle = src.value_or(
            t.settle.as_ref(),
            ranges::SETTLE_S,
            format_args!("tool {name}: settle"),
            default_settle,
        )?;
        let on_value = t.on_value.as_ref().map_or(1.0, |v| *v.get_ref());
        if on_value.is_nan() {
            let span = t.on_value.as_ref().map_or(t.kind.span(), |v| v.span());
            return Err(src.err(
                span,
                format!("tool {name}: on_value must be a number from 0 to 1"),
            ));
        }
        tools.push(Tool {
            name: name.clone(),
            kind,
            settle,
            on_value: on_value.clamp(0.0, 1.0),
        });
    }

    Ok(tools)
}
