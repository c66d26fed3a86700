//! Ways the simulated bot can be told to misbehave, for tests of the
//! host's recovery: `garbage=N,crc=N,generic=N,full=N,reply-crc=N,ack-crc=N,cancel-after=N,silent-after=N`
//! (every N-th packet; `cancel-after`: 0x89 to everything after the N-th,
//! as when the build is cancelled on the bot's panel; `silent-after`: none
//! answered after the N-th).

/// A fault specification that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("fault `{item}`: {why} (expected garbage=N, crc=N, generic=N, full=N, reply-crc=N, ack-crc=N, cancel-after=N or silent-after=N, N ≥ 1)")]
pub struct FaultError {
    /// The item.
    pub item: String,
    /// What is wrong.
    pub why: &'static str,
}

/// Which faults, every how many packets.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Faults {
    /// Noise (with a false start byte) before every N-th reply.
    pub garbage: Option<u64>,
    /// Every N-th packet taken as corrupted on the way in: answered 0x83,
    /// discarded.
    pub crc: Option<u64>,
    /// Every N-th packet answered 0x80 (generic error), discarded.
    pub generic: Option<u64>,
    /// Every N-th action answered 0x82 (buffer full) even with room.
    pub full: Option<u64>,
    /// Every N-th reply to a query corrupted on the way out.
    pub reply_crc: Option<u64>,
    /// Every N-th acknowledgement of an action corrupted on the way out
    /// (the action was queued; the host cannot know).
    pub ack_crc: Option<u64>,
    /// 0x89 (build cancelled) to everything after this many packets.
    pub cancel_after: Option<u64>,
    /// No answer to anything after this many packets.
    pub silent_after: Option<u64>,
}

impl Faults {
    /// Parses `name=N,…`; an empty string is no fault.
    pub fn parse(spec: &str) -> Result<Faults, FaultError> {
        let mut f = Faults::default();
        for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let err = |why| FaultError {
                item: item.into(),
                why,
            };
            let (name, n) = item.split_once('=').ok_or_else(|| err("no `=N`"))?;
            let n: u64 = n
                .trim()
                .parse()
                .map_err(|_| err("N is not a whole number"))?;
            if n == 0 {
                return Err(err("N must be at least 1"));
            }
            let slot = match name.trim() {
                "garbage" => &mut f.garbage,
                "crc" => &mut f.crc,
                "generic" => &mut f.generic,
                "full" => &mut f.full,
                "reply-crc" => &mut f.reply_crc,
                "ack-crc" => &mut f.ack_crc,
                "cancel-after" => &mut f.cancel_after,
                "silent-after" => &mut f.silent_after,
                _ => return Err(err("unknown fault")),
            };
            *slot = Some(n);
        }
        Ok(f)
    }

    /// Whether the fault every `every` packets hits packet `n` (from 1).
    pub fn hits(every: Option<u64>, n: u64) -> bool {
        every.is_some_and(|e| n.is_multiple_of(e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses() {
        let f = Faults::parse("crc=7, full=3,silent-after=40").unwrap();
        assert_eq!(
            (f.crc, f.full, f.silent_after),
            (Some(7), Some(3), Some(40))
        );
        assert_eq!(Faults::parse("").unwrap(), Faults::default());
        for bad in ["crc", "crc=0", "crc=x", "noise=3"] {
            let e = Faults::parse(bad).unwrap_err();
            assert_eq!(e.item, bad, "{e}");
        }
    }
}
