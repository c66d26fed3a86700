//! Frame encoding: round trips, corruption, garbage and stream resynchronisation.

use motet_wire::frame::{
    self, crc32c, decode, decode_in_place, encode, Deframer, Flags, FrameError, Header, BROADCAST,
    GROUP_FIRST, GROUP_LAST, MAX_FRAME, MAX_PAYLOAD, MAX_RAW, OVERHEAD,
};
use proptest::prelude::*;

fn header(dst: u16, src: u16, port: u8, flags: u8, seq: u16, ack: u16) -> Header {
    Header {
        dst,
        src,
        port,
        flags: Flags::from_bits(flags),
        seq,
        ack,
    }
}

fn enc(h: &Header, payload: &[u8]) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(h, payload, &mut out).unwrap();
    out[..n].to_vec()
}

fn round_trip(h: &Header, payload: &[u8]) {
    let bytes = enc(h, payload);
    assert!(bytes.len() <= MAX_FRAME);
    assert_eq!(
        bytes.len(),
        payload.len() + OVERHEAD,
        "{h:?} {}",
        payload.len()
    );
    assert_eq!(*bytes.last().unwrap(), 0);
    assert!(!bytes[..bytes.len() - 1].contains(&0));
    let mut buf = [0u8; MAX_RAW];
    let f = decode(&bytes, &mut buf).unwrap();
    assert_eq!(f.header, *h);
    assert_eq!(f.payload, payload);
    // Without the delimiter, and in place.
    let f = decode(&bytes[..bytes.len() - 1], &mut buf).unwrap();
    assert_eq!(f.payload, payload);
    let mut copy = bytes.clone();
    let f = decode_in_place(&mut copy).unwrap();
    assert_eq!((f.header, f.payload), (*h, payload));
}

#[test]
fn field_extremes_round_trip() {
    let addrs = [0, 1, 0x7FFF, GROUP_FIRST, GROUP_LAST, BROADCAST];
    let payloads: Vec<Vec<u8>> = vec![
        vec![],
        vec![0],
        vec![0xFF],
        vec![0; MAX_PAYLOAD],
        vec![0xFF; MAX_PAYLOAD],
        (0..MAX_PAYLOAD).map(|i| i as u8).collect(),
        (0..MAX_PAYLOAD).map(|i| (i % 2) as u8).collect(),
    ];
    let mut n = 0;
    for &dst in &addrs {
        for &src in &addrs {
            for &port in &[0u8, 1, 8, 255] {
                for flags in [0u8, 1, 2, 4, 8, 15] {
                    for &(seq, ack) in &[(0u16, 0u16), (u16::MAX, u16::MAX), (1, 0x8000)] {
                        for p in &payloads {
                            round_trip(&header(dst, src, port, flags, seq, ack), p);
                            n += 1;
                        }
                    }
                }
            }
        }
    }
    assert_eq!(n, 6 * 6 * 4 * 6 * 3 * 7);
}

#[test]
fn multicast_addresses() {
    assert!(frame::is_multicast(BROADCAST));
    assert!(frame::is_multicast(GROUP_FIRST));
    assert!(frame::is_multicast(GROUP_LAST));
    assert!(!frame::is_multicast(GROUP_FIRST - 1));
    assert!(!frame::is_multicast(0));
}

#[test]
fn oversized_payload_and_small_buffers_are_refused() {
    let h = header(1, 2, 3, 8, 4, 5);
    let mut out = [0u8; MAX_FRAME];
    assert_eq!(
        encode(&h, &[1; MAX_PAYLOAD + 1], &mut out),
        Err(FrameError::TooLong)
    );
    for len in 0..20 {
        let mut small = vec![0u8; len];
        assert_eq!(encode(&h, &[7; 5], &mut small), Err(FrameError::TooLong));
    }
    let bytes = enc(&h, &[7; 5]);
    let mut tiny = [0u8; 8];
    assert_eq!(decode(&bytes, &mut tiny), Err(FrameError::TooLong));
    assert_eq!(
        decode(&[1u8; MAX_FRAME + 5], &mut [0u8; MAX_RAW]),
        Err(FrameError::TooLong)
    );
}

