//! A small deterministic byte mutator for the smoke runs on stable Rust:
//! libFuzzer's basic moves (flip, set, insert, erase, duplicate, splice,
//! interesting values) driven by a seeded generator, so a run is the same
//! every time and any input it fails on can be printed and kept.

/// SplitMix64: tiny, well distributed, reproducible.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// A number in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Values that often sit on a boundary.
const INTERESTING: &[&[u8]] = &[
    b"0",
    b"-1",
    b"1e308",
    b"-1e308",
    b"1e-300",
    b"NaN",
    b"inf",
    b"-0",
    b"4294967296",
    b"18446744073709551616",
    b"0.0000001",
    b"\xff",
    b"\x00",
    b"\x7f",
    b"\x80",
];

/// One to four random edits of `input`, `other` as splice material; the
/// result is at most `max` bytes.
pub fn mutate(input: &[u8], other: &[u8], rng: &mut Rng, max: usize) -> Vec<u8> {
    let mut out = input.to_vec();
    for _ in 0..1 + rng.below(4) {
        let len = out.len();
        match rng.below(8) {
            0 if len > 0 => {
                let i = rng.below(len);
                out[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                out[i] = rng.next_u64() as u8;
            }
            2 => {
                let i = rng.below(len + 1);
                out.insert(i, rng.next_u64() as u8);
            }
            3 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(16));
                out.drain(i..i + n);
            }
            4 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(32));
                let piece = out[i..i + n].to_vec();
                let at = rng.below(len + 1);
                out.splice(at..at, piece);
            }
            5 if !other.is_empty() => {
                let i = rng.below(other.len());
                let n = 1 + rng.below((other.len() - i).min(64));
                let at = rng.below(len + 1);
                out.splice(at..at, other[i..i + n].iter().copied());
            }
            6 => {
                let v = INTERESTING[rng.below(INTERESTING.len())];
                let at = rng.below(len + 1);
                let end = (at + v.len()).min(len);
                out.splice(at..end, v.iter().copied());
            }
            7 if len > 0 => {
                let i = rng.below(len);
                out.truncate(i);
            }
            _ => {}
        }
    }
    out.truncate(max);
    out
}
