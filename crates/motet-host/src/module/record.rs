//! `[modules.NAME]`: the modules a machine file was composed from, each
//! under its node's name, so that a run can tell whether the modules on
//! the bus are still those (`motet run --nodes paired` names every
//! difference):
//!
//! ```toml
//! [modules.x]
//! order = 4                    # its place in the chain, 1 at the tool
//! uid = "5157000000000002"     # the node's unique id
//! firmware = "0.1.0"
//! digest = "8c0e2a51"          # of its description, as the module serves it
//! [modules.x.description]      # what it said of itself (a description file's keys)
//! kind = "stepper-axis"
//! ...
//! ```

use super::description::{from_file, DescriptionFile};
use crate::machine::MachineError;
use crate::machine_build::Source;
use motet_wire::describe::Description;
use serde::Deserialize;
use toml::Spanned;

/// One module record as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModuleRecordFile {
    order: Spanned<i64>,
    uid: Spanned<String>,
    #[serde(default)]
    firmware: Option<Spanned<String>>,
    digest: Spanned<String>,
    description: Spanned<DescriptionFile>,
}

/// A module the machine was composed from, as its file records it.
#[derive(Clone, Debug, PartialEq)]
pub struct ModuleRecord {
    /// The record's key: the name of the machine node the module is.
    pub node: String,
    /// Its place in the chain, 1 at the tool.
    pub order: usize,
    /// The node's unique id.
    pub uid: u64,
    /// Its firmware when composed, as text.
    pub firmware: Option<String>,
    /// What it said of itself.
    pub description: Description,
}

/// The file's module records, checked: each under a node of the machine,
/// orders 1, 2, … once each, uids once each, each description holding and
/// giving its recorded digest (a record edited by hand no longer
/// describes the module on the bus).
pub(crate) fn records(
    src: &Source,
    raw: &std::collections::BTreeMap<String, Spanned<ModuleRecordFile>>,
    nodes: &[crate::NodeSpec],
) -> Result<Vec<ModuleRecord>, MachineError> {
    let mut out: Vec<ModuleRecord> = Vec::new();
    for (name, r) in raw {
        let span = r.span();
        let r = r.get_ref();
        let at = |s: std::ops::Range<usize>, m: String| src.err(s, format!("modules.{name}: {m}"));
        if !nodes.iter().any(|n| n.name == *name) {
            return Err(at(
                span,
                format!("no [nodes.{name}]: a module record names the node the module is"),
            ));
        }
        let order = usize::try_from(*r.order.get_ref())
            .ok()
            .filter(|o| (1..=raw.len()).contains(o))
            .ok_or_else(|| {
                at(
                    r.order.span(),
                    format!("order must be from 1 to {} (one per module)", raw.len()),
                )
            })?;
        if let Some(twin) = out.iter().find(|o| o.order == order) {
            return Err(at(
                r.order.span(),
                format!("order {order} is module {}'s already", twin.node),
            ));
        }
        let uid = super::parse_uid(r.uid.get_ref())
            .ok_or_else(|| at(r.uid.span(), "uid must be hex (16 digits)".into()))?;
        if let Some(twin) = out.iter().find(|o| o.uid == uid) {
            return Err(at(
                r.uid.span(),
                format!(
                    "uid {} is module {}'s already: two records cannot be one device",
                    r.uid.get_ref(),
                    twin.node
                ),
            ));
        }
        let digest = u32::from_str_radix(r.digest.get_ref(), 16)
            .map_err(|_| at(r.digest.span(), "digest must be 8 hex digits".into()))?;
        let description = from_file(src, r.description.get_ref(), 0).map_err(|e| MachineError {
            file: e.file,
            line: e.line,
            column: e.column,
            message: format!("modules.{name}: description.{}: {}", e.field, e.message),
        })?;
        if description.digest() != digest {
            return Err(at(
                r.digest.span(),
                format!(
                    "the recorded description gives digest {:08x}, not {digest:08x}: it was edited, and no longer says what the module said; compose the machine again (`motet machine from-scan`)",
                    description.digest()
                ),
            ));
        }
        out.push(ModuleRecord {
            node: name.clone(),
            order,
            uid,
            firmware: r.firmware.as_ref().map(|f| f.get_ref().clone()),
            description,
        });
    }
    out.sort_by_key(|r| r.order);
    Ok(out)
}
