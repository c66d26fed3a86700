//! Command-line numbers checked against their ranges (`motet_planner::ranges`)
//! as clap parses them, so a refusal names the flag:
//! `invalid value '1e12' for '--lead-ms <LEAD_MS>': must be from 1 to 60000 ms`.

use motet_planner::ValueRange;

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
