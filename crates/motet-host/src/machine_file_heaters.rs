//! The tables of a heater a node drives, as written (`[heaters.NAME.pid]`,
//! `[heaters.NAME.model]`, `[heaters.NAME.runaway]`), before validation.

use serde::Deserialize;
use toml::Spanned;

/// `[heaters.NAME.pid]`: the loop on the node. Gains left out are derived
/// from the model (`motet_host::heater_loop::reaction_curve_gains`).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeaterPidFile {
    pub rate_hz: Option<Spanned<f64>>,
    pub kp: Option<Spanned<f64>>,
    pub ki: Option<Spanned<f64>>,
    pub kd: Option<Spanned<f64>>,
    pub integral_limit: Option<Spanned<f64>>,
    pub output_limit: Option<Spanned<f64>>,
    pub derivative_s: Option<Spanned<f64>>,
    pub feed_forward: Option<Spanned<f64>>,
}

/// `[heaters.NAME.model]`: the heater's thermal model (what the runaway
/// check compares with, and the simulator's plant), and faults the
/// simulator injects.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeaterModelFile {
    /// W at full power.
    pub power: Option<Spanned<f64>>,
    /// J/K.
    pub capacity: Option<Spanned<f64>>,
    /// W/K to the room.
    pub loss: Option<Spanned<f64>>,
    /// W/K more with the part-cooling fan at full speed.
    pub fan_loss: Option<Spanned<f64>>,
    /// s the sensor lags the heated block.
    pub sensor_lag: Option<Spanned<f64>>,
    /// °C.
    pub ambient: Option<Spanned<f64>>,
    /// °C of noise on the reading (simulator).
    pub noise: Option<Spanned<f64>>,
    /// A fault the simulator injects: `disconnected`, `sensor-lost`,
    /// `thermistor-off`.
    pub fault: Option<Spanned<String>>,
    /// When, s from the job's start.
    pub fault_at: Option<Spanned<f64>>,
}

/// `[heaters.NAME.runaway]`: when the node trips the heater.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeaterRunawayFile {
    /// The model comparison's window, s.
    pub window: Option<Spanned<f64>>,
    /// The measured rise's shortfall that trips, °C.
    pub margin: Option<Spanned<f64>>,
    /// How far below a reached target a reading may fall, °C.
    pub hysteresis: Option<Spanned<f64>>,
    /// For how long, s.
    pub period: Option<Spanned<f64>>,
    /// A reading below this is a lost sensor, °C.
    pub min: Option<Spanned<f64>>,
}
