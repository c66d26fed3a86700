//! Measurements of the firmware's costs on the emulated Cortex-M7, run
//! under QEMU with instruction counting (`-icount shift=0`: every guest
//! instruction advances the emulated clock by 1 ns, so the 25 MHz timer
//! ticks once every 40 instructions):
//!
//! ```text
//! qemu-system-arm -M mps2-an500 -icount shift=0 -semihosting -display none \
//!     -monitor none -serial null -serial stdio -kernel motet-mps2-bench
//! ```
//!
//! It prints, in instructions: the step interrupt per operation (one
//! operation per interrupt, and operations taken back to back), the
//! background's work per step (the node's solve for four channels, the
//! conversion to ticks and the queueing), and one frame of the Wheelbot
//! graph (24 components). Exception entry and exit (12 and 10 cycles on a
//! Cortex-M7, fewer when tail-chained) are not instructions and come on top.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use core::ptr::addr_of_mut;
use cortex_m::peripheral::NVIC;
use cortex_m_rt::entry;
use heapless::Deque;
use motet_board_mps2_an500::console::line;
use motet_board_mps2_an500::irq::{self, Irq, Vector};
use motet_board_mps2_an500::pins::Mps2Pins;
use motet_board_mps2_an500::timer;
use motet_board_mps2_an500::uart::Uart;
use motet_firmware::clock::HostToTicks;
use motet_firmware::interrupt::{Counters, StepInterrupt};
use motet_firmware::op::{Op, OpKind};
use motet_firmware::ring::Ring;
use motet_firmware::schedule::Scheduler;
use motet_node::graph::{FrameOut, Inputs, Tape};
use motet_node::Node;
use motet_trajectory::{JointMap, ProfileParams, Segment};
use motet_wire::sync::ClockModel;
use motet_wire::{encode, AxisSpan, ChannelConfig, HostMessage, SegmentMsg};

// The test's graph file names `std::f64::consts`: core's, here.
extern crate core as std;

#[allow(dead_code, unused_imports, clippy::all)]
#[path = "../../../../../crates/motet-node/tests/graph_wheelbot.rs"]
mod wheelbot;

/// Instructions per timer tick under `-icount shift=0` at 25 MHz.
const INSTRUCTIONS_PER_TICK: u64 = 40;

static RING: Ring<4096> = Ring::new();
static RING2: Ring<4096> = Ring::new();
static mut STEP: Option<StepInterrupt<'static>> = None;
static COUNTERS: Counters = Counters::new();
/// Ticks spent in the step interrupt, and its invocations.
static mut ISR_TICKS: u64 = 0;
static mut ISR_CALLS: u64 = 0;

unsafe extern "C" fn timer1() {
    let t0 = timer::now();
    timer::compare_clear();
    if let Some(s) = (*addr_of_mut!(STEP)).as_mut() {
        s.run(&mut Mps2Pins);
    }
    let t1 = timer::now();
    *addr_of_mut!(ISR_TICKS) += t1.wrapping_sub(t0) as u64;
    *addr_of_mut!(ISR_CALLS) += 1;
}

#[link_section = ".vector_table.interrupts"]
#[no_mangle]
#[used]
static __INTERRUPTS: [Vector; irq::LINES] = {
    let mut v = irq::default_vectors();
    v[Irq::Timer1 as usize] = Vector { handler: timer1 };
    v
};

fn send<const Q: usize>(node: &mut Node<Q>, m: &HostMessage) {
    let mut buf = [0u8; 256];
    let Ok(bytes) = encode(m, &mut buf) else {
        line(format_args!("bench: cannot encode {m:?}"));
        return;
    };
    if let Some(r) = node.handle(bytes) {
        line(format_args!("bench: node refused {m:?}: {r:?}"));
    }
}

