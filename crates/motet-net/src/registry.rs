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

#[cfg(test)]
mod tests {
    use super::*;
    use motet_wire::service::{Info, Kind, Version};

    fn info(kind: &str, channels: u8, tools: u8, queue: u16) -> Info {
        Info {
            kind: Kind::try_from(kind).unwrap(),
            firmware: Version::default(),
            uid: 1,
            address: 2,
            protocol_min: 1,
            protocol_max: 1,
            queue_capacity: queue,
            channels,
            tools,
        }
    }

    #[test]
    fn nodes_are_checked_against_their_machine_node() {
        let spec = NodeSpec {
            name: "mainboard".into(),
            actuators: vec![0, 1, 2, 3],
            tools: vec![0],
            queue: 64,
            frame_us: 40.0,
        };
        // (node, expected error part; None: accepted)
        let cases = [
            (info("stepper", 8, 4, 64), None),
            (info("sim", 4, 1, 64), None),
            (info("toaster", 8, 4, 64), Some("no driver on this host")),
            (
                info("stepper", 3, 4, 64),
                Some("4 actuators but it has 3 channels"),
            ),
            (
                info("stepper", 8, 0, 64),
                Some("1 tools but it has 0 outputs"),
            ),
            (
                info("stepper", 8, 4, 16),
                Some("queue of 64 but the node holds 16"),
            ),
        ];
        for (i, want) in cases {
            match (check(&spec, &i), want) {
                (Ok(_), None) => {}
                (Err(e), Some(w)) => assert!(e.contains(w), "{}: {e}", i.kind),
                (got, want) => panic!("{}: {got:?}, expected {want:?}", i.kind),
            }
        }
    }
}
