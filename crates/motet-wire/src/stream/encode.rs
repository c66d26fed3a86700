//! Host side: quantized segments into batches.

use super::varint::{put_f64, put_i64, put_u64};
use super::{
    index, whole, History, SegmentBatch, StreamConfig, StreamError, StreamState, BATCH_BYTES,
    F_ACCEL, F_JERK, F_LENGTH, F_MASK, F_START, F_V1, VC_EXPLICIT, VC_PREVIOUS, VC_SHIFT, VC_V0,
    VC_V1,
};
use heapless::Vec;
use motet_trajectory::{Point, Segment, MAX_AXES};

/// A finished batch and the number of segments in it.
#[derive(Clone, Debug, PartialEq)]
pub struct Batch {
    /// Sequence number of the batch's first segment.
    pub first_seq: u32,
    /// How many segments it holds.
    pub segments: usize,
    /// The encoded bytes, ready for [`crate::HostMessage::Segments`].
    pub batch: SegmentBatch,
}

/// Packs one node's segments into batches, keeping the same stream state the
/// node's decoder will keep.
#[derive(Clone, Debug)]
pub struct BatchEncoder {
    cfg: StreamConfig,
    /// Axes the node reads.
    axes: u8,
    state: StreamState,
    next_seq: u32,
    max_segments: usize,
    open: Option<Batch>,
    /// Bytes the last segment took: about what the next will.
    last_len: usize,
}

impl BatchEncoder {
    /// An encoder for a node reading `axes` (bit mask), at rest at `start`,
    /// whose next sequence number is `next_seq`, putting at most
    /// `max_segments` (≥ 1) segments in a batch.
    pub fn new(
        cfg: StreamConfig,
        axes: u8,
        start: Point,
        next_seq: u32,
        max_segments: usize,
    ) -> BatchEncoder {
        BatchEncoder {
            cfg,
            axes,
            state: StreamState::at(start),
            next_seq,
            max_segments: max_segments.max(1),
            open: None,
            last_len: 0,
        }
    }

    /// Segments waiting in the open batch.
    pub fn pending(&self) -> usize {
        self.open.as_ref().map_or(0, |b| b.segments)
    }

    /// The open batch would likely not take another segment like the last:
    /// a window that ends here sends it nearly full.
    pub fn nearly_full(&self) -> bool {
        self.open.as_ref().is_some_and(|b| {
            b.segments >= self.max_segments || b.batch.bytes.len() + self.last_len > BATCH_BYTES
        })
    }

    /// Adds a segment. When it does not fit in the open batch (bytes or
    /// count), the open batch is returned finished and the segment opens the
    /// next. On an error nothing changes.
    pub fn push(&mut self, seg: &Segment) -> Result<Option<Batch>, StreamError> {
        let mut bytes: Vec<u8, BATCH_BYTES> = Vec::new();
        let (mask, history) = encode_one(&self.cfg, self.axes, &self.state, seg, &mut bytes)?;
        let full = self.open.as_ref().is_some_and(|b| {
            b.segments >= self.max_segments || b.batch.bytes.len() + bytes.len() > BATCH_BYTES
        });
        let done = if full { self.open.take() } else { None };
        let open = match self.open.as_mut() {
            Some(b) => b,
            None => {
                let mut batch = SegmentBatch::default();
                if !put_u64(&mut batch.bytes, self.next_seq as u64)
                    || batch.bytes.len() + bytes.len() > BATCH_BYTES
                {
                    // Put back what was taken: nothing changes on an error.
                    self.open = done;
                    return Err(StreamError::TooLarge);
                }
                self.open.insert(Batch {
                    first_seq: self.next_seq,
                    segments: 0,
                    batch,
                })
            }
        };
        // Checked above: the segment fits.
        let _ = open.batch.bytes.extend_from_slice(&bytes);
        open.segments += 1;
        self.last_len = bytes.len();
        self.next_seq = self.next_seq.wrapping_add(1);
        self.state.advance(seg, mask, history);
        Ok(done)
    }

    /// The open batch, finished, if it holds any segment.
    pub fn flush(&mut self) -> Option<Batch> {
        self.open.take()
    }
}