#[test]
fn typed_rejections() {
    let mut buf = [0u8; MAX_RAW];
    // Too short to hold header and CRC.
    assert_eq!(decode(&[3, 1, 2, 0], &mut buf), Err(FrameError::Truncated));
    assert_eq!(decode(&[], &mut buf), Err(FrameError::Truncated));
    // A zero inside, a block running past the end.
    assert_eq!(decode(&[2, 0, 5, 0], &mut buf), Err(FrameError::BadCobs));
    assert_eq!(decode(&[9, 1, 2], &mut buf), Err(FrameError::BadCobs));
    // A good CRC over an unknown format version.
    let mut raw = header(1, 2, 3, 0, 4, 5).to_bytes().to_vec();
    raw[0] = 0x2_0;
    raw.extend_from_slice(&crc32c(&raw).to_le_bytes());
    let mut stuffed = vec![0u8; MAX_FRAME];
    let n = cobs(&raw, &mut stuffed);
    assert_eq!(
        decode(&stuffed[..n], &mut buf),
        Err(FrameError::UnknownVersion)
    );
    // Same bytes, version 1: accepted.
    raw.truncate(10);
    raw[0] = 0x1_0;
    raw.extend_from_slice(&crc32c(&raw).to_le_bytes());
    let n = cobs(&raw, &mut stuffed);
    assert!(decode(&stuffed[..n], &mut buf).is_ok());
}

/// Reference COBS encoder (no delimiter) for building odd frames.
fn cobs(raw: &[u8], out: &mut [u8]) -> usize {
    let mut code_at = 0;
    let mut o = 1;
    let mut code = 1u8;
    for &b in raw {
        if b == 0 {
            out[code_at] = code;
            code_at = o;
            o += 1;
            code = 1;
        } else {
            out[o] = b;
            o += 1;
            code += 1;
            if code == 0xFF {
                out[code_at] = code;
                code_at = o;
                o += 1;
                code = 1;
            }
        }
    }
    out[code_at] = code;
    o
}

/// A spread of valid frames for the corruption tests.
fn sample_frames() -> Vec<Vec<u8>> {
    let mut v = Vec::new();
    for (i, len) in [0usize, 1, 7, 60, 191, MAX_PAYLOAD].into_iter().enumerate() {
        let payload: Vec<u8> = (0..len).map(|k| (k * 37 + i * 11) as u8).collect();
        let zeros: Vec<u8> = (0..len).map(|k| if k % 3 == 0 { 0 } else { 9 }).collect();
        let h = header(
            i as u16,
            0xFFFF - i as u16,
            i as u8,
            (i % 16) as u8,
            300 * i as u16,
            7,
        );
        v.push(enc(&h, &payload));
        v.push(enc(&h, &zeros));
    }
    v
}

