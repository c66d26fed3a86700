//! Hostile-input harnesses: one function per input format motet reads, each
//! taking arbitrary bytes and driving the public API end to end the way the
//! command line (or a node) would, then checking what must hold whatever the
//! input: no panic, a located error or a result that keeps its invariants
//! (round trips where the format has one, a node that refuses without
//! changing its queues).
//!
//! The cargo-fuzz project in `fuzz/` calls these functions from one libFuzzer
//! target each; `tests/corpus.rs` runs every file of `fuzz/corpus/<target>/`
//! through them and a short deterministic mutation run on stable Rust, so a
//! regression fails the ordinary test suite. A harness panics exactly when it
//! found a defect.
//!
//! Work per input is bounded ([`MAX_INPUT`] bytes, a bounded prefix of each
//! planned job, a bounded stretch of simulated time) so that a fuzzer spends
//! its time on many inputs rather than on one long job.

pub mod describe_wire;
mod example;
pub mod firmware_image;
pub mod gcode;
pub mod graph_file;
pub mod journal;
pub mod machine_file;
pub mod module_description;
pub mod mutate;
pub mod pairing_file;
mod plan;
pub mod svg;
pub mod wire_frame;

pub use describe_wire::describe_wire;
pub use firmware_image::firmware_image;
pub use gcode::gcode;
pub use graph_file::graph_file;
pub use journal::journal;
pub use machine_file::machine_file;
pub use module_description::module_description;
pub use pairing_file::pairing_file;
pub use svg::svg;
pub use wire_frame::wire_frame;

/// Inputs are cut to this many bytes: longer ones exercise nothing the first
/// 64 KiB do not, and only slow the fuzzer down.
pub const MAX_INPUT: usize = 64 * 1024;

/// A harness: arbitrary bytes in, a panic on a defect.
pub type Harness = fn(&[u8]);

/// Every target by name, as `fuzz/` and the corpus tests name them.
pub const TARGETS: &[(&str, Harness)] = &[
    ("gcode", gcode),
    ("svg", svg),
    ("machine_file", machine_file),
    ("graph_file", graph_file),
    ("pairing_file", pairing_file),
    ("journal", journal),
    ("firmware_image", firmware_image),
    ("wire_frame", wire_frame),
    ("module_description", module_description),
    ("describe_wire", describe_wire),
];

/// The harness called `name`.
pub fn target(name: &str) -> Option<Harness> {
    TARGETS.iter().find(|(n, _)| *n == name).map(|(_, h)| *h)
}

/// The input cut to [`MAX_INPUT`].
fn bounded(data: &[u8]) -> &[u8] {
    &data[..data.len().min(MAX_INPUT)]
}

/// The input as text (cut to [`MAX_INPUT`] on a character boundary), or
/// `None` when it is not UTF-8: every text format motet reads refuses such
/// bytes before parsing, and the corpus tests check that path separately.
fn text(data: &[u8]) -> Option<&str> {
    match std::str::from_utf8(bounded(data)) {
        Ok(t) => Some(t),
        // A cut through a multi-byte character: keep the whole ones.
        Err(e) if e.error_len().is_none() => std::str::from_utf8(&data[..e.valid_up_to()]).ok(),
        Err(_) => None,
    }
}
