//! The simulator: runs a job on a machine's nodes, using the same node code as
//! firmware, against a simulated plant; reports how the machine moved and draws
//! what it did.

mod collector;
pub mod dance;
pub mod heaters;
mod ideal;
pub mod loops;
pub mod node_plant;
pub mod path;
pub mod plant;
pub mod plant_thread;
pub mod plots;
pub mod report;
pub mod report_heaters;
pub mod run;
pub mod servo;
pub mod tune;

pub use report::{format_duration, Report};
pub use run::{
    plant_for, simulate, simulate_stream, Held, SimError, SimMachine, SimResult, StreamRun,
    NODE_QUEUE,
};
