//! The firmware's cost measurements, shared by the boards' bench binaries
//! (`boards/mps2-an500`'s `motet-mps2-bench`, `boards/pico/bench`). They run
//! under QEMU with instruction counting, so a timer's ticks stand for a
//! fixed number of instructions; each board says how many
//! ([`BenchBoard::instructions`]), owns the step interrupt and its
//! counters, and prints. Every figure is printed as a `bench: ` line, in
//! instructions: the step interrupt per operation ([`step_interrupt`]), the
//! background's work per step ([`Background`]) and one frame of a graph
//! ([`graph_frames`]).

use crate::board::Ticks;
use crate::clock::HostToTicks;
use crate::op::{Op, OpKind};
use crate::ring::{Consumer, Producer};
use crate::schedule::Scheduler;
use core::fmt;
use heapless::Deque;
use motet_node::graph::{FrameOut, Graph, Inputs, Tape};
use motet_node::Node;
use motet_trajectory::{JointMap, ProfileParams, Segment};
use motet_wire::sync::ClockModel;
use motet_wire::{encode, AxisSpan, ChannelConfig, HostMessage, SegmentMsg};

/// What the measurements need of a board.
pub trait BenchBoard {
    /// The node's fixed-point time tolerance, µs, as the board's
    /// [`crate::board::Board::FIXED_TIME_US`] (0: exact).
    const FIXED_TIME_US: f64 = 0.0;
    /// The free-running timer the measurements read, ticks.
    fn now(&self) -> Ticks;
    /// Instructions executed in `ticks` of that timer (under QEMU's
    /// instruction counting).
    fn instructions(&self, ticks: u64) -> u64;
    /// Pends the step interrupt (the board's [`crate::interrupt::StepInterrupt`]
    /// on the ring [`step_interrupt`] fills).
    fn pend_step(&mut self);
    /// Sleeps until an interrupt.
    fn wait_for_interrupt(&mut self);
    /// Timer ticks spent in the step interrupt and its invocations since
    /// the last call; both start again from 0.
    fn isr_taken(&mut self) -> (u64, u64);
    /// Prints one line.
    fn line(&mut self, args: fmt::Arguments<'_>);
}

/// Operations on four channels' step pins: rising and falling edges in
/// turn, channel by channel in pairs.
fn edge(k: u32, at: Ticks) -> Op {
    let kind = [OpKind::StepHigh, OpKind::StepLow][(k % 2) as usize];
    Op::new(at, kind, (k / 2 % 4) as u8)
}

/// The step interrupt's cost, printed: first with one operation per
/// interrupt (2000 edges `apart` ticks apart, the first `first` ticks from
/// now), then with 4000 operations due at once, taken back to back. `ops`
/// is the ring the board's step interrupt takes from.
pub fn step_interrupt<B: BenchBoard>(
    b: &mut B,
    ops: &mut Producer<'_>,
    first: Ticks,
    apart: Ticks,
) {
    let n = 2000u32;
    let t0 = b.now().wrapping_add(first);
    for k in 0..n {
        let _ = ops.push(edge(k, t0.wrapping_add(k * apart)));
    }
    drain(b, ops);
    let (ticks, calls) = b.isr_taken();
    let per_irq = b.instructions(ticks) / calls.max(1);
    b.line(format_args!(
        "bench: step interrupt, one operation each: {per_irq} instructions per interrupt ({calls} interrupts)"
    ));

    let back_to_back = 4000u32;
    let now = b.now();
    for k in 0..back_to_back {
        let _ = ops.push(edge(k, now));
    }
    drain(b, ops);
    let (ticks, calls) = b.isr_taken();
    let per_op = b.instructions(ticks) / back_to_back as u64;
    b.line(format_args!(
        "bench: step interrupt, operations back to back: {per_op} instructions per operation ({calls} interrupts)"
    ));
}

/// Starts the step interrupt and sleeps until it has taken every operation.
fn drain<B: BenchBoard>(b: &mut B, ops: &Producer<'_>) {
    b.pend_step();
    while !ops.is_empty() {
        b.wait_for_interrupt();
    }
}

/// Hands `m` to the node as the wire would; a refusal is printed, not
/// fatal (the figures that follow say what it cost).
fn send<B: BenchBoard, const Q: usize>(b: &mut B, node: &mut Node<Q>, m: &HostMessage) {
    let mut buf = [0u8; 256];
    let Ok(bytes) = encode(m, &mut buf) else {
        b.line(format_args!("bench: cannot encode {m:?}"));
        return;
    };
    if let Some(r) = node.handle(bytes) {
        b.line(format_args!("bench: node refused {m:?}: {r:?}"));
    }
}

/// The background per step: the node's solve for four channels (80 steps
/// per unit, each moving 50 units on one 100-unit segment), the conversion
/// to ticks and the queueing. Set up with [`Background::new`], measured with
/// [`Background::run`] (apart, so a board can start counting in between).
pub struct Background<'q> {
    node: Node<8>,
    sched: Scheduler<'q>,
    conv: HostToTicks,
}

