//! Heater channels: a temperature loop closed on the node, its target set
//! by the events of one event track, watched for runaway against a thermal
//! model of the heater.
//!
//! Units: °C, seconds, and power as the share of full power (duty 0 to 1).
//! See docs/wire.md, section 3 ("Heater channels").

use serde::{Deserialize, Serialize};

/// Loop rates a heater takes, Hz. Thermal time constants are seconds (a hot
/// end's sensor lags its block by one or two) to minutes (a bed), so a
/// loop of a few Hz already samples many times within the plant's own
/// delay; faster adds nothing but the reading's noise in the derivative.
pub const HEATER_HZ: core::ops::RangeInclusive<f32> = 1.0..=100.0;

/// Highest target or limit a heater takes, °C.
pub const MAX_HEATER_C: f32 = 1000.0;

/// A reading this far above the heater's `max_c` cannot be a working
/// sensor on a working heater (a shorted thermistor reads far above, an
/// open one far below `min_c`): the node trips at once, °C.
pub const OVER_MAX_C: f32 = 15.0;

/// Gains of a temperature loop. Error `e` = target − measured, °C; output
/// the power, 0 to `output_limit`: `u = kp·e + ki·∫e dt + kd·ė + ff`, with
/// `ff` the model's holding power at the target (see [`ThermalModel`])
/// times `feed_forward`, the integral term clamped to ±`integral_limit`
/// and not integrating further while `u` is clamped.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeaterGains {
    /// Power per °C of error.
    pub kp: f32,
    /// Power per °C·s.
    pub ki: f32,
    /// Power per °C/s (on the error's rate).
    pub kd: f32,
    /// Most |integral term|, power.
    pub integral_limit: f32,
    /// Most power, 0 to 1 (1: full).
    pub output_limit: f32,
    /// Time constant of the low-pass filter on the error's rate, s.
    pub derivative_s: f32,
    /// Share of the model's holding power fed forward, 0 to 1.
    pub feed_forward: f32,
}

/// Ranges [`HeaterGains::invalid`] holds each gain to, in the order of the
/// struct's fields.
pub const HEATER_GAIN_RANGES: [(&str, f32, f32); 7] = [
    ("kp", 0.0, 100.0),
    ("ki", 0.0, 100.0),
    ("kd", 0.0, 1000.0),
    ("integral_limit", 0.0, 1.0),
    ("output_limit", 0.001, 1.0),
    ("derivative_s", 0.0, 100.0),
    ("feed_forward", 0.0, 1.0),
];

impl HeaterGains {
    /// Every gain, in the order of [`HEATER_GAIN_RANGES`].
    pub fn values(&self) -> [f32; 7] {
        [
            self.kp,
            self.ki,
            self.kd,
            self.integral_limit,
            self.output_limit,
            self.derivative_s,
            self.feed_forward,
        ]
    }

    /// The first gain outside its range (or not finite), by name.
    pub fn invalid(&self) -> Option<&'static str> {
        first_invalid(&self.values(), &HEATER_GAIN_RANGES)
    }
}

/// A heater as the runaway check and the feed-forward see it: one lumped
/// heat capacity, heated by the power applied and losing heat to ambient
/// in proportion to how much hotter it is. `dT/dt = heat_rate · u −
/// loss · (T − ambient_c)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThermalModel {
    /// Rise at full power with no loss, °C/s (power ÷ heat capacity).
    pub heat_rate: f32,
    /// Loss per °C above ambient, 1/s (loss coefficient ÷ heat capacity).
    pub loss: f32,
    /// The room's temperature, °C.
    pub ambient_c: f32,
}

/// The ranges of a [`ThermalModel`]'s fields.
pub const MODEL_RANGES: [(&str, f32, f32); 3] = [
    ("heat_rate", 1e-4, 1000.0),
    ("loss", 0.0, 10.0),
    ("ambient_c", -50.0, 100.0),
];

impl ThermalModel {
    /// The model's fields, in the order of [`MODEL_RANGES`].
    pub fn values(&self) -> [f32; 3] {
        [self.heat_rate, self.loss, self.ambient_c]
    }

