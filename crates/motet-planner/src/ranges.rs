//! The accepted range of every duration, distance, rate and count that comes
//! from outside: machine files, job files (G-code, SVG), command-line flags
//! and the scripting API.
//!
//! One table, used by every source, so a value is refused the same way
//! wherever it comes from, with the place it came from (the source adds it)
//! and the range it missed. The ranges are wide enough for any real machine
//! and narrow enough that nothing downstream overflows, loses its time
//! resolution or runs for years: `docs/ranges.md` gives the reason for each.
//!
//! Time stamps are `f64` microseconds. Below 2^53 µs (285 years) they are
//! exact to the microsecond; below [`JOB_S`] (2.6e12 µs) an `f64` still
//! resolves half a nanosecond, which the step timing checks rely on.

use std::fmt;

/// A closed range of accepted values and their unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueRange {
    /// Smallest accepted value, inclusive.
    pub min: f64,
    /// Largest accepted value, inclusive.
    pub max: f64,
    /// Unit as printed after the numbers (empty for plain counts).
    pub unit: &'static str,
}

impl ValueRange {
    /// The values from `min` to `max` inclusive, printed with `unit`.
    pub const fn new(min: f64, max: f64, unit: &'static str) -> ValueRange {
        ValueRange { min, max, unit }
    }

    /// The same range in another unit, `factor` of the new per old.
    pub fn scaled(&self, factor: f64, unit: &'static str) -> ValueRange {
        ValueRange::new(self.min * factor, self.max * factor, unit)
    }

    /// Whether `v` is in the range (never for NaN).
    pub fn contains(&self, v: f64) -> bool {
        v >= self.min && v <= self.max
    }

    /// `v` if it is in the range, else the error naming `what`.
    #[inline]
    pub fn check(&self, what: impl fmt::Display, v: f64) -> Result<f64, OutOfRange> {
        if self.contains(v) {
            Ok(v)
        } else {
            Err(self.out_of_range(&what, v))
        }
    }

    /// The error for `v`: out of line, since checks run on every move and
    /// almost never fail.
    #[cold]
    #[inline(never)]
    fn out_of_range(&self, what: &dyn fmt::Display, v: f64) -> OutOfRange {
        OutOfRange {
            what: what.to_string(),
            value: v,
            range: *self,
        }
    }

    /// A count (an integer from a file or a flag) if it is in the range.
    pub fn check_count(&self, what: impl fmt::Display, v: i64) -> Result<usize, OutOfRange> {
        // Counts are far below 2^53: the conversion is exact.
        self.check(what, v as f64).map(|v| v as usize)
    }
}

impl fmt::Display for ValueRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "from {} to {}", number(self.min), number(self.max))?;
        if !self.unit.is_empty() {
            write!(f, " {}", self.unit)?;
        }
        Ok(())
    }
}

/// A value outside its range: what it is, what it was and what it may be.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{what} must be {range}, got {}", number(*value))]
pub struct OutOfRange {
    /// The value's name as the user wrote it, with its section where it
    /// has one (`axis x: max_velocity`, `--sync-ms`, `dwell`).
    pub what: String,
    /// What was given (NaN and infinities included).
    pub value: f64,
    /// What is accepted.
    pub range: ValueRange,
}