impl<'q> Background<'q> {
    /// The node with its channels configured and the segment queued, and a
    /// scheduler filling `queue` at `ticks_per_us` (the board's step timer).
    pub fn new<B: BenchBoard>(b: &mut B, queue: Producer<'q>, ticks_per_us: u32) -> Self {
        let node = bench_node(b);
        let mut sched = Scheduler::new(queue, ticks_per_us);
        for ch in 0..4 {
            sched.set_timing(ch, 2.0, 1.0);
        }
        let conv = HostToTicks::new(
            ClockModel {
                offset: 1000.0,
                skew: 1e-4,
            },
            ticks_per_us,
        );
        Background { node, sched, conv }
    }

    /// Polls the node every [`POLL_US`] until its segment is done, timing only
    /// the polls and the scheduler (the operations are drained from `ops`
    /// untimed: the interrupt's share is [`step_interrupt`]'s); prints the
    /// instructions per step, and of them the node's own (the same polls
    /// with the outputs dropped), and returns the steps (at least 1).
    pub fn run<B: BenchBoard>(mut self, b: &mut B, ops: &mut Consumer<'_>) -> u64 {
        let mut measured = 0u64;
        let mut t = 0.0;
        while self.node.queued() > 0 {
            t += POLL_US;
            let start = b.now();
            // As the main loop does: outputs near now (in integers
            // without an FPU).
            let conv = self.conv.near(t);
            self.node.poll(t, &mut self.sched.outputs(conv));
            self.sched.release(conv.ticks(t));
            let end = b.now();
            measured += end.wrapping_sub(start) as u64;
            while ops.front().is_some() {
                ops.pop();
            }
        }
        let steps = (self.sched.stats().steps as u64).max(1);
        let (node, node_steps) = node_alone(b);
        b.line(format_args!(
            "bench: background, four channels: {} instructions per step ({steps} steps, {:.2} s of motion), of which the node's poll {}",
            b.instructions(measured) / steps,
            t * 1e-6,
            b.instructions(node) / node_steps.max(1),
        ));
        steps
    }
}

/// How often the background measurements poll the node, µs.
const POLL_US: f64 = 250.0;

/// Steps counted, nothing else: the node's own share of the background.
struct Dropped(u64);

impl motet_node::Board for Dropped {
    fn step(&mut self, _: u8, _: bool, _: f64) {
        self.0 += 1;
    }
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
}

/// The same polls as [`Background::run`] with the outputs dropped: timer
/// ticks spent, and steps.
fn node_alone<B: BenchBoard>(b: &mut B) -> (u64, u64) {
    let mut node = bench_node(b);
    let mut out = Dropped(0);
    let mut t = 0.0;
    let start = b.now();
    while node.queued() > 0 {
        t += POLL_US;
        node.poll(t, &mut out);
    }
    let end = b.now();
    (end.wrapping_sub(start) as u64, out.0)
}

/// The node of the background measurements: four channels (80 steps per
/// unit, each moving 50 units on one 100-unit segment), keeping the tally
/// an endpoint keeps.
fn bench_node<B: BenchBoard>(b: &mut B) -> Node<8> {
    {
        let mut node: Node<8> = Node::new();
        // As on a board: an endpoint keeps the tally of every output, and
        // a board without an FPU runs in fixed-point time.
        node.keep_tally();
        node.use_fixed_time(B::FIXED_TIME_US);
        for ch in 0..4u8 {
            let mut coeffs = [0.0; 6];
            coeffs[ch as usize] = 1.0;
            send(
                b,
                &mut node,
                &HostMessage::ConfigureChannel(ChannelConfig {
                    channel: ch,
                    map: JointMap::Linear { coeffs },
                    steps_per_unit: 80.0,
                    pulse_us: 2.0,
                    dir_setup_us: 1.0,
                }),
            );
        }
        send(
            b,
            &mut node,
            &HostMessage::SetPosition { position: [0.0; 6] },
        );
        let mut axes = heapless::Vec::new();
        for a in 0..4u8 {
            let _ = axes.push(AxisSpan {
                axis: a,
                from: 0.0,
                to: 50.0,
            });
        }
        send(
            b,
            &mut node,
            &HostMessage::Segment(SegmentMsg {
                seq: 0,
                t0: 0.0,
                profile: ProfileParams {
                    length: 100.0,
                    v0: 0.0,
                    vc: 400.0,
                    v1: 0.0,
                    accel: 4000.0,
                    jerk: 0.0,
                    dwell: 0.0,
                },
                axes,
            }),
        );
        node
    }
}

