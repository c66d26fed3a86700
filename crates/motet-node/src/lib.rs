//! The node runtime: what runs on every motet node, in firmware and in the
//! simulator alike.
//!
//! A node receives messages as bytes ([`Node::handle`]), keeps a queue of
//! trajectory segments and a queue of event changes, and on every frame
//! ([`Node::poll`]) tells its [`Board`] which steps to take and which tool
//! outputs to switch, each at its exact time within the frame. It never reads a
//! clock: the caller passes the time in.
#![no_std]
#![forbid(unsafe_code)]

pub mod board;
pub mod channel;
pub mod control;
pub mod drift;
pub mod endpoint;
pub mod graph;
pub mod group_watch;
pub mod node;
pub mod service;
pub mod storage;
pub mod tally;
pub mod time;
pub mod tool;

pub use board::Board;
pub use channel::Channel;
pub use endpoint::{Endpoint, EndpointStats};
pub use node::{
    Node, NodeGraph, NodeStatus, DEFAULT_QUEUE, GRAPH_COMPONENTS, GRAPH_MAPPINGS, MAX_CHANNELS,
    MAX_OUTPUTS_PER_POLL, MAX_STEPS_PER_UNIT, MAX_STEP_RATE, MAX_TOOLS,
};
pub use service::{Action, Handled, NodeConfig, Services};
pub use storage::{Flash, Persisted, RamFlash, RamStore, StorageError, Store};
pub use tally::{StepTally, Tallying};
