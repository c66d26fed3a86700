//! Command-line numbers checked against their ranges (`motet_planner::ranges`)
//! as clap parses them, so a refusal names the flag:
//! `invalid value '1e12' for '--lead-ms <LEAD_MS>': must be from 1 to 60000 ms`.
//! Also the placement flags `run` and `check` share.

use motet_api::placement::DEFAULT_FIT_MARGIN_MM;
use motet_api::Placement;
use motet_planner::ValueRange;

/// Where an SVG or photo goes on the machine: rotate about the drawing's
/// centre, then scale or fit, then move (README, "Placing a drawing").
/// Ranges and combinations are checked by [`Placement::check`], whose
/// errors name the flags.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct PlacementFlags {
    /// Fit the drawing to the x/y travel less MARGIN_MM on every side
    /// (default 10), keeping its aspect ratio, centred.
    #[arg(long, value_name = "MARGIN_MM", num_args = 0..=1, allow_negative_numbers = true)]
    pub fit: Option<Option<f64>>,
    /// Scale the drawing by this factor (> 0), from its lower-left corner.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub scale: Option<f64>,
    /// Rotate the drawing by DEG degrees counter-clockwise about its centre.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub rotate: Option<f64>,
    /// Put the placed drawing's lower-left corner at machine X,Y (mm).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true,
          value_parser = |s: &str| Placement::parse_origin(s).map_err(|e| e.to_string()))]
    pub origin: Option<[f64; 2]>,
}

impl PlacementFlags {
    /// The placement the flags ask for, checked.
    pub fn placement(&self) -> Result<Placement, motet_api::PlacementError> {
        let p = Placement {
            fit_margin_mm: self.fit.map(|m| m.unwrap_or(DEFAULT_FIT_MARGIN_MM)),
            scale: self.scale,
            rotate_deg: self.rotate.unwrap_or(0.0),
            origin: self.origin,
        };
        p.check()?;
        Ok(p)
    }
}

/// A parser for a number in `range`.
pub fn number(range: ValueRange) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s| {
        let v: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
        if range.contains(v) {
            Ok(v)
        } else {
            Err(format!("must be {range}"))
        }
    }
}

/// A parser for a whole number in `range`.
pub fn count<T: TryFrom<u64>>(
    range: ValueRange,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync {
    move |s| {
        let v: u64 = s.trim().parse().map_err(|e| format!("{e}"))?;
        // Ranges of counts are far below 2^53: the comparison is exact.
        if range.contains(v as f64) {
            T::try_from(v).map_err(|_| format!("must be {range}"))
        } else {
            Err(format!("must be {range}"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_planner::ranges;

    #[test]
    fn numbers_outside_their_range_are_refused_with_it() {
        let lead = number(ranges::LEAD_MS);
        assert_eq!(lead("100"), Ok(100.0));
        for bad in ["1e12", "0", "-5", "nan", "inf"] {
            assert_eq!(lead(bad), Err("must be from 1 to 60000 ms".into()), "{bad}");
        }
        assert!(lead("fast").is_err());
        let repeat = count::<u32>(ranges::REPEAT);
        assert_eq!(repeat("3"), Ok(3));
        assert_eq!(repeat("0"), Err("must be from 1 to 1000".into()));
        assert!(repeat("-1").is_err());
    }
}