#[test]
fn every_single_bit_flip_is_rejected() {
    let mut buf = [0u8; MAX_RAW];
    let mut checked = 0;
    for bytes in sample_frames() {
        for i in 0..bytes.len() {
            for bit in 0..8 {
                let mut b = bytes.clone();
                b[i] ^= 1 << bit;
                assert!(decode(&b, &mut buf).is_err(), "byte {i} bit {bit}");
                // The same in a stream: nothing decodes.
                let mut d = Deframer::new();
                let mut rest: &[u8] = &b;
                while !rest.is_empty() {
                    let (n, r) = d.push(rest);
                    assert!(!matches!(r, Some(Ok(_))), "stream byte {i} bit {bit}");
                    rest = &rest[n..];
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 8_000, "{checked}");
}

#[test]
fn every_truncation_is_rejected() {
    let mut buf = [0u8; MAX_RAW];
    for bytes in sample_frames() {
        let body = &bytes[..bytes.len() - 1];
        for n in 0..body.len() {
            // Cut at the end and at the start.
            assert!(decode(&body[..n], &mut buf).is_err(), "head {n}");
            assert!(
                decode(&body[body.len() - n..], &mut buf).is_err(),
                "tail {n}"
            );
        }
    }
}

fn drain(d: &mut Deframer, mut input: &[u8]) -> (Vec<(Header, Vec<u8>)>, Vec<FrameError>) {
    let mut ok = Vec::new();
    let mut errs = Vec::new();
    while !input.is_empty() {
        let (n, r) = d.push(input);
        match r {
            Some(Ok(f)) => ok.push((f.header, f.payload.to_vec())),
            Some(Err(e)) => errs.push(e),
            None => {}
        }
        input = &input[n..];
    }
    (ok, errs)
}

#[test]
fn concatenated_frames_and_missing_delimiters() {
    let frames = sample_frames();
    let stream: Vec<u8> = frames.concat();
    // Fed whole, and byte by byte.
    let (ok, errs) = drain(&mut Deframer::new(), &stream);
    assert_eq!(ok.len(), frames.len());
    assert!(errs.is_empty());
    let mut d = Deframer::new();
    let mut count = 0;
    for b in &stream {
        count += drain(&mut d, std::slice::from_ref(b)).0.len();
    }
    assert_eq!(count, frames.len());
    // Two frames run together (delimiter lost): both lost, the next one found.
    let mut s = frames[2].clone();
    s.pop();
    s.extend_from_slice(&frames[3]);
    s.extend_from_slice(&frames[4]);
    let (ok, errs) = drain(&mut Deframer::new(), &s);
    assert_eq!(ok.len(), 1);
    assert_eq!(errs.len(), 1);
    // A run of non-zero bytes longer than any frame: one TooLong, then resync.
    let mut s = vec![0x55u8; 1000];
    s.push(0);
    s.extend_from_slice(&frames[5]);
    let (ok, errs) = drain(&mut Deframer::new(), &s);
    assert_eq!((ok.len(), errs), (1, vec![FrameError::TooLong]));
    // Leading and repeated delimiters are ignored.
    let mut s = vec![0, 0, 0];
    s.extend_from_slice(&frames[0]);
    s.extend_from_slice(&[0, 0]);
    assert_eq!(
        drain(&mut Deframer::new(), &s),
        (vec![decoded(&frames[0])], vec![])
    );
}

fn decoded(bytes: &[u8]) -> (Header, Vec<u8>) {
    let mut buf = [0u8; MAX_RAW];
    let f = decode(bytes, &mut buf).unwrap();
    (f.header, f.payload.to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn any_frame_round_trips(
        dst: u16, src: u16, port: u8, flags in 0u8..16, seq: u16, ack: u16,
        payload in proptest::collection::vec(any::<u8>(), 0..=MAX_PAYLOAD),
    ) {
        round_trip(&header(dst, src, port, flags, seq, ack), &payload);
    }

    #[test]
    fn garbage_never_panics_nor_decodes(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let mut buf = [0u8; MAX_RAW];
        prop_assert!(decode(&bytes, &mut buf).is_err());
        let mut copy = bytes.clone();
        prop_assert!(decode_in_place(&mut copy).is_err());
        let (ok, _) = drain(&mut Deframer::new(), &bytes);
        prop_assert!(ok.is_empty());
    }

    #[test]
    fn streams_with_interleaved_garbage_resynchronise(
        payloads in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..=MAX_PAYLOAD), 1..12),
        garbage in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..300), 12),
        chunk in 1usize..100,
    ) {
        // garbage, 0, frame, garbage, 0, frame, …: every frame comes out, in order.
        let mut stream = Vec::new();
        let mut want = Vec::new();
        for (i, p) in payloads.iter().enumerate() {
            stream.extend_from_slice(&garbage[i]);
            stream.push(0);
            let h = header(i as u16, 1, 2, 8, i as u16, 0);
            stream.extend_from_slice(&enc(&h, p));
            want.push((h, p.clone()));
        }
        let mut d = Deframer::new();
        let mut got = Vec::new();
        for c in stream.chunks(chunk) {
            got.extend(drain(&mut d, c).0);
        }
        prop_assert_eq!(got, want);
    }

    #[test]
    fn random_corruption_never_yields_a_wrong_frame(
        payload in proptest::collection::vec(any::<u8>(), 0..=MAX_PAYLOAD),
        flips in proptest::collection::vec((any::<usize>(), 0u8..8), 1..4),
    ) {
        let h = header(5, 6, 7, 9, 10, 11);
        let mut bytes = enc(&h, &payload);
        let len = bytes.len();
        for (i, bit) in flips {
            bytes[i % len] ^= 1 << bit;
        }
        let mut buf = [0u8; MAX_RAW];
        if let Ok(f) = decode(&bytes, &mut buf) {
            // Only if the flips cancelled out.
            prop_assert_eq!((f.header, f.payload), (h, &payload[..]));
        }
    }
}
