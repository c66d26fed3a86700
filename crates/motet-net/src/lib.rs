//! The node network on the host side: reaching nodes over links, pairing
//! them, synchronising their clocks, streaming a job to them in sealed
//! windows with a safe stop, and resuming after a stop. Also the simulated
//! node that runs the node firmware's endpoint in its own process.
//!
//! Everything here takes the time as an argument (see [`clock`]), so the same
//! code runs on the wall clock with real processes and on a simulated clock
//! in tests ([`loopback`]).

pub mod admin;
pub mod clock;
pub mod digest;
pub mod journal;
pub mod loopback;
pub mod medium;
pub mod modules;
pub mod node_clock;
pub mod pairing;
pub mod pairing_file;
pub mod peer;
pub(crate) mod plan_feed;
pub mod registry;
pub mod replay;
pub mod resume;
pub mod run;
pub mod run_record;
pub mod session;
pub mod sim_node;
pub(crate) mod source;
pub mod spawn;
pub(crate) mod tail;

pub use plan_feed::CommandSource;
pub use run::{LostNode, NetConfig, NetError, NetRun, Phase, RunIdentity, StopInfo, Tally};
