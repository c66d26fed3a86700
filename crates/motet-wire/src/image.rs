//! Firmware image files: a fixed header, then the payload a node runs.
//!
//! | byte | size | field |
//! |---|---|---|
//! | 0–3 | 4 | magic `MTFW` |
//! | 4 | 1 | image format version: 2 ([`IMAGE_FORMAT`]), or 1 |
//! | 5 | 1 | length of the node kind, 1..=16 |
//! | 6–21 | 16 | node kind (ASCII, zero-padded) |
//! | 22–27 | 6 | firmware version: major, minor, patch, u16 LE each |
//! | 28–31 | 4 | payload length, u32 LE |
//! | 32–35 | 4 | CRC-32C of the payload, u32 LE |
//! | 36 | 1 | format 2: length of the board name, 1..=16 |
//! | 37–52 | 16 | format 2: board name (ASCII, zero-padded) |
//! | 53–55 | 3 | format 2: zero |
//! | 36… or 56… | | payload |
//!
//! The header is fixed-size (per format) so that a bootloader can read it
//! from flash into a stack buffer and check the payload a page at a time;
//! the kind is in the image so that a node refuses firmware built for
//! another node type even if the host announced it wrongly, and the board
//! (format 2) so that a board refuses a binary built for another chip.
//! Format 1 images name no board: simulated nodes take them, boards refuse
//! them.

use crate::frame::{crc32c, Crc32c};
use crate::service::{Kind, Version, KIND_LEN};
use serde::{Deserialize, Serialize};

/// First four bytes of every image.
pub const MAGIC: [u8; 4] = *b"MTFW";
/// Image format version this crate writes for an image naming a board
/// (it writes format 1 for one naming none, and reads both).
pub const IMAGE_FORMAT: u8 = 2;
/// Header bytes before the payload in a format 1 image: the shortest header.
pub const MIN_HEADER_LEN: usize = 36;
/// Header bytes before the payload in a format 2 image: the longest header.
pub const MAX_HEADER_LEN: usize = 56;

/// Why bytes are not a firmware image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ImageError {
    /// Fewer bytes than the header, or than the header says.
    Truncated,
    /// More bytes after the payload than the header says.
    TrailingBytes,
    /// The file does not start with [`MAGIC`] ("MTFW"): not a firmware image.
    BadMagic,
    /// An image format version this parser does not know.
    UnknownFormat {
        /// The format byte the image carries.
        format: u8,
    },
    /// The kind is empty, longer than 16 bytes, not ASCII, or not zero-padded.
    BadKind,
    /// The payload does not match the CRC-32C in the header.
    CrcMismatch {
        /// The CRC-32C the header gives.
        expected: u32,
        /// The CRC-32C of the payload as read.
        actual: u32,
    },
    /// The output buffer cannot hold the image.
    BufferTooSmall,
    /// The header announces no payload: there is no firmware to run.
    EmptyPayload,
    /// The board name is empty, longer than 16 bytes, not ASCII, or not
    /// zero-padded (or the reserved bytes after it are not zero).
    BadBoard,
}

impl core::fmt::Display for ImageError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ImageError::Truncated => f.write_str("firmware image truncated"),
            ImageError::TrailingBytes => f.write_str("bytes after the firmware payload"),
            ImageError::BadMagic => f.write_str("not a firmware image (bad magic)"),
            ImageError::UnknownFormat { format } => {
                write!(f, "unknown firmware image format {format}")
            }
            ImageError::BadKind => f.write_str("bad node kind in firmware image"),
            ImageError::CrcMismatch { expected, actual } => write!(
                f,
                "firmware payload CRC-32C {actual:#010x}, header says {expected:#010x}"
            ),
            ImageError::BufferTooSmall => f.write_str("buffer too small for the firmware image"),
            ImageError::EmptyPayload => f.write_str("firmware image with an empty payload"),
            ImageError::BadBoard => f.write_str("bad board name in firmware image"),
        }
    }
}

/// An image's header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageHeader {
    /// The node kind the firmware is for (a node of another kind refuses it).
    pub kind: Kind,
    /// The board the payload was built for; None in a format 1 image.
    pub board: Option<Kind>,
    /// The firmware's version, what the node reports once it runs.
    pub version: Version,
    /// Payload length, bytes.
    pub payload_len: u32,
    /// CRC-32C of the payload.
    pub payload_crc: u32,
}

