//! The closed-loop tables of a machine file as written: a servo's loop and
//! its simulated motor, and sensors.

use serde::Deserialize;
use toml::Spanned;

/// `[actuators.NAME.servo]`: the loop the node runs (units in
/// docs/wire.md, "Closed loops").
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoFile {
    pub rate_hz: Option<Spanned<f64>>,
    pub kp: Option<Spanned<f64>>,
    pub ki: Option<Spanned<f64>>,
    pub kd: Option<Spanned<f64>>,
    pub kv: Option<Spanned<f64>>,
    pub ka: Option<Spanned<f64>>,
    pub kf: Option<Spanned<f64>>,
    pub integral_limit: Option<Spanned<f64>>,
    pub output_limit: Option<Spanned<f64>>,
    pub derivative_hz: Option<Spanned<f64>>,
    pub lead: Option<Spanned<f64>>,
    pub following_limit: Option<Spanned<f64>>,
}

/// `[actuators.NAME.motor]`: the simulated DC motor, load and switches.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorFile {
    pub resistance: Option<Spanned<f64>>,
    pub inductance: Option<Spanned<f64>>,
    pub torque_constant: Option<Spanned<f64>>,
    pub inertia: Option<Spanned<f64>>,
    pub damping: Option<Spanned<f64>>,
    pub friction: Option<Spanned<f64>>,
    pub supply: Option<Spanned<f64>>,
    pub load: Option<Spanned<f64>>,
    pub load_force: Option<Spanned<f64>>,
    pub limit_margin: Option<Spanned<f64>>,
    pub encoder_fails_s: Option<Spanned<f64>>,
}

/// `[sensors.NAME]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorFile {
    pub kind: Spanned<String>,
    pub actuator: Spanned<String>,
    pub rate_hz: Option<Spanned<f64>>,
    pub noise: Option<Spanned<f64>>,
}
