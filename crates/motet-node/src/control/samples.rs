//! Samples upstream: each loop's ticks decimated into samples (a servo's
//! position at the window's end with the least and most following error
//! over it, so a decimated trace keeps its peaks; a sensor's mean over the
//! window), gathered into batches of one source, and the bounded queue of
//! messages waiting to go to the host.
//!
//! A batch closes when it is full, when one more sample could make its
//! message longer than [`MAX_MESSAGE`], or when its first sample is
//! [`MAX_BATCH_AGE_US`] old, so the host hears from every sampled source
//! at least that often while it runs. A batch that finds the queue full is
//! dropped and counted in the next one's `dropped`.

use heapless::{Deque, Vec};
use motet_wire::control::{
    FaultKind, SampleBatch, SampleData, SampleSource, ServoSample, SERVO_SAMPLES, VALUE_SAMPLES,
};
use motet_wire::{NodeMessage, MAX_MESSAGE};

/// Most messages waiting to go upstream.
pub const UPSTREAM: usize = 4;

/// Longest a batch gathers before it goes, µs of host time.
pub const MAX_BATCH_AGE_US: f64 = 1e6;

/// Bytes of a batch message besides its samples, at most: the variant,
/// the source, `t0`, `period_us`, `dropped`, the data's variant, a servo's
/// base and the samples' count.
const HEADER_BYTES: usize = 1 + 2 + 8 + 4 + 3 + 1 + 10 + 1;

/// Messages waiting to go upstream, oldest first.
#[derive(Clone, Debug, Default)]
pub struct Upstream {
    queue: Deque<NodeMessage, UPSTREAM>,
}

impl Upstream {
    /// An empty queue.
    pub const fn new() -> Upstream {
        Upstream {
            queue: Deque::new(),
        }
    }

    /// The oldest message, taken.
    pub fn take(&mut self) -> Option<NodeMessage> {
        self.queue.pop_front()
    }

    /// Messages waiting.
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// Whether none waits.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Queues a fault. A fault goes before samples: when the queue is full
    /// the newest batch makes room for it.
    pub fn fault(&mut self, source: SampleSource, kind: FaultKind, at: f64, value: f32) {
        let m = NodeMessage::Fault {
            source,
            kind,
            at,
            value,
        };
        if self.queue.is_full() {
            self.queue.pop_back();
        }
        let _ = self.queue.push_back(m);
    }

    /// Queues a message that must reach the host (a heater's readiness):
    /// as a fault, it makes room by dropping the newest batch.
    pub fn urgent(&mut self, m: NodeMessage) {
        if self.queue.is_full() {
            self.queue.pop_back();
        }
        let _ = self.queue.push_back(m);
    }

    /// Queues a batch; false (nothing queued) when the queue is full.
    fn batch(&mut self, b: SampleBatch) -> bool {
        self.queue.push_back(NodeMessage::Samples(b)).is_ok()
    }
}

/// Bytes of `v` as a postcard varint.
fn varint_len(v: u64) -> usize {
    let bits = 64 - v.leading_zeros() as usize;
    bits.max(1).div_ceil(7)
}

/// Bytes of `v` as a postcard zigzag varint.
fn zigzag_len(v: i64) -> usize {
    varint_len(((v << 1) ^ (v >> 63)) as u64)
}

/// `counts` in 1/16 count, saturating.
fn sixteenths(counts: f32) -> i16 {
    let v = counts * 16.0;
    if v.is_nan() {
        0
    } else if v >= i16::MAX as f32 {
        i16::MAX
    } else if v <= i16::MIN as f32 {
        i16::MIN
    } else {
        libm::roundf(v) as i16
    }
}

/// Decimates one source's ticks into samples and gathers them into
/// batches.
#[derive(Clone, Debug)]
pub struct Sampler {
    source: SampleSource,
    /// Ticks a sample (0: off).
    every: u32,
    /// Ticks in the current window.
    n: u32,
    lo: f32,
    hi: f32,
    sum: f32,
    /// The batch being gathered.
    batch: Option<SampleBatch>,
    /// Its message's bytes so far, at most.
    bytes: usize,
    /// The count its last sample is at.
    last: i64,
    /// Samples lost since the last batch queued.
    dropped: u16,
}

