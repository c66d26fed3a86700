//! Word values in machine units: inch scaling, and the range each kind of
//! number must be in.

use motet_planner::ranges::{self, ValueRange};
use motet_planner::SourceError;

use super::Interp;
use crate::block::Param;
use crate::codes::{AXIS_LETTERS, SLOT_E};

const INCH: f64 = 25.4;

impl Interp {
    /// Value of a parameter that must have a number (the lexer guarantees it
    /// for non-axis letters).
    pub(super) fn value(&self, p: Param, letter: char) -> Result<f64, SourceError> {
        p.value
            .ok_or_else(|| self.error(p.at, format!("{letter} without a number")))
    }

    /// `v` (the value of word `p`) if it is in `range`; else an error at
    /// the word.
    pub(super) fn in_range(
        &self,
        p: Param,
        range: ValueRange,
        what: &str,
        v: f64,
    ) -> Result<f64, SourceError> {
        range
            .check(what, v)
            .map_err(|e| self.error(p.at, e.to_string()))
    }

    /// An axis word's value in machine units (mm, or degrees for A B C),
    /// in its range: [`ranges::COORDINATE`], or [`ranges::RIDING_COORDINATE`]
    /// for an axis without travel limits (an extruder).
    pub(super) fn axis_value(&self, p: Param, slot: usize) -> Result<f64, SourceError> {
        let letter = AXIS_LETTERS[slot] as char;
        let v = self.value(p, letter)? * self.slot_scale(slot);
        let riding = self.letter_axis[slot]
            .and_then(|i| self.target.axes.get(i))
            .is_some_and(|a| !a.travel.iter().all(|t| t.is_finite()));
        let range = match (riding, slot > SLOT_E) {
            (true, _) => ranges::RIDING_COORDINATE,
            (false, true) => ranges::COORDINATE.scaled(1.0, "°"),
            (false, false) => ranges::COORDINATE,
        };
        self.in_range(p, range, &letter.to_string(), v)
    }

    /// A length word (arc offsets and radius) in mm, within
    /// [`ranges::COORDINATE`].
    pub(super) fn length_value(&self, p: Param, letter: char) -> Result<f64, SourceError> {
        let v = self.value(p, letter)? * self.length_scale();
        self.in_range(p, ranges::COORDINATE, &letter.to_string(), v)
    }

    pub(super) fn length_scale(&self) -> f64 {
        if self.inch {
            INCH
        } else {
            1.0
        }
    }

    pub(super) fn slot_scale(&self, slot: usize) -> f64 {
        if slot <= SLOT_E {
            self.length_scale()
        } else {
            1.0
        }
    }
}