/// A zero-padded ASCII name field: `n` bytes of `field`, printable, the
/// rest zero.
fn name_field(n: usize, field: &[u8]) -> Option<Kind> {
    if n == 0 || n > KIND_LEN || field[n..].iter().any(|&b| b != 0) {
        return None;
    }
    let text = &field[..n];
    if !text.iter().all(|&b| b.is_ascii_graphic()) {
        return None;
    }
    let mut name = Kind::new();
    for &b in text {
        name.push(b as char).ok()?;
    }
    Some(name)
}

/// Writes `name` into a length byte and a zero-padded field.
fn put_name(name: &Kind, len: &mut u8, field: &mut [u8]) -> bool {
    let b = name.as_bytes();
    if b.is_empty() || b.len() > field.len() || !b.iter().all(|c| c.is_ascii_graphic()) {
        return false;
    }
    *len = b.len() as u8;
    field[..b.len()].copy_from_slice(b);
    true
}

fn u16_at(b: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

impl ImageHeader {
    /// Parses the header at the start of `bytes` (the payload is not checked;
    /// a header announcing none is refused).
    pub fn parse(bytes: &[u8]) -> Result<ImageHeader, ImageError> {
        if bytes.len() < MIN_HEADER_LEN {
            return Err(ImageError::Truncated);
        }
        if bytes[0..4] != MAGIC {
            return Err(ImageError::BadMagic);
        }
        let format = bytes[4];
        if format != 1 && format != 2 {
            return Err(ImageError::UnknownFormat { format });
        }
        if format == 2 && bytes.len() < MAX_HEADER_LEN {
            return Err(ImageError::Truncated);
        }
        let kind =
            name_field(bytes[5] as usize, &bytes[6..6 + KIND_LEN]).ok_or(ImageError::BadKind)?;
        let board = if format == 2 {
            if bytes[53..56].iter().any(|&b| b != 0) {
                return Err(ImageError::BadBoard);
            }
            Some(
                name_field(bytes[36] as usize, &bytes[37..37 + KIND_LEN])
                    .ok_or(ImageError::BadBoard)?,
            )
        } else {
            None
        };
        Ok(ImageHeader {
            kind,
            board,
            version: Version {
                major: u16_at(bytes, 22),
                minor: u16_at(bytes, 24),
                patch: u16_at(bytes, 26),
            },
            payload_len: match u32_at(bytes, 28) {
                0 => return Err(ImageError::EmptyPayload),
                n => n,
            },
            payload_crc: u32_at(bytes, 32),
        })
    }

    /// Header bytes before the payload: 56 naming a board (format 2), 36
    /// naming none (format 1).
    pub fn header_len(&self) -> usize {
        if self.board.is_some() {
            MAX_HEADER_LEN
        } else {
            MIN_HEADER_LEN
        }
    }

    /// The header's bytes (the first [`ImageHeader::header_len`] of the
    /// array); fails only for a kind or board that [`ImageHeader::parse`]
    /// would refuse.
    pub fn to_bytes(&self) -> Result<[u8; MAX_HEADER_LEN], ImageError> {
        let mut h = [0u8; MAX_HEADER_LEN];
        h[0..4].copy_from_slice(&MAGIC);
        h[4] = if self.board.is_some() {
            IMAGE_FORMAT
        } else {
            1
        };
        let (len, rest) = h[5..].split_at_mut(1);
        if !put_name(&self.kind, &mut len[0], &mut rest[..KIND_LEN]) {
            return Err(ImageError::BadKind);
        }
        if let Some(board) = &self.board {
            let (len, rest) = h[36..].split_at_mut(1);
            if !put_name(board, &mut len[0], &mut rest[..KIND_LEN]) {
                return Err(ImageError::BadBoard);
            }
        }
        h[22..24].copy_from_slice(&self.version.major.to_le_bytes());
        h[24..26].copy_from_slice(&self.version.minor.to_le_bytes());
        h[26..28].copy_from_slice(&self.version.patch.to_le_bytes());
        h[28..32].copy_from_slice(&self.payload_len.to_le_bytes());
        h[32..36].copy_from_slice(&self.payload_crc.to_le_bytes());
        Ok(h)
    }

    /// Whole image length, header included.
    pub fn image_len(&self) -> u64 {
        self.header_len() as u64 + self.payload_len as u64
    }
}

/// A parsed image borrowing its bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image<'a> {
    /// The header, parsed and checked.
    pub header: ImageHeader,
    /// The payload: the bytes written to the node's firmware storage.
    pub payload: &'a [u8],
}

