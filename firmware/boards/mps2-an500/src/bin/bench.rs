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
use motet_board_mps2_an500::console::line;
use motet_board_mps2_an500::irq::{self, Irq, Vector};
use motet_board_mps2_an500::pins::Mps2Pins;
use motet_board_mps2_an500::timer;
use motet_board_mps2_an500::uart::Uart;
use motet_firmware::bench::{self, BenchBoard};
use motet_firmware::board::Ticks;
use motet_firmware::interrupt::{Counters, StepInterrupt};
use motet_firmware::ring::Ring;

// The test's graph file names `std::f64::consts`: core's, here.
extern crate core as std;

#[allow(dead_code, unused_imports, clippy::all)]
#[path = "../../../../../crates/motet-node/tests/graph_wheelbot.rs"]
mod wheelbot;

/// Instructions per timer tick under `-icount shift=0` at 25 MHz.
const INSTRUCTIONS_PER_TICK: u64 = 40;
/// The timer's ticks per µs (25 MHz).
const TIMER_TICKS_PER_US: u32 = 25;

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

/// The board's side of the measurements: the 25 MHz timer, the step
/// interrupt on Timer1, and the console.
struct Mps2Bench;

impl BenchBoard for Mps2Bench {
    fn now(&self) -> Ticks {
        timer::now()
    }
    fn instructions(&self, ticks: u64) -> u64 {
        ticks * INSTRUCTIONS_PER_TICK
    }
    fn pend_step(&mut self) {
        NVIC::pend(Irq::Timer1);
    }
    fn wait_for_interrupt(&mut self) {
        cortex_m::asm::wfi();
    }
    fn isr_taken(&mut self) -> (u64, u64) {
        // SAFETY: read with the interrupt idle (the ring is empty).
        unsafe {
            let r = (*addr_of_mut!(ISR_TICKS), *addr_of_mut!(ISR_CALLS));
            *addr_of_mut!(ISR_TICKS) = 0;
            *addr_of_mut!(ISR_CALLS) = 0;
            r
        }
    }
    fn line(&mut self, args: core::fmt::Arguments<'_>) {
        line(args);
    }
}

#[entry]
fn main() -> ! {
    timer::init();
    Uart::UART1.init(false);
    let b = &mut Mps2Bench;
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
    // Edges 5000 ticks apart (200 µs at 25 MHz), the first 1 ms from now.
    bench::step_interrupt(b, &mut p, 25 * 1000, 5000);
    // The background is measured alone.
    NVIC::mask(Irq::Timer1);
    let Some((p2, mut c2)) = RING2.split() else {
        exit()
    };
    bench::Background::new(b, p2, TIMER_TICKS_PER_US).run(b, &mut c2);
    // The graph of crates/motet-node/tests/graph_wheelbot.rs.
    let mut w = wheelbot::wheelbot();
    let _ = w.g.reset_deep(motet_node::graph::port(w.enc_r, 0), 50.0);
    bench::graph_frames(b, "Wheelbot", &mut w.g, 5000);
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