    /// Power that holds `target_c`, as a share of full power (may be above
    /// 1: the model cannot get there).
    pub fn holding_power(&self, target_c: f32) -> f32 {
        self.loss * (target_c - self.ambient_c) / self.heat_rate
    }

    /// Rate of rise at `temp_c` with power `u`, °C/s.
    pub fn rate(&self, temp_c: f32, u: f32) -> f32 {
        self.heat_rate * u - self.loss * (temp_c - self.ambient_c)
    }
}

/// When a heater counts as running away. While the heater is driven, the
/// rise its model predicts for the power applied and the rise measured
/// are summed over an exponential window of `window_s`: the heater trips
/// when the measured rise falls short of the predicted by more than
/// `margin_c` and is less than half of it (heater disconnected, thermistor
/// fallen off its block). Once the target has been reached, a reading
/// below it by more than `hysteresis_c` for `period_s` trips too (a heater
/// that cannot hold its target).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunawayWatch {
    /// The comparison's window, s.
    pub window_s: f32,
    /// Shortfall of the measured rise over the window, °C.
    pub margin_c: f32,
    /// How far below a reached target a reading may fall, °C.
    pub hysteresis_c: f32,
    /// How long it may stay there, s.
    pub period_s: f32,
}

/// The ranges of a [`RunawayWatch`]'s fields.
pub const WATCH_RANGES: [(&str, f32, f32); 4] = [
    ("window_s", 0.1, 3600.0),
    ("margin_c", 0.1, 1000.0),
    ("hysteresis_c", 0.1, 1000.0),
    ("period_s", 0.1, 3600.0),
];

impl RunawayWatch {
    /// The watch's fields, in the order of [`WATCH_RANGES`].
    pub fn values(&self) -> [f32; 4] {
        [
            self.window_s,
            self.margin_c,
            self.hysteresis_c,
            self.period_s,
        ]
    }
}

/// When a heater is ready (a wait for it is over): its readings have been
/// within `window_c` of the target for `residency_s` since the target was
/// last set.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReadyRule {
    /// °C either side of the target.
    pub window_c: f32,
    /// s.
    pub residency_s: f32,
}

/// The ranges of a [`ReadyRule`]'s fields.
pub const READY_RANGES: [(&str, f32, f32); 2] =
    [("window_c", 0.1, 100.0), ("residency_s", 0.0, 3600.0)];

/// A heater channel: a temperature sensor, a power output and the loop
/// between them, its target set by the events of `track`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeaterConfig {
    /// The heater's index on the node (its samples' and faults'
    /// `SampleSource::Heater`).
    pub heater: u8,
    /// The board's temperature sensor (`Board::temperature`).
    pub sensor: u8,
    /// The board's drive output the power goes to (`Board::drive`); not a
    /// servo's channel nor another heater's.
    pub drive: u8,
    /// The event track whose events set the target (°C; 0: off).
    pub track: u8,
    /// Loop rate, Hz (within [`HEATER_HZ`]).
    pub rate_hz: f32,
    /// The loop's gains.
    pub gains: HeaterGains,
    /// Highest target, °C: a target above it (or below 0, or not a number)
    /// switches the heater off; a reading above it by [`OVER_MAX_C`] trips.
    pub max_c: f32,
    /// A reading below it trips (an open sensor), °C.
    pub min_c: f32,
    /// What the runaway check and the feed-forward predict with.
    pub model: ThermalModel,
    /// When it runs away.
    pub watch: RunawayWatch,
    /// When a wait for it is over.
    pub ready: ReadyRule,
}

