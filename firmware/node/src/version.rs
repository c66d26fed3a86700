//! The firmware's version: the crate's, or `MOTET_FW_VERSION` at build
//! time (`MAJOR.MINOR.PATCH`), so that a test or a release builds an image
//! whose version differs from the one running.

use motet_wire::service::Version;

/// Parses `MAJOR.MINOR.PATCH` in a const context; None if malformed.
pub const fn parse(s: &str) -> Option<Version> {
    let b = s.as_bytes();
    let mut parts = [0u32; 3];
    let mut k = 0;
    let mut i = 0;
    let mut digits = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'.' {
            if digits == 0 || k == 2 {
                return None;
            }
            k += 1;
            digits = 0;
        } else if c.is_ascii_digit() {
            parts[k] = parts[k] * 10 + (c - b'0') as u32;
            if parts[k] > u16::MAX as u32 {
                return None;
            }
            digits += 1;
        } else {
            return None;
        }
        i += 1;
    }
    if k != 2 || digits == 0 {
        return None;
    }
    Some(Version {
        major: parts[0] as u16,
        minor: parts[1] as u16,
        patch: parts[2] as u16,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_parse_or_are_refused() {
        let v = |a, b, c| {
            Some(Version {
                major: a,
                minor: b,
                patch: c,
            })
        };
        let cases = [
            ("0.1.0", v(0, 1, 0)),
            ("12.345.65535", v(12, 345, 65535)),
            ("1.2", None),
            ("1.2.3.4", None),
            ("1..3", None),
            ("1.2.65536", None),
            ("v1.2.3", None),
            ("", None),
        ];
        for (s, want) in cases {
            assert_eq!(parse(s), want, "{s}");
        }
    }
}
