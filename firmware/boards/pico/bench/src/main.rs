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
use motet_firmware::bench::{self, BenchBoard};
use motet_firmware::board::{Pins, Ticks};
use motet_firmware::interrupt::{Counters, StepInterrupt};
use motet_firmware::ring::Ring;
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

/// The board's side of the measurements: the nRF51's timer (16 MHz, in
/// instructions by [`instructions`]), the step interrupt on Timer0, and
/// semihosting's console.
struct PicoBench;

impl BenchBoard for PicoBench {
    // As the Pico's board (`motet_board_pico::Pico`).
    const FIXED_TIME_US: f64 = motet_firmware::board::NO_FPU_FIXED_TIME_US;

    fn now(&self) -> Ticks {
        nrf51::now()
    }
    fn instructions(&self, ticks: u64) -> u64 {
        instructions(ticks)
    }
    fn pend_step(&mut self) {
        NVIC::pend(Irq::Timer0);
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
    nrf51::init();
    let b = &mut PicoBench;
    let Some((mut p, c)) = RING.split() else {
        exit()
    };
    unsafe {
        // No spinning: every operation its own interrupt.
        *addr_of_mut!(STEP) = Some(StepInterrupt::new(c, &COUNTERS, 0, u32::MAX));
        NVIC::unmask(Irq::Timer0);
    }
    // Edges 20 µs (320 ticks) apart, the first 1 ms from now.
    bench::step_interrupt(b, &mut p, 16 * 1000, 320);
    NVIC::mask(Irq::Timer0);

    let Some((p2, mut c2)) = RING2.split() else {
        exit()
    };
    let background = bench::Background::new(b, p2, PICO_TICKS_PER_US);
    #[cfg(feature = "float-calls")]
    let _ = float_calls::take();
    let _steps = background.run(b, &mut c2);
    #[cfg(feature = "float-calls")]
    float_report("per step", _steps);

    // The graph of crates/motet-node/tests/graph_wheelbot.rs.
    let mut w = wheelbot::wheelbot();
    let _ = w.g.reset_deep(motet_node::graph::port(w.enc_r, 0), 50.0);
    let frames = 500;
    bench::graph_frames(b, "Wheelbot", &mut w.g, frames);
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
