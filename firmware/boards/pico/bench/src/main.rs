//! What the node costs per step on ARMv6-M (the Pico's RP2040 is a pair of
//! Cortex-M0+), measured on QEMU's `microbit` machine (a Cortex-M0, the
//! same instruction set) with instruction counting:
//!
//! ```text
//! qemu-system-arm -M microbit -global nrf51-soc.flash-size=1048576 \
//!     -global nrf51-soc.sram-size=262144 -icount shift=0 -semihosting \
//!     -display none -monitor none -kernel motet-pico-bench
//! ```
//!
//! It prints, in instructions: the step interrupt per operation (one
//! operation per interrupt, and operations taken back to back), the
//! background's work per step (the node's f64 solve for four channels in
//! the compiler's soft float, the conversion to ticks of the Pico's 1 MHz
//! timer and the queueing), and one frame of the Wheelbot graph. Built with
//! `--features float-calls`, it also counts the calls to each f64 routine
//! per step and the instructions each takes: what the RP2040 boot ROM's
//! routines would replace (docs/firmware.md has the estimate).
#![no_std]
#![no_main]

#[cfg(feature = "float-calls")]
mod float_calls;
mod nrf51;
mod semihosting;

use core::panic::PanicInfo;
use core::ptr::{addr_of_mut, write_volatile};
use cortex_m::peripheral::NVIC;
use cortex_m_rt::entry;
use heapless::Deque;
use motet_firmware::board::{Pins, Ticks};
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
use nrf51::{instructions, Irq};
use semihosting::{exit, line};

// The test's graph file names `std::f64::consts`: core's, here.
extern crate core as std;

#[allow(dead_code, unused_imports, clippy::all)]
#[path = "../../../../../crates/motet-node/tests/graph_wheelbot.rs"]
mod wheelbot;

/// The Pico's timer: 1 tick per µs.
const PICO_TICKS_PER_US: u32 = 1;

static RING: Ring<4096> = Ring::new();
static RING2: Ring<4096> = Ring::new();
static mut STEP: Option<StepInterrupt<'static>> = None;
static COUNTERS: Counters = Counters::new();
static mut ISR_TICKS: u64 = 0;
static mut ISR_CALLS: u64 = 0;

/// Stand-ins for the RP2040's SIO `GPIO_OUT_SET` / `GPIO_OUT_CLR` (RAM
/// here): a pin edge is one store of the channel's mask, as on the Pico.
static mut GPIO_SET: u32 = 0;
static mut GPIO_CLR: u32 = 0;
const STEP_MASK: [u32; 8] = [
    1 << 2,
    1 << 4,
    1 << 6,
    1 << 8,
    1 << 10,
    1 << 12,
    1 << 14,
    1 << 16,
];
const DIR_MASK: [u32; 8] = [
    1 << 3,
    1 << 5,
    1 << 7,
    1 << 9,
    1 << 11,
    1 << 13,
    1 << 15,
    1 << 17,
];

/// The step interrupt's pins, shaped as the Pico's: one store per edge,
/// the compare of a free-running counter for the next interrupt.
struct BenchPins;

impl Pins for BenchPins {
    #[inline(always)]
    fn now(&self) -> Ticks {
        nrf51::now()
    }
    #[inline(always)]
    fn step_high(&mut self, ch: u8) {
        // SAFETY: a RAM word standing for a set register.
        unsafe { write_volatile(addr_of_mut!(GPIO_SET), STEP_MASK[(ch & 7) as usize]) }
    }
    #[inline(always)]
    fn step_low(&mut self, ch: u8) {
        // SAFETY: as above.
        unsafe { write_volatile(addr_of_mut!(GPIO_CLR), STEP_MASK[(ch & 7) as usize]) }
    }
    #[inline(always)]
    fn set_dir(&mut self, ch: u8, forward: bool) {
        let reg = if forward {
            addr_of_mut!(GPIO_SET)
        } else {
            addr_of_mut!(GPIO_CLR)
        };
        // SAFETY: as above.
        unsafe { write_volatile(reg, DIR_MASK[(ch & 7) as usize]) }
    }
    fn set_tool(&mut self, _output: u8, _duty: u16) {}
    #[inline(always)]
    fn arm(&mut self, at: Ticks) {
        nrf51::set_compare(at);
        if (at.wrapping_sub(nrf51::now()) as i32) <= 0 {
            NVIC::pend(Irq::Timer0);
        }
    }
    fn disarm(&mut self) {}
}

unsafe extern "C" fn timer0() {
    let t0 = nrf51::now();
    nrf51::compare_clear();
    if let Some(s) = (*addr_of_mut!(STEP)).as_mut() {
        s.run(&mut BenchPins);
    }
    let t1 = nrf51::now();
    *addr_of_mut!(ISR_TICKS) += t1.wrapping_sub(t0) as u64;
    *addr_of_mut!(ISR_CALLS) += 1;
}

extern "C" {
    fn DefaultHandler();
}

