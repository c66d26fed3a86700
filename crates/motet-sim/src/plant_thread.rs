//! The plant on a thread of its own, for whole-job runs.
//!
//! A simulation's time splits about evenly between the nodes (solving every
//! step) and the plant (checking every step and drawing the executed path).
//! Neither waits on the other within a job: the nodes never read the plant,
//! and the plant needs only the segments planned and the nodes' outputs, in
//! order. So [`simulate_stream`](crate::simulate_stream) runs the plant on a
//! second thread, fed in batches through a bounded channel: the two halves
//! run side by side, and memory stays bounded because the channel is.
//!
//! The results are those of the plant run in line: it sees the same
//! segments and the same outputs in the same order. A batch may carry
//! segments planned after some of its outputs; the plant follows the front
//! segment by time, so a segment held earlier changes nothing.

use crate::plant::{Plant, Stamped};
use crate::run::Held;
use motet_render::Stroke;
use motet_trajectory::Segment;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};

/// Where a simulated machine's plant takes its inputs: the plant itself,
/// or a link to the thread it runs on.
pub trait PlantSink {
    /// A segment was sent to the nodes.
    fn planned(&mut self, seg: Segment);
    /// Where the nodes put their outputs: each node's in time order, and
    /// all of them before [`PlantSink::applied`] is told their time.
    fn outputs(&mut self) -> &mut Vec<Stamped>;
    /// Every node's outputs before `until` (µs) are in
    /// [`PlantSink::outputs`]: the plant may take them.
    fn applied(&mut self, until: f64);
}

impl PlantSink for Plant {
    fn planned(&mut self, seg: Segment) {
        Plant::planned(self, seg);
    }

    fn outputs(&mut self) -> &mut Vec<Stamped> {
        &mut self.inbox
    }

    fn applied(&mut self, until: f64) {
        let mut outputs = std::mem::take(&mut self.inbox);
        self.apply(&mut outputs);
        outputs.clear();
        self.inbox = outputs;
        self.applied_until(until);
    }
}

/// Outputs gathered before a batch goes to the plant's thread: large
/// enough that handing over costs little per step, small enough to stay in
/// cache.
const BATCH_OUTPUTS: usize = 8192;

/// Segments planned before a batch goes, whatever its outputs: keeps the
/// plant's window within the bound of ARCHITECTURE.md's invariant.
const BATCH_SEGMENTS: usize = 16;

/// Batches in flight between the threads at most.
const IN_FLIGHT: usize = 2;

struct Batch {
    planned: Vec<Segment>,
    outputs: Vec<Stamped>,
    until: f64,
}

/// The host side of the plant's thread.
pub struct PlantLink {
    /// `None` once closed.
    tx: Option<SyncSender<Batch>>,
    /// Output buffers the plant's thread is done with, for reuse.
    spare: Receiver<Vec<Stamped>>,
    planned: Vec<Segment>,
    outputs: Vec<Stamped>,
    until: f64,
}

impl PlantSink for PlantLink {
    fn planned(&mut self, seg: Segment) {
        self.planned.push(seg);
        if self.planned.len() >= BATCH_SEGMENTS {
            self.flush();
        }
    }

    fn outputs(&mut self) -> &mut Vec<Stamped> {
        &mut self.outputs
    }

    fn applied(&mut self, until: f64) {
        self.until = until;
        if self.outputs.len() >= BATCH_OUTPUTS {
            self.flush();
        }
    }
}

impl PlantLink {
    /// Hands what is gathered to the plant's thread (waiting while
    /// `IN_FLIGHT` batches are ahead of it).
    pub fn flush(&mut self) {
        if self.planned.is_empty() && self.outputs.is_empty() {
            return;
        }
        let fresh = self.spare.try_recv().unwrap_or_default();
        let batch = Batch {
            planned: std::mem::take(&mut self.planned),
            outputs: std::mem::replace(&mut self.outputs, fresh),
            until: self.until,
        };
        // A plant thread that is gone has panicked; joining it says so.
        if let Some(tx) = &self.tx {
            let _ = tx.send(batch);
        }
    }

    /// Hands over what is gathered and ends the plant's run: its thread
    /// finishes the batches in flight, the last stroke, and returns.
    pub fn close(&mut self) {
        self.flush();
        self.tx = None;
    }
}

/// The plant's side: what it ran, and the most it held.
pub struct PlantRun {
    /// The plant as the run left it (its statistics and path deviation).
    pub plant: Plant,
    /// The most the plant held at once (its `node_segments` is 0: the
    /// nodes are not the plant's).
    pub held: Held,
}

/// Batches of finished strokes in flight to the drawing thread at most.
const STROKES_IN_FLIGHT: usize = 64;

/// The threads of a plant's run, to be joined once its link is closed.
pub struct PlantThreads<'scope> {
    plant: std::thread::ScopedJoinHandle<'scope, PlantRun>,
    draw: std::thread::ScopedJoinHandle<'scope, ()>,
}

impl PlantThreads<'_> {
    /// Waits for the plant to finish the batches it was given and for the
    /// last stroke to be drawn; a panic on either thread is passed on.
    pub fn join(self) -> std::thread::Result<PlantRun> {
        let run = self.plant.join();
        self.draw.join()?;
        run
    }
}

/// Starts `plant` on a thread of `scope`, and a second thread that hands
/// each finished stroke of the executed path to `strokes` (drawing takes
/// about as long as checking, so the operating system spreads the three
/// threads over the cores there are). The run ends when the link is closed
/// or dropped; joining gives the plant back.
pub fn spawn<'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    mut plant: Plant,
    strokes: &'scope mut (dyn FnMut(Stroke) + Send),
) -> (PlantLink, PlantThreads<'scope>) {
    let (tx, rx) = sync_channel::<Batch>(IN_FLIGHT);
    let (spare_tx, spare) = sync_channel::<Vec<Stamped>>(IN_FLIGHT + 1);
    let (draw_tx, draw_rx) = sync_channel::<Vec<Stroke>>(STROKES_IN_FLIGHT);
    let draw = scope.spawn(move || {
        for batch in draw_rx {
            batch.into_iter().for_each(&mut *strokes);
        }
    });
    let plant = scope.spawn(move || {
        let mut held = Held::default();
        for mut batch in rx {
            for seg in batch.planned.drain(..) {
                plant.planned(seg);
            }
            held.plant_segments = held.plant_segments.max(plant.window_len());
            plant.apply(&mut batch.outputs);
            plant.applied_until(batch.until);
            held.path_points = held.path_points.max(plant.recorder.held_points());
            if plant.recorder.has_finished() {
                // A drawing thread that is gone has panicked; joining says so.
                let _ = draw_tx.send(plant.recorder.take_finished());
            }
            // A buffer that one long frame grew is freed, not kept: the
            // buffers in flight would otherwise all grow to the longest.
            if batch.outputs.capacity() <= 2 * BATCH_OUTPUTS {
                batch.outputs.clear();
                let _ = spare_tx.try_send(batch.outputs);
            }
        }
        let _ = draw_tx.send(plant.recorder.take());
        PlantRun { plant, held }
    });
    let link = PlantLink {
        tx: Some(tx),
        spare,
        planned: Vec::new(),
        outputs: Vec::new(),
        until: 0.0,
    };
    (link, PlantThreads { plant, draw })
}
