//! Float functions through `libm`, so the same results come out on the host and on
//! a Cortex-M node (the square root in hardware where the FPU has one).

/// The correctly rounded square root: the FPU's instruction where the
/// target has one (see `build.rs`), `libm`'s otherwise.
#[inline]
pub fn sqrt(x: f64) -> f64 {
    #[cfg(hw_sqrt_f64)]
    {
        hw_sqrt(x)
    }
    #[cfg(not(hw_sqrt_f64))]
    {
        libm::sqrt(x)
    }
}

/// The FPU's square root (see `build.rs`): one instruction where `libm`'s
/// integer algorithm takes hundreds on a 32-bit core; the same bits, since
/// both are correctly rounded.
#[cfg(hw_sqrt_f64)]
#[inline(always)]
#[allow(unsafe_code)]
fn hw_sqrt(x: f64) -> f64 {
    let r: f64;
    // SAFETY: `vsqrt.f64` reads one FPU register and writes another; no
    // memory, stack or condition flags are touched.
    unsafe {
        core::arch::asm!(
            "vsqrt.f64 {0}, {1}",
            out(dreg_low16) r,
            in(dreg_low16) x,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    r
}
#[inline]
pub fn cbrt(x: f64) -> f64 {
    libm::cbrt(x)
}
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}
#[inline]
pub fn round(x: f64) -> f64 {
    libm::round(x)
}
#[inline]
pub fn acos(x: f64) -> f64 {
    libm::acos(x)
}
#[inline]
pub fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}
