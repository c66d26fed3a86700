//! Clocks in µs. The network code never reads a clock itself: every call
//! takes `now`, or a [`Clock`] to read it from, so the same code runs on the
//! wall clock and on a simulated one (tests, fault injection, runs faster
//! than real time). The clocks are `motet-link`'s, so that transports, fault
//! injection and the network share one abstraction.

pub use motet_link::clock::{Clock, SimClock, WallClock};

/// A clock shared by the parts of a session (administrative requests, the
/// run that follows).
pub type SharedClock = std::sync::Arc<dyn Clock + Send + Sync>;

/// The wall clock, shared.
pub fn wall() -> SharedClock {
    std::sync::Arc::new(WallClock::new())
}
