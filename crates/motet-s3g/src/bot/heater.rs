//! The simulated heater the bot warms: the first-order model shared with
//! `motet serve`'s heaters ([`motet_host::heater`]).

pub use motet_host::heater::{Heater, AMBIENT_C, READY_WITHIN_C};
