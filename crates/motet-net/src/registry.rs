//! Host-side drivers by node kind: which kinds the host can drive, and
//! whether a node can serve a machine node (enough channels and tools, a
//! queue the host's window fits in).

use motet_host::{Machine, NodeSpec};
use motet_wire::service::{kind, Info};

/// What the host knows about driving one kind of node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Driver {
    /// The node kind it drives, as a node names itself in `Info`.
    pub kind: &'static str,
    /// Follows the trajectory with step channels.
    pub trajectory: bool,
    /// One line for `motet nodes scan`.
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
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Mismatch {
    /// The host has no driver for the node's kind.
    #[error("node kind `{kind}` has no driver on this host (known: {known})")]
    NoDriver {
        /// The kind the node named.
        kind: String,
        /// The kinds this host drives, comma-separated.
        known: String,
    },
    /// The node has fewer step channels than the machine node has actuators.
    #[error("the machine gives it {want} actuators but it has {have} channels")]
    Channels {
        /// Actuators the machine file gives the node.
        want: usize,
        /// Step channels the node has.
        have: u8,
    },
    /// The node has fewer tool outputs than the machine node has tools.
    #[error("the machine gives it {want} tools but it has {have} outputs")]
    Tools {
        /// Tools the machine file gives the node.
        want: usize,
        /// Tool outputs the node has.
        have: u8,
    },
    /// The node's segment queue is smaller than the machine file asks for.
    #[error("the machine file asks for a queue of {want} but the node holds {have}")]
    Queue {
        /// Queue places the machine file asks for (`queue`).
        want: usize,
        /// Queue places the node has.
        have: u16,
    },
    /// An actuator would need to step faster than the node's channels can.
    #[error("actuator {actuator} steps up to {hz:.0} times a second at its joint's top speed, but the node's channels reach {max} ({board}): lower its max_velocity or its microstepping")]
    StepRate {
        /// The actuator's name in the machine file.
        actuator: String,
        /// Steps per second it needs at its joint's top speed.
        hz: f64,
        /// Steps per second the node's channels reach.
        max: u32,
        /// The node's board (`its board` when it names none).
        board: String,
    },
}

/// The driver for a node (that answered `info`) that can serve machine
/// node `spec` of `machine`, or why it cannot: it needs a driver for its
/// kind, enough channels, tools and queue, and step rates its channels
/// reach.
pub fn check(machine: &Machine, spec: &NodeSpec, info: &Info) -> Result<&'static Driver, Mismatch> {
    let d = driver(info.kind.as_str()).ok_or_else(|| Mismatch::NoDriver {
        kind: info.kind.to_string(),
        known: DRIVERS
            .iter()
            .map(|d| d.kind)
            .collect::<Vec<_>>()
            .join(", "),
    })?;
    if (info.channels as usize) < spec.actuators.len() {
        return Err(Mismatch::Channels {
            want: spec.actuators.len(),
            have: info.channels,
        });
    }
    if (info.tools as usize) < spec.tools.len() {
        return Err(Mismatch::Tools {
            want: spec.tools.len(),
            have: info.tools,
        });
    }
    if (info.queue_capacity as usize) < spec.queue {
        return Err(Mismatch::Queue {
            want: spec.queue,
            have: info.queue_capacity,
        });
    }
    if info.max_step_hz > 0 {
        for &a in &spec.actuators {
            let act = &machine.actuators[a];
            if let Some(hz) = act.max_step_hz.filter(|&hz| hz > info.max_step_hz as f64) {
                return Err(Mismatch::StepRate {
                    actuator: act.name.clone(),
                    hz,
                    max: info.max_step_hz,
                    board: if info.board.is_empty() {
                        "its board".to_string()
                    } else {
                        info.board.to_string()
                    },
                });
            }
        }
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
            board: Kind::new(),
            max_step_hz: 0,
        }
    }

    fn board(max_step_hz: u32) -> Info {
        Info {
            board: Kind::try_from("mps2-an500").unwrap(),
            max_step_hz,
            ..info("stepper", 8, 4, 64)
        }
    }

    #[test]
    fn nodes_are_checked_against_their_machine_node() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/printer.toml");
        let machine = Machine::load(&path).unwrap();
        let fastest = machine
            .actuators
            .iter()
            .filter_map(|a| a.max_step_hz)
            .fold(0.0, f64::max);
        assert!(fastest > 1000.0);
        let spec = NodeSpec {
            name: "mainboard".into(),
            actuators: vec![0, 1, 2, 3],
            tools: vec![0],
            queue: 64,
            frame_us: 40.0,
            fixed_time_us: 0.0,
            sensors: vec![],
            sample_budget: 400.0,
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
            (board(fastest.ceil() as u32), None),
            (
                board(fastest as u32 - 1),
                Some("but the node's channels reach"),
            ),
        ];
        for (i, want) in cases {
            match (check(&machine, &spec, &i), want) {
                (Ok(_), None) => {}
                (Err(e), Some(w)) => assert!(e.to_string().contains(w), "{}: {e}", i.kind),
                (got, want) => panic!("{}: {got:?}, expected {want:?}", i.kind),
            }
        }
    }
}
