//! A dance watched as it runs, for as long as the watcher wants: what a
//! server runs for a hand-driven machine. The watcher sees the node's time
//! and the pen's place every few frames and says when to stop; the inputs
//! come from any [`InputSource`] (one that paces itself to the wall clock
//! makes the dance live).

use super::run::Dance;
use super::{DanceError, DanceOptions, DanceResult, InputSource};
use motet_graph::GraphFile;
use motet_host::Machine;

/// What the watcher sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DanceMoment {
    /// The node's time: the end of the last frame run, s.
    pub t_s: f64,
    /// The pen's x, y, mm (the machine's kinematics over the channels'
    /// steps; 0, 0 when the graph drives no x and y).
    pub xy: [f64; 2],
    /// Whether the pen is down (always when the graph has no pen channel).
    pub pen_down: bool,
}

/// Frames between which the drawing is let go of: a watched dance may run
/// for days, and its watcher keeps what it shows.
const FORGET_EVERY: u64 = 1 << 16;

/// Runs `graph` on a simulated node fed by `inputs`, calling `watch` every
/// `every` frames until it returns `false`; then reports as
/// [`super::run_dance`] does, over the frames run, with the strokes of
/// about the last 65,536 frames only (memory stays bounded).
pub fn watch_dance(
    machine: &Machine,
    graph: &GraphFile,
    inputs: &mut dyn InputSource,
    options: DanceOptions<'_>,
    every: u64,
    watch: &mut dyn FnMut(&DanceMoment) -> bool,
) -> Result<DanceResult, DanceError> {
    let mut dance = Dance::new(machine, graph, options)?;
    let every = every.max(1);
    let mut f = 0u64;
    loop {
        dance.frame(f as f64 * graph.frame_us, inputs)?;
        f += 1;
        if f.is_multiple_of(every) {
            let moment = DanceMoment {
                t_s: f as f64 * graph.frame_us * 1e-6,
                xy: dance.xy(),
                pen_down: dance.pen_down(),
            };
            if !watch(&moment) {
                break;
            }
        }
        if f.is_multiple_of(FORGET_EVERY) {
            dance.forget_drawing();
        }
    }
    Ok(dance.finish(f))
}
