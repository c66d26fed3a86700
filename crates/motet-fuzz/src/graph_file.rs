//! Graph files: validated as `motet dance` does; a graph that validates is
//! built on a simulated node (which must accept every message the host made
//! from it) and run for a few hundred frames with moving inputs.

use crate::text;
use motet_graph::GraphFile;
use motet_host::Machine;
use motet_sim::dance::{run_dance, DanceError, InputSource};
use std::path::Path;
use std::sync::OnceLock;

/// Simulated time each graph runs, seconds.
const SECONDS: f64 = 0.01;

fn machine() -> &'static Machine {
    static M: OnceLock<Machine> = OnceLock::new();
    M.get_or_init(|| {
        let text = include_str!("../../../examples/dance/harmonograph/machine.toml");
        Machine::parse(text, Path::new("examples/dance/harmonograph/machine.toml"))
            .expect("the example machine is valid")
    })
}

/// Every input swings, each at its own rate, so filters, thresholds and
/// buttons all see change.
struct Swing;

impl InputSource for Swing {
    fn values(&mut self, t_s: f64, out: &mut [f64]) {
        for (i, v) in out.iter_mut().enumerate() {
            *v = 500.0 * (t_s * 300.0 * (i + 1) as f64).sin();
        }
    }
}

/// Runs graph-file bytes through validation and, when they validate, a node.
pub fn graph_file(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let lines = text.split('\n').count();
    let graph = match GraphFile::parse(text, "fuzz.graph.toml") {
        Ok(g) => g,
        Err(e) => {
            assert!(
                (1..=lines + 1).contains(&e.line) && e.column >= 1,
                "graph file error placed at {}:{} of {lines} lines: {e}",
                e.line,
                e.column
            );
            assert!(!e.message.trim().is_empty(), "an empty graph file error");
            return;
        }
    };
    match run_dance(machine(), &graph, &mut Swing, SECONDS, &mut |_| {}) {
        Ok(_) | Err(DanceError::Setup(_)) => {}
        Err(e @ DanceError::Refused { .. }) => {
            panic!("the node refused a graph the host validated: {e}")
        }
        Err(e) => panic!("a graph run without a job or trace failed: {e}"),
    }
}
