//! The four-track recording format (Stepdance's FourTrackRecorder):
//!
//! * one byte per frame; track `i` uses bits `2i..2i+1`: `11` forward step,
//!   `10` reverse step, `00` none (`01` is read as none);
//! * the length (sample count) is kept apart from the bytes ([`Tape::len`]),
//!   like the paper's companion file;
//! * each track is quantised to at most one step per frame at its resolution
//!   (default [`DEFAULT_RESOLUTION`] = 0.01 mm per step) by [`StepQuantizer`].
//!
//! Storage is a caller-provided byte buffer: nothing is allocated.

/// Tracks per byte.
pub const TRACKS: usize = 4;
/// Default track resolution: world units (mm) per recorded step.
pub const DEFAULT_RESOLUTION: f64 = 0.01;

/// Packs four track steps (−1, 0, +1 each) into a byte.
pub fn pack(steps: [i8; TRACKS]) -> u8 {
    let mut b = 0u8;
    for (i, s) in steps.iter().enumerate() {
        let bits = match s.signum() {
            1 => 0b11,
            -1 => 0b10,
            _ => 0b00,
        };
        b |= bits << (2 * i);
    }
    b
}

/// Unpacks a byte into four track steps.
pub fn unpack(b: u8) -> [i8; TRACKS] {
    let mut out = [0i8; TRACKS];
    for (i, s) in out.iter_mut().enumerate() {
        *s = match (b >> (2 * i)) & 0b11 {
            0b11 => 1,
            0b10 => -1,
            _ => 0,
        };
    }
    out
}

/// A recording: bytes in a caller's buffer plus the sample count.
#[derive(Debug)]
pub struct Tape<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl<'a> Tape<'a> {
    /// An empty tape over `buf`.
    pub fn new(buf: &'a mut [u8]) -> Tape<'a> {
        Tape { buf, len: 0 }
    }

    /// A tape holding `len` samples already in `buf` (clamped to its size).
    pub fn with_len(buf: &'a mut [u8], len: usize) -> Tape<'a> {
        let len = len.min(buf.len());
        Tape { buf, len }
    }

    /// Sample count.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the tape holds no sample.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The most samples it holds (its buffer's size).
    pub fn capacity(&self) -> usize {
        self.buf.len()
    }

    /// The recorded samples.
    pub fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Appends a sample; false when the buffer is full.
    pub fn push(&mut self, b: u8) -> bool {
        if self.len >= self.buf.len() {
            return false;
        }
        self.buf[self.len] = b;
        self.len += 1;
        true
    }

    /// Sample `i`, if recorded.
    pub fn get(&self, i: usize) -> Option<u8> {
        (i < self.len).then(|| self.buf[i])
    }

    /// Forgets the samples (the buffer is kept).
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

/// Quantizes one recorded track to whole steps, at most one per frame, by
/// the half-step rule: a step is taken when the value is more than half a
/// step away from the steps already recorded. (The wire's
/// `motet_wire::stream::Quantizer` is another thing: it quantizes segments.)
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepQuantizer {
    base: f64,
    count: i64,
}

impl StepQuantizer {
    /// Starts counting from `value` (in steps).
    pub fn start(value: f64) -> StepQuantizer {
        StepQuantizer {
            base: value,
            count: 0,
        }
    }

    /// The step (−1, 0, +1) for the track now at `value` (in steps).
    #[inline]
    pub fn step(&mut self, value: f64) -> i8 {
        let rel = value - self.base - self.count as f64;
        if rel > 0.5 {
            self.count += 1;
            1
        } else if rel < -0.5 {
            self.count -= 1;
            -1
        } else {
            0
        }
    }

    /// Steps recorded, net.
    pub fn count(&self) -> i64 {
        self.count
    }
}
