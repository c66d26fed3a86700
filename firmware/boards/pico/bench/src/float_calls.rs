//! With the `float-calls` feature: every call the program makes to one of
//! the compiler's float routines goes through a wrapper here (the linker's
//! `--wrap`, set in build.rs), which counts it and the timer ticks it took.
//! The ticks include two timer captures; [`overhead`] measures those.

use crate::nrf51;
use core::ptr::addr_of_mut;

/// Calls and ticks per routine, in the order of [`NAMES`].
static mut CALLS: [u32; NAMES.len()] = [0; NAMES.len()];
static mut TICKS: [u64; NAMES.len()] = [0; NAMES.len()];

#[inline(always)]
fn record(i: usize, ticks: u32) {
    // SAFETY: one core, the wrappers are called from the background only
    // (the step interrupt does no float arithmetic).
    unsafe {
        (*addr_of_mut!(CALLS))[i] += 1;
        (*addr_of_mut!(TICKS))[i] += ticks as u64;
    }
}

/// Calls and ticks so far, per routine; and clears them.
pub fn take() -> [(u32, u64); NAMES.len()] {
    // SAFETY: as in `record`.
    unsafe {
        let r = core::array::from_fn(|i| ((*addr_of_mut!(CALLS))[i], (*addr_of_mut!(TICKS))[i]));
        *addr_of_mut!(CALLS) = [0; NAMES.len()];
        *addr_of_mut!(TICKS) = [0; NAMES.len()];
        r
    }
}

/// Ticks two back-to-back captures count around nothing, averaged over
/// `n` pairs (subtracted from each call's ticks).
pub fn overhead(n: u32) -> f64 {
    let mut sum = 0u64;
    for _ in 0..n {
        let a = nrf51::now();
        let b = nrf51::now();
        sum += b.wrapping_sub(a) as u64;
    }
    sum as f64 / n as f64
}

macro_rules! wrap {
    ($($i:literal $name:literal $real:ident $wrap:ident ($($a:ident: $t:ty),*) -> $r:ty;)*) => {
        pub const NAMES: [&str; [$($i),*].len()] = [$($name),*];
        extern "C" {
            $(fn $real($($a: $t),*) -> $r;)*
        }
        $(
            #[no_mangle]
            extern "C" fn $wrap($($a: $t),*) -> $r {
                let t0 = nrf51::now();
                // SAFETY: the compiler's routine, under its own name.
                let v = unsafe { $real($($a),*) };
                let t1 = nrf51::now();
                record($i, t1.wrapping_sub(t0));
                v
            }
        )*
    };
}

wrap! {
    0 "dadd" __real___aeabi_dadd __wrap___aeabi_dadd(a: f64, b: f64) -> f64;
    1 "dsub" __real___aeabi_dsub __wrap___aeabi_dsub(a: f64, b: f64) -> f64;
    2 "dmul" __real___aeabi_dmul __wrap___aeabi_dmul(a: f64, b: f64) -> f64;
    3 "ddiv" __real___aeabi_ddiv __wrap___aeabi_ddiv(a: f64, b: f64) -> f64;
    4 "dcmpeq" __real___aeabi_dcmpeq __wrap___aeabi_dcmpeq(a: f64, b: f64) -> i32;
    5 "dcmplt" __real___aeabi_dcmplt __wrap___aeabi_dcmplt(a: f64, b: f64) -> i32;
    6 "dcmple" __real___aeabi_dcmple __wrap___aeabi_dcmple(a: f64, b: f64) -> i32;
    7 "dcmpgt" __real___aeabi_dcmpgt __wrap___aeabi_dcmpgt(a: f64, b: f64) -> i32;
    8 "dcmpge" __real___aeabi_dcmpge __wrap___aeabi_dcmpge(a: f64, b: f64) -> i32;
    9 "dcmpun" __real___aeabi_dcmpun __wrap___aeabi_dcmpun(a: f64, b: f64) -> i32;
    10 "d2iz" __real___aeabi_d2iz __wrap___aeabi_d2iz(a: f64) -> i32;
    11 "d2uiz" __real___aeabi_d2uiz __wrap___aeabi_d2uiz(a: f64) -> u32;
    12 "d2lz" __real___aeabi_d2lz __wrap___aeabi_d2lz(a: f64) -> i64;
    13 "d2ulz" __real___aeabi_d2ulz __wrap___aeabi_d2ulz(a: f64) -> u64;
    14 "i2d" __real___aeabi_i2d __wrap___aeabi_i2d(a: i32) -> f64;
    15 "ui2d" __real___aeabi_ui2d __wrap___aeabi_ui2d(a: u32) -> f64;
    16 "l2d" __real___aeabi_l2d __wrap___aeabi_l2d(a: i64) -> f64;
    17 "ul2d" __real___aeabi_ul2d __wrap___aeabi_ul2d(a: u64) -> f64;
    18 "f2d" __real___aeabi_f2d __wrap___aeabi_f2d(a: f32) -> f64;
    19 "d2f" __real___aeabi_d2f __wrap___aeabi_d2f(a: f64) -> f32;
}