#[entry]
fn main() -> ! {
    timer::init();
    Uart::UART1.init(false);
    let Some((mut p, c)) = RING.split() else {
        exit()
    };
    unsafe {
        // No spinning: every operation its own interrupt. Nothing counts as
        // late (operations queued due are taken late by design here; the
        // comparison still runs).
        *addr_of_mut!(STEP) = Some(StepInterrupt::new(c, &COUNTERS, 0, u32::MAX));
        NVIC::unmask(Irq::Timer1);
    }

    // 1. One operation per interrupt: rising and falling edges 20 µs apart.
    let n = 2000u32;
    let t0 = timer::now().wrapping_add(25 * 1000);
    for k in 0..n {
        let at = t0.wrapping_add(k * 5000);
        let kind = if k % 2 == 0 {
            OpKind::StepHigh
        } else {
            OpKind::StepLow
        };
        let _ = p.push(Op::new(at, kind, (k / 2 % 4) as u8));
    }
    NVIC::pend(Irq::Timer1);
    while !p.is_empty() {
        cortex_m::asm::wfi();
    }
    let (ticks, calls) = unsafe { (*addr_of_mut!(ISR_TICKS), *addr_of_mut!(ISR_CALLS)) };
    let per_irq = ticks * INSTRUCTIONS_PER_TICK / calls;
    line(format_args!(
        "bench: step interrupt, one operation each: {per_irq} instructions per interrupt ({calls} interrupts)"
    ));

    // 2. Operations due at once, taken in one interrupt.
    unsafe {
        *addr_of_mut!(ISR_TICKS) = 0;
        *addr_of_mut!(ISR_CALLS) = 0;
    }
    let now = timer::now();
    for k in 0..4000u32 {
        let kind = if k % 2 == 0 {
            OpKind::StepHigh
        } else {
            OpKind::StepLow
        };
        let _ = p.push(Op::new(now, kind, (k / 2 % 4) as u8));
    }
    NVIC::pend(Irq::Timer1);
    while !p.is_empty() {
        cortex_m::asm::wfi();
    }
    let (ticks, calls) = unsafe { (*addr_of_mut!(ISR_TICKS), *addr_of_mut!(ISR_CALLS)) };
    let per_op = ticks * INSTRUCTIONS_PER_TICK / 4000;
    line(format_args!(
        "bench: step interrupt, operations back to back: {per_op} instructions per operation ({calls} interrupts)"
    ));

    // 3. The background per step: four channels on one segment.
    let mut node: Node<8> = Node::new();
    for ch in 0..4u8 {
        let mut coeffs = [0.0; 6];
        coeffs[ch as usize] = 1.0;
        send(
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
    send(&mut node, &HostMessage::SetPosition { position: [0.0; 6] });
    let mut axes = heapless::Vec::new();
    for a in 0..4u8 {
        let _ = axes.push(AxisSpan {
            axis: a,
            from: 0.0,
            to: 50.0,
        });
    }
    send(
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
    // (drained, not measured: the interrupt's share is above)
    NVIC::mask(Irq::Timer1);
    let Some((p2, mut c2)) = RING2.split() else {
        exit()
    };
    let mut sched = Scheduler::new(p2, 25);
    for ch in 0..4 {
        sched.set_timing(ch, 2.0, 1.0);
    }
    let conv = HostToTicks {
        model: ClockModel {
            offset: 1000.0,
            skew: 1e-4,
        },
        ticks_per_us: 25.0,
    };
    let mut measured = 0u64;
    let mut t = 0.0;
    while node.queued() > 0 {
        t += 250.0;
        let a = timer::now();
        node.poll(t, &mut sched.outputs(conv));
        sched.release(conv.ticks(t));
        let b = timer::now();
        measured += b.wrapping_sub(a) as u64;
        while c2.front().is_some() {
            c2.pop();
        }
    }
    let steps = sched.stats().steps as u64;
    line(format_args!(
        "bench: background, four channels: {} instructions per step ({steps} steps, {:.2} s of motion)",
        measured * INSTRUCTIONS_PER_TICK / steps.max(1),
        t * 1e-6
    ));

    // 4. A Wheelbot frame (the graph of crates/motet-node/tests/graph_wheelbot.rs).
    let mut w = wheelbot::wheelbot();
    let _ = w.g.reset_deep(motet_node::graph::port(w.enc_r, 0), 50.0);
    let mut inputs = Inputs::default();
    inputs.analog[0] = 600.0;
    let segs: Deque<Segment, 4> = Deque::new();
    let mut out = FrameOut::default();
    let frames = 5000u64;
    let mut gt = 0.0;
    let a = timer::now();
    for i in 0..frames {
        if i % 100 == 0 {
            inputs.encoders[0] += 3;
        }
        let mut none = [];
        let mut tape = Tape::new(&mut none);
        w.g.frame(gt, &inputs, &segs, &mut out, &mut tape);
        if i % 25 == 0 {
            w.g.slow_frame(&inputs);
        }
        gt += 40.0;
    }
    let b = timer::now();
    line(format_args!(
        "bench: Wheelbot graph: {} instructions per frame ({frames} frames)",
        b.wrapping_sub(a) as u64 * INSTRUCTIONS_PER_TICK / frames
    ));
    line(format_args!("bench: done"));
    exit()
}

/// Ends QEMU through semihosting (`-semihosting`).
fn exit() -> ! {
    // SAFETY: SYS_EXIT with ADP_Stopped_ApplicationExit; QEMU stops here.
    unsafe {
        core::arch::asm!("bkpt 0xab", in("r0") 0x18, in("r1") 0x20026);
    }
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    line(format_args!("bench: panic: {info}"));
    exit()
}