/// Encodes `seg` after `st` into `out`; returns the mask of moving axes and
/// the history with its moves.
fn encode_one(
    cfg: &StreamConfig,
    axes: u8,
    st: &StreamState,
    seg: &Segment,
    out: &mut Vec<u8, BATCH_BYTES>,
) -> Result<(u8, History), StreamError> {
    let bad = StreamError::NotQuantized;
    let p = seg.profile.params();
    let (q, sq, aq) = (cfg.quantum, cfg.speed_quantum, cfg.accel_quantum);
    let mut mask = 0u8;
    let mut deltas = [0i64; MAX_AXES];
    for (i, d) in deltas.iter_mut().enumerate() {
        if axes & (1 << i) != 0 && seg.end[i] != st.tail[i] {
            mask |= 1 << i;
            *d = whole(seg.end[i], q).ok_or(bad)? - index(st.tail[i], q).ok_or(bad)?;
        }
    }
    // What the node will rebuild the end as: unmoved axes keep their value.
    let mut end = st.tail;
    for (i, e) in end.iter_mut().enumerate() {
        if mask & (1 << i) != 0 {
            *e = seg.end[i];
        }
    }
    let start = st.valid && seg.t0 == st.t1 && p.v0 == st.v1;
    let v0 = if start { st.v1 } else { p.v0 };
    let dwell = p.length == 0.0;
    let derived = !dwell
        && cfg.path_mask & axes == cfg.path_mask
        && cfg.derived_length(&st.tail, &end) == Some(p.length);
    let vc_mode = if p.vc == v0 {
        VC_V0
    } else if p.vc == p.v1 {
        VC_V1
    } else if st.valid && p.vc == st.vc {
        VC_PREVIOUS
    } else {
        VC_EXPLICIT
    };
    let mut flags = vc_mode << VC_SHIFT;
    let set = |flags: &mut u8, f: u8, on: bool| {
        if on {
            *flags |= f
        }
    };
    set(&mut flags, F_START, !start);
    set(&mut flags, F_MASK, mask != st.mask);
    set(&mut flags, F_LENGTH, !derived);
    set(&mut flags, F_ACCEL, p.accel != st.accel);
    set(&mut flags, F_JERK, p.jerk != st.jerk);
    set(&mut flags, F_V1, p.v1 != v0);

    let mut ok = out.push(flags).is_ok();
    if flags & F_MASK != 0 {
        ok &= out.push(mask).is_ok();
    }
    let unsigned = |v: f64, q: f64| whole(v, q).filter(|n| *n >= 0).map(|n| n as u64);
    if flags & F_START != 0 {
        ok &= put_f64(out, seg.t0) && put_u64(out, unsigned(v0, sq).ok_or(bad)?);
    }
    // The length in quanta (0 for a dwell), sent or derived alike.
    let length = if dwell {
        0
    } else {
        unsigned(p.length, q).filter(|n| *n > 0).ok_or(bad)?
    };
    if flags & F_LENGTH != 0 {
        ok &= put_u64(out, length);
        if dwell {
            ok &= put_f64(out, p.dwell);
        }
    }
    if flags & F_ACCEL != 0 {
        ok &= put_u64(out, unsigned(p.accel, aq).ok_or(bad)?);
    }
    if flags & F_JERK != 0 {
        ok &= put_u64(out, unsigned(p.jerk, aq).ok_or(bad)?);
    }
    if flags & F_V1 != 0 {
        ok &= put_u64(out, unsigned(p.v1, sq).ok_or(bad)?);
    }
    if vc_mode == VC_EXPLICIT {
        ok &= put_u64(out, unsigned(p.vc, sq).ok_or(bad)?);
    }
    let mut history = st.history();
    for i in cfg.axis_order(mask) {
        // A riding axis is read once the path axes give the length.
        let rider = cfg.path_mask & (1 << i) == 0;
        let known = (rider || flags & F_LENGTH != 0).then_some(length as i64);
        let miss = deltas[i] - history.axis(i).predict(known);
        ok &= put_i64(out, miss);
        history.record(i, deltas[i], known, length as i64);
    }
    if !ok {
        return Err(StreamError::TooLarge);
    }
    Ok((mask, history))
}