impl HeaterConfig {
    /// The first field a node does not take, by name (none: valid).
    pub fn invalid(&self) -> Option<&'static str> {
        if !(self.rate_hz.is_finite() && HEATER_HZ.contains(&self.rate_hz)) {
            return Some("rate_hz");
        }
        if let Some(g) = self.gains.invalid() {
            return Some(g);
        }
        if !(self.max_c.is_finite() && self.max_c > 0.0 && self.max_c <= MAX_HEATER_C) {
            return Some("max_c");
        }
        if !(self.min_c.is_finite() && self.min_c >= -273.15 && self.min_c < self.max_c) {
            return Some("min_c");
        }
        first_invalid(&self.model.values(), &MODEL_RANGES)
            .or_else(|| first_invalid(&self.watch.values(), &WATCH_RANGES))
            .or_else(|| {
                first_invalid(
                    &[self.ready.window_c, self.ready.residency_s],
                    &READY_RANGES,
                )
            })
    }

    /// Whether a node takes it.
    pub fn is_valid(&self) -> bool {
        self.invalid().is_none()
    }
}

/// The first of `values` outside its range in `ranges` (or not finite).
fn first_invalid(values: &[f32], ranges: &[(&'static str, f32, f32)]) -> Option<&'static str> {
    values
        .iter()
        .zip(ranges.iter())
        .find(|(v, (_, lo, hi))| !(v.is_finite() && **v >= *lo && **v <= *hi))
        .map(|(_, (name, _, _))| *name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> HeaterConfig {
        HeaterConfig {
            heater: 0,
            sensor: 0,
            drive: 8,
            track: 128,
            rate_hz: 10.0,
            gains: HeaterGains {
                kp: 0.2,
                ki: 0.05,
                kd: 0.2,
                integral_limit: 0.3,
                output_limit: 1.0,
                derivative_s: 1.0,
                feed_forward: 1.0,
            },
            max_c: 275.0,
            min_c: 0.0,
            model: ThermalModel {
                heat_rate: 3.0,
                loss: 0.005,
                ambient_c: 25.0,
            },
            watch: RunawayWatch {
                window_s: 10.0,
                margin_c: 12.0,
                hysteresis_c: 4.0,
                period_s: 20.0,
            },
            ready: ReadyRule {
                window_c: 1.0,
                residency_s: 10.0,
            },
        }
    }

    #[test]
    fn invalid_fields_are_named() {
        // (a change to a valid config, the field it makes invalid)
        type Case = (fn(&mut HeaterConfig), Option<&'static str>);
        let cases: [Case; 9] = [
            (|_| {}, None),
            (|c| c.rate_hz = 200.0, Some("rate_hz")),
            (|c| c.gains.kp = f32::NAN, Some("kp")),
            (|c| c.gains.output_limit = 0.0, Some("output_limit")),
            (|c| c.max_c = 2000.0, Some("max_c")),
            (|c| c.min_c = 300.0, Some("min_c")),
            (|c| c.model.heat_rate = 0.0, Some("heat_rate")),
            (|c| c.watch.period_s = -1.0, Some("period_s")),
            (|c| c.ready.window_c = f32::INFINITY, Some("window_c")),
        ];
        for (change, want) in cases {
            let mut c = config();
            change(&mut c);
            assert_eq!(c.invalid(), want, "{c:?}");
        }
    }

    /// Both heater messages round-trip within a message, at their
    /// documented sizes (docs/wire.md).
    #[test]
    fn messages_round_trip() {
        use crate::{decode, encode, HostMessage, NodeMessage, MAX_MESSAGE};
        let mut buf = [0u8; MAX_MESSAGE];
        let m = HostMessage::ConfigureHeater(config());
        let bytes = encode(&m, &mut buf).unwrap();
        assert_eq!(bytes.len(), 81);
        assert_eq!(decode::<HostMessage>(bytes).unwrap(), m);
        let r = NodeMessage::HeaterReady {
            heater: 1,
            at: 1.5e7,
            target: 215.0,
        };
        let bytes = encode(&r, &mut buf).unwrap();
        assert_eq!(bytes.len(), 14);
        assert_eq!(decode::<NodeMessage>(bytes).unwrap(), r);
    }

    #[test]
    fn model_holds_and_rises() {
        let m = config().model;
        let u = m.holding_power(215.0);
        assert!((m.rate(215.0, u)).abs() < 1e-5);
        assert!((u - 0.005 * 190.0 / 3.0).abs() < 1e-6);
    }
}
