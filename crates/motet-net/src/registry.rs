//! Host-side drivers by node kind: which kinds the host can drive, and
//! whether a node can serve a machine node (enough channels and tools, a
//! queue the host's window fits in).

use motet_host::NodeSpec;
use motet_wire::service::{kind, Info};

/// What the host knows about driving one kind of node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Driver {
    pub kind: &'static str,
    /// Follows the trajectory with step channels.
    pub trajectory: bool,
    pub description: &'static str,
}

/// Every kind this host drives.
pub const DRIVERS: &[Driver] = &[
    Driver {
        kind: kind::STEPPER,
        trajectory: true,
        description: "step/direction channels and tool outputs following the trajectory",
    },
    Driver {
        kind: kind::SIM,
        trajectory: true,
        description: "a simulated stepper node",
    },
];

/// The driver for `kind`, if the host has one.
pub fn driver(kind: &str) -> Option<&'static Driver> {
    DRIVERS.iter().find(|d| d.kind == kind)
}

/// Why a node cannot serve a machine node.
pub fn check(spec: &NodeSpec, info: &Info) -> Result<&'static Driver, String> {
    let d = driver(info.kind.as_str()).ok_or_else(|| {
        format!(
            "node kind `{}` has no driver on this host (known: {})",
            info.kind,
            DRIVERS
                .iter()
                .map(|d| d.kind)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    if (info.channels as usize) < spec.actuators.len() {
        return Err(format!(
            "the machine gives it {} actuators but it has {} channels",
            spec.actuators.len(),
            info.channels
        ));
    }
    if (info.tools as usize) < spec.tools.len() {
        return Err(format!(
            "the machine gives it {} tools but it has {} outputs",
            spec.tools.len(),
            info.tools
        ));
    }
    if (info.queue_capacity as usize) < spec.queue {
        return Err(format!(
            "the machine file asks for a queue of {} but the node holds {}",
            spec.queue, info.queue_capacity
        ));
    }
    Ok(d)
}
