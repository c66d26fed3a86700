//! Machines from modules on the network: modules found and described over
//! datagrams ([`scan`]), the bus checked against a machine file's records,
//! and the live watch that notices a module added, removed or replaced
//! while the host is connected ([`watch`]), beside a run ([`run_watch`])
//! or on its own links ([`run_watch::IdleWatch`]). The composition,
//! viability and diff themselves are `motet_host::module`'s.

pub mod run_watch;
pub mod scan;
pub mod watch;

pub use run_watch::{watch_run, IdleWatch};
pub use scan::{check_bus, describe, follow, scan_links, scan_modules, ModuleError, Scanned};
pub use watch::{ModuleWatch, Probe, WatchConfig, WatchReport};
