//! `motet serve`: a long-running host that owns one machine and its nodes
//! ([`session::Session`]), with the jobs uploaded to it ([`jobs::JobStore`]),
//! served over HTTP and a WebSocket to programs and to the browser page
//! embedded here (`docs/api.md` documents the API; `openapi.json` is its
//! schema), and to other programs through protocol adapters
//! ([`device`]; docs/compat.md): to G-code senders as a grbl 1.1 device
//! ([`grbl`]), to the AxiDraw software as an EiBotBoard ([`ebb`]), to
//! printer hosts (Moonraker) as Klipper's API server on a Unix socket
//! ([`klipper`]) and to print hosts (OctoPrint) as a Marlin-style printer
//! ([`marlin`]).
//!
//! The session is plain, synchronous code driven by a clock thread
//! ([`server::Server`]); the HTTP side (axum on tokio) only takes a lock,
//! acts, and answers, so nothing a client does can hold the machine up.

pub mod auth;
pub mod device;
pub mod ebb;
pub mod engine;
pub mod events;
pub mod graph;
pub mod grbl;
mod http;
pub mod jobs;
pub mod klipper;
pub mod marlin;
pub mod persist;
pub mod preview;
pub mod server;
pub mod session;

pub use engine::{
    linked_config, serve_config, LinkedNodes, Nodes, PairOutcome, PairRefusal, SimNodes,
};
pub use http::ROUTES;
pub use server::{Server, ServerConfig};
pub use session::{ActionError, Session, State, Status};
