//! How a node's refusal reads to a person (the host prints it when a node
//! refuses a message).

use crate::message::Refusal;
use core::fmt;

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Malformed => f.write_str("the message did not decode"),
            Refusal::QueueFull => f.write_str("its segment queue is full"),
            Refusal::OutOfOrder { expected, got } => write!(
                f,
                "segment {got} arrived where segment {expected} was due"
            ),
            Refusal::BadConfig => f.write_str(
                "the configuration does not fit this node (channels, tools, kinematics or limits), or it keeps no such record",
            ),
            Refusal::NotAtRest => f.write_str("it is moving, and this needs it at rest"),
            Refusal::BadGraph => f.write_str(
                "the motion-stream graph was refused (a bad component, port, ratio, mapping or parameter, or a graph message out of place)",
            ),
            Refusal::Stopped => f.write_str(
                "it stopped on its contingency tail; set its position or reset it first",
            ),
            Refusal::TailStarted => f.write_str(
                "the seal came after the committed window's tail had started",
            ),
            Refusal::Closed => f.write_str(
                "the run was stopped for every node (a group stop, or a member fell silent): it takes no more seals",
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write;

    /// A fixed buffer to format into without an allocator.
    struct Buf([u8; 160], usize);

    impl Write for Buf {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            let end = self.1 + s.len();
            self.0
                .get_mut(self.1..end)
                .ok_or(fmt::Error)?
                .copy_from_slice(s.as_bytes());
            self.1 = end;
            Ok(())
        }
    }

    #[test]
    fn every_refusal_reads_as_a_sentence() {
        // (refusal, a part of what it says)
        let cases = [
            (Refusal::Malformed, "did not decode"),
            (Refusal::QueueFull, "queue is full"),
            (
                Refusal::OutOfOrder {
                    expected: 7,
                    got: 9,
                },
                "segment 9 arrived where segment 7 was due",
            ),
            (Refusal::BadConfig, "does not fit this node"),
            (Refusal::NotAtRest, "at rest"),
            (Refusal::BadGraph, "graph was refused"),
            (Refusal::Stopped, "contingency tail"),
            (Refusal::TailStarted, "tail had started"),
        ];
        for (r, want) in cases {
            let mut b = Buf([0; 160], 0);
            write!(b, "{r}").unwrap();
            let text = core::str::from_utf8(&b.0[..b.1]).unwrap();
            assert!(text.contains(want), "{r:?}: {text}");
        }
    }
}