#[link_section = ".vector_table.interrupts"]
#[no_mangle]
#[used]
static __INTERRUPTS: [unsafe extern "C" fn(); 32] = {
    let mut v: [unsafe extern "C" fn(); 32] = [DefaultHandler; 32];
    v[Irq::Timer0 as usize] = timer0;
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

fn isr_taken() -> (u64, u64) {
    // SAFETY: read with the interrupt idle (the ring is empty).
    unsafe {
        let r = (*addr_of_mut!(ISR_TICKS), *addr_of_mut!(ISR_CALLS));
        *addr_of_mut!(ISR_TICKS) = 0;
        *addr_of_mut!(ISR_CALLS) = 0;
        r
    }
}

#[entry]
fn main() -> ! {
    nrf51::init();
    let Some((mut p, c)) = RING.split() else {
        exit()
    };
    unsafe {
        // No spinning: every operation its own interrupt.
        *addr_of_mut!(STEP) = Some(StepInterrupt::new(c, &COUNTERS, 0, u32::MAX));
        NVIC::unmask(Irq::Timer0);
    }

    // 1. One operation per interrupt: edges 20 µs apart (320 ticks).
    let n = 2000u32;
    let t0 = nrf51::now().wrapping_add(16 * 1000);
    for k in 0..n {
        let kind = if k % 2 == 0 {
            OpKind::StepHigh
        } else {
            OpKind::StepLow
        };
        let _ = p.push(Op::new(t0.wrapping_add(k * 320), kind, (k / 2 % 4) as u8));
    }
    NVIC::pend(Irq::Timer0);
    while !p.is_empty() {
        cortex_m::asm::wfi();
    }
    let (ticks, calls) = isr_taken();
    line(format_args!(
        "bench: step interrupt, one operation each: {} instructions per interrupt ({calls} interrupts)",
        instructions(ticks) / calls.max(1)
    ));

    // 2. Operations due at once, taken in one interrupt.
    let now = nrf51::now();
    for k in 0..4000u32 {
        let kind = if k % 2 == 0 {
            OpKind::StepHigh
        } else {
            OpKind::StepLow
        };
        let _ = p.push(Op::new(now, kind, (k / 2 % 4) as u8));
    }
    NVIC::pend(Irq::Timer0);
    while !p.is_empty() {
        cortex_m::asm::wfi();
    }
    let (ticks, calls) = isr_taken();
    line(format_args!(
        "bench: step interrupt, operations back to back: {} instructions per operation ({calls} interrupts)",
        instructions(ticks) / 4000
    ));
    NVIC::mask(Irq::Timer0);

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
    let Some((p2, mut c2)) = RING2.split() else {
        exit()
    };
    let mut sched = Scheduler::new(p2, PICO_TICKS_PER_US);
    for ch in 0..4 {
        sched.set_timing(ch, 2.0, 1.0);
    }
    let conv = HostToTicks {
        model: ClockModel {
            offset: 1000.0,
            skew: 1e-4,
        },
        ticks_per_us: PICO_TICKS_PER_US as f64,
    };
    #[cfg(feature = "float-calls")]
    let _ = float_calls::take();
    let mut measured = 0u64;
    let mut t = 0.0;
    while node.queued() > 0 {
        t += 250.0;
        let a = nrf51::now();
        node.poll(t, &mut sched.outputs(conv));
        sched.release(conv.ticks(t));
        let b = nrf51::now();
        measured += b.wrapping_sub(a) as u64;
        while c2.front().is_some() {
            c2.pop();
        }
    }
    let steps = (sched.stats().steps as u64).max(1);
    line(format_args!(
        "bench: background, four channels: {} instructions per step ({steps} steps, {:.2} s of motion)",
        instructions(measured) / steps,
        t * 1e-6
    ));
    #[cfg(feature = "float-calls")]
    float_report("per step", steps);

    // 4. A Wheelbot frame (the graph of crates/motet-node/tests/graph_wheelbot.rs).
    let mut w = wheelbot::wheelbot();
    let _ = w.g.reset_deep(motet_node::graph::port(w.enc_r, 0), 50.0);
    let mut inputs = Inputs::default();
    inputs.analog[0] = 600.0;
    let segs: Deque<Segment, 4> = Deque::new();
    let mut out = FrameOut::default();
    let frames = 500u64;
    let mut gt = 0.0;
    let a = nrf51::now();
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
    let b = nrf51::now();
    line(format_args!(
        "bench: Wheelbot graph: {} instructions per frame ({frames} frames)",
        instructions(b.wrapping_sub(a) as u64) / frames
    ));
    #[cfg(feature = "float-calls")]
    float_report("per Wheelbot frame", frames);
    line(format_args!("bench: done"));
    exit()
}

/// The float routines' calls and instructions since the last report,
/// per `unit` (`per` of them).
#[cfg(feature = "float-calls")]
fn float_report(unit: &str, per: u64) {
    let overhead = float_calls::overhead(1000);
    let mut total = 0.0;
    for (name, (calls, ticks)) in float_calls::NAMES.iter().zip(float_calls::take()) {
        if calls == 0 {
            continue;
        }
        let inside = ticks as f64 - overhead * calls as f64;
        let each = inside * 62.5 / calls as f64;
        let per_unit = calls as f64 / per as f64;
        total += each * per_unit;
        line(format_args!(
            "bench: float {name}: {per_unit:.2} calls {unit}, {each:.0} instructions each"
        ));
    }
    line(format_args!(
        "bench: float routines: {total:.0} instructions {unit} (captures: {overhead:.2} ticks a pair)"
    ));
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    line(format_args!("bench: panic: {info}"));
    exit()
}
