//! Float functions through `libm`, so the graph computes the same numbers on the
//! host and on a Cortex-M node.

pub const TAU: f64 = core::f64::consts::TAU;

#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}
#[inline]
pub fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}
#[inline]
pub fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
#[inline]
pub fn floor(x: f64) -> f64 {
    libm::floor(x)
}
#[inline]
pub fn round(x: f64) -> f64 {
    libm::round(x)
}

/// The angle equal to `angle` modulo a full turn that is nearest `reference`.
#[inline]
pub fn unwrap_near(angle: f64, reference: f64) -> f64 {
    angle + TAU * round((reference - angle) / TAU)
}