impl Sampler {
    /// A sampler of `source`, off.
    pub const fn new(source: SampleSource) -> Sampler {
        Sampler {
            source,
            every: 0,
            n: 0,
            lo: f32::INFINITY,
            hi: f32::NEG_INFINITY,
            sum: 0.0,
            batch: None,
            bytes: 0,
            last: 0,
            dropped: 0,
        }
    }

    /// One sample every `every` ticks (0: none); a batch being gathered
    /// goes first.
    pub fn set_every(&mut self, every: u32, up: &mut Upstream) {
        self.flush(up);
        self.every = every;
        self.n = 0;
        self.reset_window();
    }

    /// Ticks a sample (0: off).
    pub fn every(&self) -> u32 {
        self.every
    }

    fn reset_window(&mut self) {
        self.lo = f32::INFINITY;
        self.hi = f32::NEG_INFINITY;
        self.sum = 0.0;
    }

    /// A servo's tick at host time `t`: its count and following error.
    pub fn servo(&mut self, t: f64, period_us: f64, count: i64, error: f32, up: &mut Upstream) {
        if self.every == 0 {
            return;
        }
        self.lo = self.lo.min(error);
        self.hi = self.hi.max(error);
        self.n += 1;
        if self.n < self.every {
            return;
        }
        self.n = 0;
        let s = ServoSample {
            delta: 0,
            error_lo: sixteenths(self.lo),
            error_hi: sixteenths(self.hi),
        };
        self.reset_window();
        let every = self.every as f64;
        if self.batch.is_none() {
            self.open(
                t,
                period_us * every,
                SampleData::Servo {
                    base: count,
                    samples: Vec::new(),
                },
            );
            self.bytes += zigzag_len(count);
            self.last = count;
        }
        let delta = count.wrapping_sub(self.last);
        let Ok(delta) = i32::try_from(delta) else {
            // A jump no sample can carry starts a batch of its own.
            self.flush(up);
            return self.servo_first(t, period_us * every, count, s, up);
        };
        let size = zigzag_len(delta as i64)
            + zigzag_len(s.error_lo as i64)
            + zigzag_len(s.error_hi as i64);
        if self.bytes + size > MAX_MESSAGE {
            self.flush(up);
            return self.servo_first(t, period_us * every, count, s, up);
        }
        self.push_servo(ServoSample { delta, ..s }, size, count, t, up);
    }

    fn servo_first(&mut self, t: f64, period: f64, count: i64, s: ServoSample, up: &mut Upstream) {
        self.open(
            t,
            period,
            SampleData::Servo {
                base: count,
                samples: Vec::new(),
            },
        );
        self.bytes += zigzag_len(count);
        self.last = count;
        let size = 1 + zigzag_len(s.error_lo as i64) + zigzag_len(s.error_hi as i64);
        self.push_servo(s, size, count, t, up);
    }

    fn push_servo(&mut self, s: ServoSample, size: usize, count: i64, t: f64, up: &mut Upstream) {
        if let Some(SampleBatch {
            data: SampleData::Servo { samples, .. },
            ..
        }) = self.batch.as_mut()
        {
            let _ = samples.push(s);
        }
        self.bytes += size;
        self.last = count;
        self.close_if_done(t, SERVO_SAMPLES, 11, up);
    }

    /// A sensor's reading at host time `t`: its window's mean goes.
    pub fn value(&mut self, t: f64, period_us: f64, v: f32, up: &mut Upstream) {
        if self.every == 0 {
            return;
        }
        self.sum += v;
        self.n += 1;
        if self.n < self.every {
            return;
        }
        let mean = self.sum / self.n as f32;
        self.n = 0;
        self.reset_window();
        if self.batch.is_none() {
            let period = period_us * self.every as f64;
            self.open(t, period, SampleData::Values(Vec::new()));
        }
        if let Some(SampleBatch {
            data: SampleData::Values(values),
            ..
        }) = self.batch.as_mut()
        {
            let _ = values.push(mean);
        }
        self.bytes += 4;
        self.close_if_done(t, VALUE_SAMPLES, 4, up);
    }

