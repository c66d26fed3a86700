//! Properties of the packet decoder and the command codec.

use motet_s3g::command::{Command, PointAccel, PointNew};
use motet_s3g::decoder::{Decoded, Decoder};
use motet_s3g::{encode, stream, MAX_PAYLOAD, START};
use proptest::prelude::*;

fn packets(d: &[Decoded]) -> Vec<&Vec<u8>> {
    d.iter()
        .filter_map(|x| match x {
            Decoded::Packet(p) => Some(p),
            Decoded::CrcMismatch { .. } => None,
        })
        .collect()
}

fn command() -> impl Strategy<Value = Command> {
    let steps = prop::array::uniform5(any::<i32>());
    prop_oneof![
        (steps, any::<u32>(), 0u8..32).prop_map(|(steps, us, relative)| {
            Command::PointNew(PointNew {
                steps,
                us,
                relative,
            })
        }),
        (steps, any::<u32>(), 0u8..32, -1e6f32..1e6, any::<u16>()).prop_map(
            |(steps, dda_rate, relative, distance, feedrate_x64)| {
                Command::PointAccel(PointAccel {
                    steps,
                    dda_rate,
                    relative,
                    distance,
                    feedrate_x64,
                })
            }
        ),
        (
            any::<u8>(),
            any::<u8>(),
            prop::collection::vec(any::<u8>(), 0..=28)
        )
            .prop_map(|(tool, sub, data)| Command::ToolAction { tool, sub, data }),
        (
            any::<u8>(),
            any::<u8>(),
            prop::collection::vec(any::<u8>(), 0..=29)
        )
            .prop_map(|(tool, sub, data)| Command::ToolQuery { tool, sub, data }),
        any::<u32>().prop_map(Command::Delay),
        steps.prop_map(Command::SetPositionExt),
        any::<bool>().prop_map(Command::SetAcceleration),
        Just(Command::GetBufferSize),
        Just(Command::IsFinished),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Whatever arrives, nothing panics: the decoder, the command reader
    /// and the X3G stream reader.
    #[test]
    fn any_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let (found, d) = Decoder::decode_all(&bytes);
        for p in packets(&found) {
            prop_assert!(!p.is_empty() && p.len() <= MAX_PAYLOAD);
            let _ = Command::decode(p);
        }
        prop_assert!(d.skipped <= bytes.len() as u64);
        let _ = Command::decode(&bytes);
        let _ = stream::read_commands(&bytes);
    }

    /// A packet after noise (no start byte in it) and split anywhere comes
    /// out whole, once.
    #[test]
    fn round_trip_through_noise(
        payload in prop::collection::vec(any::<u8>(), 1..=MAX_PAYLOAD),
        noise in prop::collection::vec(any::<u8>().prop_filter("no start", |b| *b != START), 0..40),
        split in any::<prop::sample::Index>(),
    ) {
        let mut bytes = noise.clone();
        bytes.extend(encode(&payload).unwrap());
        let at = split.index(bytes.len() + 1);
        let mut d = Decoder::new();
        let mut found = Vec::new();
        d.push(&bytes[..at], &mut found);
        d.push(&bytes[at..], &mut found);
        prop_assert_eq!(packets(&found), vec![&payload]);
        prop_assert_eq!(d.skipped, noise.len() as u64);
        prop_assert!(!d.in_frame());
    }

    /// Any byte of the payload or the CRC changed is caught; the next
    /// packet still comes through unless a start byte inside the bad frame
    /// begins a false frame that swallows it (S3G has no escaping).
    #[test]
    fn corrupted_byte_is_caught(
        payload in prop::collection::vec(any::<u8>(), 1..=MAX_PAYLOAD),
        at in any::<prop::sample::Index>(),
        flip in 1u8..=255,
    ) {
        let mut bytes = encode(&payload).unwrap();
        let i = 2 + at.index(payload.len() + 1);
        bytes[i] ^= flip;
        let next = encode(&[0x81, 7]).unwrap();
        bytes.extend(&next);
        let (found, d) = Decoder::decode_all(&bytes);
        prop_assert!(!packets(&found).contains(&&payload), "corruption missed");
        prop_assert!(d.crc_errors >= 1);
        if !bytes[2..i + 1].contains(&START) && !payload.contains(&START) {
            let want = vec![0x81u8, 7];
            prop_assert_eq!(packets(&found), vec![&want]);
        }
    }

    /// Every command reads back as written, and frames into a packet.
    #[test]
    fn commands_round_trip(c in command()) {
        let p = c.encode().unwrap();
        prop_assert_eq!(Command::decode(&p).unwrap(), c.clone());
        let (found, _) = Decoder::decode_all(&encode(&p).unwrap());
        prop_assert_eq!(packets(&found), vec![&p]);
        if c.is_action() {
            prop_assert_eq!(stream::read_commands(&p).unwrap(), vec![c]);
        }
    }
}