/// Parses a whole image: header, exact length and payload CRC.
pub fn parse(bytes: &[u8]) -> Result<Image<'_>, ImageError> {
    let header = ImageHeader::parse(bytes)?;
    let len = bytes.len() as u64;
    if len < header.image_len() {
        return Err(ImageError::Truncated);
    }
    if len > header.image_len() {
        return Err(ImageError::TrailingBytes);
    }
    let payload = &bytes[header.header_len()..];
    let actual = crc32c(payload);
    if actual != header.payload_crc {
        return Err(ImageError::CrcMismatch {
            expected: header.payload_crc,
            actual,
        });
    }
    Ok(Image { header, payload })
}

/// Writes an image of `payload` into `out`, returning its length: format 2
/// when it names a `board`, format 1 when not.
pub fn build(
    kind: &str,
    board: Option<&str>,
    version: Version,
    payload: &[u8],
    out: &mut [u8],
) -> Result<usize, ImageError> {
    let mut k = Kind::new();
    k.push_str(kind).map_err(|_| ImageError::BadKind)?;
    let board = match board {
        Some(b) => {
            let mut name = Kind::new();
            name.push_str(b).map_err(|_| ImageError::BadBoard)?;
            Some(name)
        }
        None => None,
    };
    if payload.is_empty() {
        return Err(ImageError::EmptyPayload);
    }
    let payload_len = u32::try_from(payload.len()).map_err(|_| ImageError::BufferTooSmall)?;
    let mut crc = Crc32c::new();
    crc.update(payload);
    let header = ImageHeader {
        kind: k,
        board,
        version,
        payload_len,
        payload_crc: crc.finish(),
    };
    let head = header.to_bytes()?;
    let hl = header.header_len();
    let total = hl + payload.len();
    if out.len() < total {
        return Err(ImageError::BufferTooSmall);
    }
    out[..hl].copy_from_slice(&head[..hl]);
    out[hl..total].copy_from_slice(payload);
    Ok(total)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec;
    use std::vec::Vec;

    const V: Version = Version {
        major: 1,
        minor: 2,
        patch: 300,
    };

    fn image(kind: &str, payload: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; MIN_HEADER_LEN + payload.len()];
        let n = build(kind, None, V, payload, &mut out).unwrap();
        assert_eq!(n, out.len());
        out
    }

    fn board_image(kind: &str, board: &str, payload: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; MAX_HEADER_LEN + payload.len()];
        let n = build(kind, Some(board), V, payload, &mut out).unwrap();
        assert_eq!(n, out.len());
        out
    }

    #[test]
    fn header_layout_format_2() {
        let img = board_image("stepper", "mps2-an500", b"abc");
        assert_eq!(&img[0..4], b"MTFW");
        assert_eq!(img[4], 2);
        assert_eq!(img[5], 7);
        assert_eq!(&img[6..13], b"stepper");
        assert_eq!(&img[22..28], &[1, 0, 2, 0, 0x2c, 1]);
        assert_eq!(&img[28..32], &[3, 0, 0, 0]);
        assert_eq!(u32_at(&img, 32), crc32c(b"abc"));
        assert_eq!(img[36], 10);
        assert_eq!(&img[37..47], b"mps2-an500");
        assert!(img[47..56].iter().all(|&b| b == 0));
        assert_eq!(&img[56..], b"abc");
        let parsed = parse(&img).unwrap();
        assert_eq!(parsed.header.board.as_deref(), Some("mps2-an500"));
        assert_eq!(parsed.payload, b"abc");
        // The same header read from the format 1 bytes: no board.
        assert_eq!(parse(&image("stepper", b"abc")).unwrap().header.board, None);
    }

    #[test]
    fn header_layout() {
        let img = image("stepper", b"abc");
        assert_eq!(&img[0..4], b"MTFW");
        assert_eq!(img[4], 1);
        assert_eq!(img[5], 7);
        assert_eq!(&img[6..13], b"stepper");
        assert!(img[13..22].iter().all(|&b| b == 0));
        assert_eq!(&img[22..28], &[1, 0, 2, 0, 0x2c, 1]);
        assert_eq!(&img[28..32], &[3, 0, 0, 0]);
        assert_eq!(u32_at(&img, 32), crc32c(b"abc"));
        assert_eq!(&img[36..], b"abc");
    }

    #[test]
    fn bad_images_are_named() {
        let good = image("laser", &[7u8; 300]);
        let mut cases: Vec<(Vec<u8>, ImageError)> = Vec::new();
        cases.push((good[..20].to_vec(), ImageError::Truncated));
        cases.push((good[..good.len() - 1].to_vec(), ImageError::Truncated));
        let mut t = good.clone();
        t.push(0);
        cases.push((t, ImageError::TrailingBytes));
        let mut m = good.clone();
        m[0] = b'X';
        cases.push((m, ImageError::BadMagic));
        let mut f = good.clone();
        f[4] = 9;
        cases.push((f, ImageError::UnknownFormat { format: 9 }));
        let mut k = good.clone();
        k[5] = 0;
        cases.push((k, ImageError::BadKind));
        let mut k = good.clone();
        k[5] = 17;
        cases.push((k, ImageError::BadKind));
        let mut k = good.clone();
        k[20] = b'x';
        cases.push((k, ImageError::BadKind));
        let mut k = good.clone();
        k[6] = b' ';
        cases.push((k, ImageError::BadKind));
        let mut p = good.clone();
        p[100] ^= 1;
        let actual = crc32c(&p[36..]);
        cases.push((
            p,
            ImageError::CrcMismatch {
                expected: crc32c(&[7u8; 300]),
                actual,
            },
        ));
        let board = board_image("stepper", "teensy41", &[7u8; 300]);
        cases.push((board[..50].to_vec(), ImageError::Truncated));
        let mut b = board.clone();
        b[36] = 0;
        cases.push((b, ImageError::BadBoard));
        let mut b = board.clone();
        b[50] = b'x';
        cases.push((b, ImageError::BadBoard));
        let mut b = board.clone();
        b[54] = 1;
        cases.push((b, ImageError::BadBoard));
        let mut b = board.clone();
        b[37] = 0x7f;
        cases.push((b, ImageError::BadBoard));
        for (bytes, want) in cases {
            assert_eq!(parse(&bytes), Err(want));
        }
        assert_eq!(
            build("stepper", None, V, b"abc", &mut [0u8; 38]),
            Err(ImageError::BufferTooSmall)
        );
        assert_eq!(
            build("stepper", Some("pico"), V, b"abc", &mut [0u8; 58]),
            Err(ImageError::BufferTooSmall)
        );
        assert_eq!(
            build("", None, V, b"abc", &mut [0u8; 64]),
            Err(ImageError::BadKind)
        );
        assert_eq!(
            build("seventeen-chars!!", None, V, b"x", &mut [0u8; 64]),
            Err(ImageError::BadKind)
        );
        assert_eq!(
            build("stepper", Some(""), V, b"x", &mut [0u8; 64]),
            Err(ImageError::BadBoard)
        );
        assert_eq!(
            build(
                "stepper",
                Some("a board name too long"),
                V,
                b"x",
                &mut [0u8; 64]
            ),
            Err(ImageError::BadBoard)
        );
        // No payload: nothing to run, refused when built and when parsed.
        assert_eq!(
            build("stepper", None, V, b"", &mut [0u8; 64]),
            Err(ImageError::EmptyPayload)
        );
        let mut empty = image("stepper", b"x");
        empty.truncate(MIN_HEADER_LEN);
        empty[28..32].copy_from_slice(&0u32.to_le_bytes());
        empty[32..36].copy_from_slice(&crc32c(b"").to_le_bytes());
        assert_eq!(parse(&empty), Err(ImageError::EmptyPayload));
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
            let _ = parse(&bytes);
            let _ = ImageHeader::parse(&bytes);
        }

        #[test]
        fn good_images_parse(
            kind in "[a-z0-9_-]{1,16}",
            major in any::<u16>(), minor in any::<u16>(), patch in any::<u16>(),
            payload in proptest::collection::vec(any::<u8>(), 1..600),
        ) {
            let version = Version { major, minor, patch };
            let mut out = vec![0u8; MAX_HEADER_LEN + payload.len()];
            let n = build(&kind, Some(&kind), version, &payload, &mut out).unwrap();
            let img = parse(&out[..n]).unwrap();
            prop_assert_eq!(img.header.kind.as_str(), kind.as_str());
            prop_assert_eq!(img.header.board.as_deref(), Some(kind.as_str()));
            prop_assert_eq!(img.header.version, version);
            prop_assert_eq!(img.payload, &payload[..]);
        }

        #[test]
        fn one_flipped_bit_is_caught(
            payload in proptest::collection::vec(any::<u8>(), 1..300),
            at in any::<proptest::sample::Index>(),
            bit in 0u8..8,
        ) {
            let mut img = vec![0u8; MIN_HEADER_LEN + payload.len()];
            build("servo", None, V, &payload, &mut img).unwrap();
            let i = MIN_HEADER_LEN + at.index(payload.len());
            img[i] ^= 1 << bit;
            let is_crc_mismatch = matches!(parse(&img), Err(ImageError::CrcMismatch { .. }));
            prop_assert!(is_crc_mismatch);
        }
    }
}