/// A number for messages: plain where that is short (`0.001`, `86400`),
/// scientific where it is not (`1e308`, `2e-300`).
pub fn number(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// [`number`] to six significant digits, for values computed rather than
/// given (`0.01`, not `0.010000000000019327`).
pub fn rounded(v: f64) -> String {
    match format!("{v:.5e}").parse::<f64>() {
        Ok(r) if v.is_finite() => number(r),
        _ => number(v),
    }
}

// ---- durations --------------------------------------------------------------

/// A dwell (G-code G4, the API's `dwell`), seconds: up to a day.
pub const DWELL_S: ValueRange = ValueRange::new(0.0, 86_400.0, "s");
/// Standing still after a tool switch (`settle`), seconds: up to an hour.
pub const SETTLE_S: ValueRange = ValueRange::new(0.0, 3_600.0, "s");
/// The planned length of a job (or of a scripted session between waits),
/// seconds: 30 days.
pub const JOB_S: ValueRange = ValueRange::new(0.0, 30.0 * 86_400.0, "s");

// ---- distances --------------------------------------------------------------

/// Any position: travel ends, start, G-code coordinates, offsets, arc centres
/// and radii, SVG coordinates after placement, in mm (degrees for rotary
/// axes): a kilometre either way.
pub const COORDINATE: ValueRange = ValueRange::new(-1e6, 1e6, "mm");
/// Any position of an axis without travel limits (an extruder counts all
/// the filament it ever pushed), and the planner's bound for every axis.
pub const RIDING_COORDINATE: ValueRange = ValueRange::new(-1e9, 1e9, "mm");
/// Junction deviation, mm.
pub const JUNCTION_DEVIATION_MM: ValueRange = ValueRange::new(1e-4, 10.0, "mm");
/// Chord tolerance for arcs and curves, mm.
pub const TOLERANCE_MM: ValueRange = ValueRange::new(1e-4, 10.0, "mm");
/// Polar machines' closest approach to the centre, mm.
pub const MIN_RADIUS_MM: ValueRange = ValueRange::new(0.0, 1e6, "mm");
/// Pulley pitch diameter, belt pitch, leadscrew lead, mm.
pub const ELEMENT_MM: ValueRange = ValueRange::new(1e-3, 1e4, "mm");

// ---- rates ------------------------------------------------------------------

/// Velocity limits and feeds, units/s (mm/s, or °/s on rotary joints).
pub const VELOCITY: ValueRange = ValueRange::new(1e-3, 1e5, "units/s");
/// Acceleration limits, units/s².
pub const ACCELERATION: ValueRange = ValueRange::new(1e-3, 1e7, "units/s²");
/// Jerk limits, units/s³.
pub const JERK: ValueRange = ValueRange::new(1e-3, 1e10, "units/s³");
/// Steps per joint unit that an element chain may give.
pub const STEPS_PER_UNIT: ValueRange = ValueRange::new(1e-6, 1e6, "steps/unit");
/// Gear ratio, motor turns per output turn.
pub const GEAR_RATIO: ValueRange = ValueRange::new(1e-3, 1e4, "");
/// Stepper step angle, degrees.
pub const STEP_ANGLE_DEG: ValueRange = ValueRange::new(1e-3, 360.0, "°");
/// G-code F in inverse time mode (G93): moves per minute.
pub const INVERSE_TIME_F: ValueRange = ValueRange::new(1e-3, 1e7, "per minute");
/// Temperatures (M104, M109, M140, M190, M141, M191), °C.
pub const TEMPERATURE_C: ValueRange = ValueRange::new(-273.15, 2000.0, "°C");

/// A tool output: pen 0 up / 1 down, laser or spindle power 0 to 1.
pub const TOOL_VALUE: ValueRange = ValueRange::new(0.0, 1.0, "");

// ---- counts -----------------------------------------------------------------

/// Pulley teeth.
pub const TEETH: ValueRange = ValueRange::new(1.0, 10_000.0, "");
/// Microsteps per full step.
pub const MICROSTEPS: ValueRange = ValueRange::new(1.0, 256.0, "");
/// Moves held for lookahead.
pub const LOOKAHEAD: ValueRange = ValueRange::new(2.0, 65_536.0, "moves");
/// Stop horizon, moves (also at most the smallest node queue).
pub const STOP_HORIZON: ValueRange = ValueRange::new(0.0, 64.0, "moves");
/// Segment queue places a node uses.
pub const NODE_QUEUE: ValueRange = ValueRange::new(2.0, 64.0, "segments");
/// A node's frame period, µs.
pub const FRAME_US: ValueRange = ValueRange::new(1.0, 100_000.0, "µs");
/// A node's fixed-point time tolerance, µs (0: exact).
pub const FIXED_TIME_US: ValueRange = ValueRange::new(0.0, 10.0, "µs");
/// How deep an SVG document's elements may nest.
pub const SVG_DEPTH: ValueRange = ValueRange::new(0.0, 256.0, "levels");

// ---- command-line flags -------------------------------------------------------

/// `--time-scale`: simulated node clocks run this many times faster.
pub const TIME_SCALE: ValueRange = ValueRange::new(0.01, 1000.0, "");
/// `--lead-ms`: least time the committed trajectory reaches ahead.
pub const LEAD_MS: ValueRange = ValueRange::new(1.0, 60_000.0, "ms");
/// `--sync-ms`: time between clock exchanges.
pub const SYNC_MS: ValueRange = ValueRange::new(1.0, 60_000.0, "ms");
/// `--ppm`: a simulated node's crystal error.
pub const PPM: ValueRange = ValueRange::new(-10_000.0, 10_000.0, "ppm");
/// Waits for people and answers (`nodes scan --wait`, `nodes pair --wait`,
/// `nodes identify --seconds`, `node --idle-exit`), seconds.
pub const WAIT_S: ValueRange = ValueRange::new(0.0, 3_600.0, "s");
/// `dance --seconds`: every frame of a graph runs, 25,000 a second.
pub const DANCE_S: ValueRange = ValueRange::new(0.0, 3_600.0, "s");
/// `bench --repeat`.
pub const REPEAT: ValueRange = ValueRange::new(1.0, 1_000.0, "");
/// `bench --long`: the job written this many times over (100 times the
/// benchmark print is 550 MB of G-code on disk).
pub const LONG_JOB: ValueRange = ValueRange::new(2.0, 100.0, "");
/// `bench --instructions`: lines of the job run under callgrind (about
/// fifty times slower than a plain run).
pub const INSTRUCTION_LINES: ValueRange = ValueRange::new(100.0, 1_000_000.0, "");
/// `bench-net --jitter-us`: extra delay of every frame.
pub const JITTER_US: ValueRange = ValueRange::new(0.0, 1e6, "µs");
/// `bench-net --faults`: the rate of each fault per frame.
pub const FAULT_RATE: ValueRange = ValueRange::new(0.0, 1.0, "");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_value_and_the_range() {
        for (range, what, v, want) in [
            (
                DWELL_S,
                "dwell",
                2e13,
                "dwell must be from 0 to 86400 s, got 2e13",
            ),
            (
                DWELL_S,
                "dwell",
                -1.0,
                "dwell must be from 0 to 86400 s, got -1",
            ),
            (
                DWELL_S,
                "dwell",
                f64::NAN,
                "dwell must be from 0 to 86400 s, got NaN",
            ),
            (
                VELOCITY,
                "feed",
                1e-300,
                "feed must be from 0.001 to 100000 units/s, got 1e-300",
            ),
            (
                COORDINATE,
                "x",
                1e308,
                "x must be from -1000000 to 1000000 mm, got 1e308",
            ),
            (
                REPEAT,
                "--repeat",
                0.0,
                "--repeat must be from 1 to 1000, got 0",
            ),
        ] {
            let e = range.check(what, v).unwrap_err();
            assert_eq!(e.to_string(), want);
            assert!(e.value.is_nan() || e.value == v);
        }
    }

    #[test]
    fn rounded_numbers_keep_six_digits() {
        for (v, want) in [
            (220.01 - 220.0, "0.01"),
            (1.0000019e-7, "1e-7"),
            (86_400.0, "86400"),
            (2.0 / 3.0, "0.666667"),
            (f64::NAN, "NaN"),
        ] {
            assert_eq!(rounded(v), want);
        }
    }

    #[test]
    fn bounds_are_inclusive() {
        for r in [DWELL_S, VELOCITY, COORDINATE, LOOKAHEAD, FRAME_US] {
            assert_eq!(r.check("v", r.min), Ok(r.min));
            assert_eq!(r.check("v", r.max), Ok(r.max));
            assert!(r.check("v", r.max * (1.0 + 1e-12) + 1e-12).is_err());
            assert!(r.check("v", f64::INFINITY).is_err());
        }
        assert_eq!(LOOKAHEAD.check_count("lookahead", 4096), Ok(4096));
        assert!(LOOKAHEAD.check_count("lookahead", 1).is_err());
    }

    #[test]
    fn the_longest_job_keeps_sub_nanosecond_time_stamps() {
        let end_us = JOB_S.max * 1e6;
        let ulp = f64::from_bits(end_us.to_bits() + 1) - end_us;
        assert!(ulp < 1e-3, "{ulp} µs");
    }
}