    /// A heater's tick at host time `t`: its reading, target and power.
    /// A sample is three values: the reading's and the power's means over
    /// the window, and the target at its end.
    pub fn heater(
        &mut self,
        t: f64,
        period_us: f64,
        reading: f32,
        target: f32,
        power: f32,
        up: &mut Upstream,
    ) {
        if self.every == 0 {
            return;
        }
        self.sum += reading;
        // The window's power rides in `lo`, which heaters do not use.
        self.lo = if self.n == 0 { power } else { self.lo + power };
        self.n += 1;
        if self.n < self.every {
            return;
        }
        let n = self.n as f32;
        let (mean, power) = (self.sum / n, self.lo / n);
        self.n = 0;
        self.reset_window();
        if self.batch.is_none() {
            let period = period_us * self.every as f64;
            self.open(t, period, SampleData::Values(Vec::new()));
        }
        if let Some(SampleBatch {
            data: SampleData::Values(values),
            ..
        }) = self.batch.as_mut()
        {
            let _ = values.push(mean);
            let _ = values.push(target);
            let _ = values.push(power);
        }
        self.bytes += 12;
        self.close_if_done(t, VALUE_SAMPLES - 3, 12, up);
    }

    fn open(&mut self, t0: f64, period_us: f64, data: SampleData) {
        self.batch = Some(SampleBatch {
            source: self.source,
            t0,
            period_us: period_us as f32,
            dropped: self.dropped,
            data,
        });
        self.bytes = HEADER_BYTES;
    }

    /// Closes the batch when full, when another sample (at most `reserve`
    /// bytes) might not fit a message, or when it is old.
    fn close_if_done(&mut self, t: f64, capacity: usize, reserve: usize, up: &mut Upstream) {
        let Some(b) = self.batch.as_ref() else {
            return;
        };
        let full = b.len() >= capacity || self.bytes + reserve > MAX_MESSAGE;
        if full || t - b.t0 >= MAX_BATCH_AGE_US {
            self.flush(up);
        }
    }

    /// Queues the batch being gathered, if any.
    pub fn flush(&mut self, up: &mut Upstream) {
        if let Some(b) = self.batch.take() {
            let n = b.len() as u16;
            if up.batch(b) {
                self.dropped = 0;
            } else {
                self.dropped = self.dropped.saturating_add(n);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_wire::encode;

    #[test]
    fn batches_fit_a_message_and_keep_peaks() {
        let mut up = Upstream::new();
        let mut s = Sampler::new(SampleSource::Servo(0));
        s.set_every(10, &mut up);
        let mut count: i64 = 1 << 40;
        // Large moves between samples: every delta takes five bytes.
        for k in 0..2000 {
            count += 300_000_000;
            let error = if k % 10 == 3 { 7.0 } else { 0.5 };
            s.servo(k as f64 * 100.0, 100.0, count, error, &mut up);
            while let Some(m) = up.take() {
                let mut buf = [0u8; MAX_MESSAGE];
                assert!(encode(&m, &mut buf).is_ok(), "{m:?} fits");
                let NodeMessage::Samples(b) = m else {
                    panic!("{m:?}")
                };
                let SampleData::Servo { samples, .. } = b.data else {
                    panic!()
                };
                assert!(samples.iter().all(|x| x.error_hi == 7 * 16));
            }
        }
    }

    #[test]
    fn full_queue_counts_what_it_drops() {
        let mut up = Upstream::new();
        let mut s = Sampler::new(SampleSource::Sensor(1));
        s.set_every(1, &mut up);
        for k in 0..(VALUE_SAMPLES * (UPSTREAM + 2)) {
            s.value(k as f64, 1.0, k as f32, &mut up);
        }
        assert_eq!(up.len(), UPSTREAM);
        while up.take().is_some() {}
        for k in 0..VALUE_SAMPLES {
            s.value(1e3 + k as f64, 1.0, 0.0, &mut up);
        }
        let Some(NodeMessage::Samples(b)) = up.take() else {
            panic!()
        };
        assert_eq!(b.dropped as usize, 2 * VALUE_SAMPLES);
        // A fault always finds room.
        for _ in 0..UPSTREAM {
            s.value(0.0, 1.0, 0.0, &mut up);
        }
        up.fault(SampleSource::Sensor(1), FaultKind::SensorLost, 5.0, 0.0);
        assert!(core::iter::from_fn(|| up.take()).any(|m| matches!(m, NodeMessage::Fault { .. })));
    }

    #[test]
    fn old_batches_go() {
        let mut up = Upstream::new();
        let mut s = Sampler::new(SampleSource::Sensor(0));
        s.set_every(1, &mut up);
        s.value(0.0, 1e5, 1.0, &mut up);
        assert!(up.is_empty());
        s.value(MAX_BATCH_AGE_US, 1e5, 2.0, &mut up);
        assert_eq!(up.len(), 1);
    }
}