/// Runs `frames` frames of `graph` (40 µs apart; analog input 0 at 600, the
/// first encoder 3 counts further every 100 frames, a slow frame every 25)
/// and prints the instructions per frame of the graph named `name`.
pub fn graph_frames<B: BenchBoard, const C: usize, const M: usize>(
    b: &mut B,
    name: &str,
    graph: &mut Graph<C, M>,
    frames: u64,
) {
    let mut inputs = Inputs::default();
    inputs.analog[0] = 600.0;
    let segs: Deque<Segment, 4> = Deque::new();
    let mut out = FrameOut::default();
    let mut gt = 0.0;
    let start = b.now();
    for i in 0..frames {
        if i % 100 == 0 {
            inputs.encoders[0] += 3;
        }
        let mut none = [];
        let mut tape = Tape::new(&mut none);
        graph.frame(gt, &inputs, &segs, &mut out, &mut tape);
        if i % 25 == 0 {
            graph.slow_frame(&inputs);
        }
        gt += 40.0;
    }
    let end = b.now();
    b.line(format_args!(
        "bench: {name} graph: {} instructions per frame ({frames} frames)",
        b.instructions(end.wrapping_sub(start) as u64) / frames
    ));
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::ring::Ring;
    use core::cell::Cell;
    use std::string::{String, ToString};
    use std::vec::Vec;

    /// A board whose step interrupt takes every due operation at once, and
    /// whose timer advances by one tick at each reading.
    struct Fake<'q> {
        /// The step interrupt's ring, when the test measures it.
        ops: Option<Consumer<'q>>,
        taken: Vec<Op>,
        clock: Cell<Ticks>,
        calls: u64,
        lines: Vec<String>,
    }

    impl BenchBoard for Fake<'_> {
        fn now(&self) -> Ticks {
            self.clock.set(self.clock.get() + 1);
            self.clock.get()
        }
        fn instructions(&self, ticks: u64) -> u64 {
            ticks * 40
        }
        fn pend_step(&mut self) {}
        fn wait_for_interrupt(&mut self) {
            self.calls += 1;
            let Some(ops) = self.ops.as_mut() else {
                return;
            };
            while let Some(op) = ops.front() {
                ops.pop();
                self.taken.push(op);
            }
        }
        fn isr_taken(&mut self) -> (u64, u64) {
            (0, core::mem::take(&mut self.calls))
        }
        fn line(&mut self, args: fmt::Arguments<'_>) {
            self.lines.push(args.to_string());
        }
    }

    fn fake(ops: Option<Consumer<'_>>) -> Fake<'_> {
        Fake {
            ops,
            taken: Vec::new(),
            clock: Cell::new(100),
            calls: 0,
            lines: Vec::new(),
        }
    }

    #[test]
    fn step_interrupt_queues_edges_at_the_boards_spacing() {
        // (first, apart): the mps2-an500's 25 MHz timer, the nRF51's 16 MHz.
        for (first, apart) in [(25_000, 5000), (16_000, 320)] {
            let ring: Ring<4096> = Ring::new();
            let (mut p, c) = ring.split().unwrap();
            let mut b = fake(Some(c));
            step_interrupt(&mut b, &mut p, first, apart);
            assert_eq!(b.taken.len(), 6000, "{first} {apart}");
            let (spaced, at_once) = b.taken.split_at(2000);
            // The timer read 101 when the first was placed.
            let expected = |k: usize, at: Ticks| {
                let kind = [OpKind::StepHigh, OpKind::StepLow][k % 2];
                Op::new(at, kind, (k / 2 % 4) as u8)
            };
            for (k, op) in spaced.iter().enumerate() {
                assert_eq!(*op, expected(k, 101 + first + k as u32 * apart), "{k}");
            }
            for (k, op) in at_once.iter().enumerate() {
                assert_eq!(*op, expected(k, at_once[0].at), "{k}");
            }
            assert_eq!(b.lines.len(), 2);
        }
    }

    #[test]
    fn background_runs_the_whole_segment() {
        let ring: Ring<4096> = Ring::new();
        let (p, mut c) = ring.split().unwrap();
        let lines = {
            let mut b = fake(None);
            let bg = Background::new(&mut b, p, 25);
            // Four channels, 50 units each at 80 steps per unit.
            assert_eq!(bg.run(&mut b, &mut c), 4 * 50 * 80);
            b.lines
        };
        assert_eq!(lines.len(), 1, "{lines:?}");
        assert!(
            lines[0].contains("(16000 steps, 0.35 s of motion)"),
            "{lines:?}"
        );
        assert!(c.is_empty());
    }
}
