//! Node side: a batch back into segments.

use super::varint::Reader;
use super::{
    index, SegmentBatch, StreamConfig, StreamState, F_ACCEL, F_JERK, F_LENGTH, F_MASK, F_START,
    F_V1, VC_EXPLICIT, VC_PREVIOUS, VC_SHIFT, VC_V0, VC_V1,
};
use crate::{AxisSpan, SegmentMsg, WireError};
use heapless::Vec;
use motet_trajectory::{Profile, ProfileParams, Segment, MAX_AXES};

/// Reads the segments of a batch one by one, advancing a stream state.
pub struct BatchReader<'a> {
    cfg: StreamConfig,
    bytes: Reader<'a>,
    next_seq: u32,
}

impl<'a> BatchReader<'a> {
    /// A reader of `batch`; fails on a batch without a sequence number.
    pub fn new(cfg: StreamConfig, batch: &'a SegmentBatch) -> Result<BatchReader<'a>, WireError> {
        let mut bytes = Reader::new(&batch.bytes);
        let seq = bytes.u64().filter(|s| *s <= u32::MAX as u64);
        let next_seq = seq.ok_or(WireError::Malformed)? as u32;
        Ok(BatchReader {
            cfg,
            bytes,
            next_seq,
        })
    }

    /// Sequence number of the next segment.
    pub fn next_seq(&self) -> u32 {
        self.next_seq
    }

    /// The next segment as a [`SegmentMsg`] (spans for the axes that move)
    /// and as the [`Segment`] it makes after `state`, which advances; `None`
    /// after the last. Values are not checked for being finite: that is the
    /// receiver's business, as for a plain segment message.
    #[allow(clippy::type_complexity)]
    pub fn next(
        &mut self,
        state: &mut StreamState,
    ) -> Option<Result<(SegmentMsg, Segment), WireError>> {
        if self.bytes.at_end() {
            return None;
        }
        Some(self.read(state).ok_or(WireError::Malformed))
    }

    fn read(&mut self, st: &mut StreamState) -> Option<(SegmentMsg, Segment)> {
        let c = self.cfg;
        let r = &mut self.bytes;
        let flags = r.u8()?;
        let mask = if flags & F_MASK != 0 {
            r.u8()?
        } else {
            st.mask
        };
        if mask >> MAX_AXES != 0 {
            return None;
        }
        let speed = |r: &mut Reader, q: f64| r.u64().map(|n| n as f64 * q);
        let (t0, v0) = if flags & F_START != 0 {
            (r.f64()?, speed(r, c.speed_quantum)?)
        } else if st.valid {
            (st.t1, st.v1)
        } else {
            return None;
        };
        // The length in quanta, when sent.
        let (mut sent, mut dwell) = (None, 0.0);
        if flags & F_LENGTH != 0 {
            let n = i64::try_from(r.u64()?).ok()?;
            if n == 0 {
                dwell = r.f64()?;
            }
            sent = Some(n);
        }
        let accel = if flags & F_ACCEL != 0 {
            speed(r, c.accel_quantum)?
        } else {
            st.accel
        };
        let jerk = if flags & F_JERK != 0 {
            speed(r, c.accel_quantum)?
        } else {
            st.jerk
        };
        let v1 = if flags & F_V1 != 0 {
            speed(r, c.speed_quantum)?
        } else {
            v0
        };
        let vc = match flags >> VC_SHIFT {
            VC_EXPLICIT => speed(r, c.speed_quantum)?,
            VC_V0 => v0,
            VC_V1 => v1,
            VC_PREVIOUS if st.valid => st.vc,
            _ => return None,
        };
        let mut end = st.tail;
        let mut history = st.history();
        // The path axes, then (knowing the length) the riding ones.
        let mut length = sent;
        for i in c.axis_order(mask) {
            let rider = c.path_mask & (1 << i) == 0;
            if rider && length.is_none() {
                length = Some(c.derived_quanta(&st.tail, &end)?);
            }
            let known = if rider || sent.is_some() {
                length
            } else {
                None
            };
            let delta = history.axis(i).predict(known).checked_add(r.i64()?)?;
            let k = index(st.tail[i], c.quantum)?.checked_add(delta)?;
            end[i] = k as f64 * c.quantum;
            // The length is not final before every path axis is read.
            history.record(i, delta, known, 0);
        }
        let length = match length {
            Some(l) => l,
            None => c.derived_quanta(&st.tail, &end)?,
        };
        let mut axes = Vec::new();
        for i in (0..MAX_AXES).filter(|i| mask & (1 << i) != 0) {
            history.set_length(i, length);
            // At most MAX_AXES spans: cannot overflow.
            let _ = axes.push(AxisSpan {
                axis: i as u8,
                from: st.tail[i],
                to: end[i],
            });
        }
        let length = length as f64 * c.quantum;
        let profile = ProfileParams {
            length,
            v0,
            vc,
            v1,
            accel,
            jerk,
            dwell,
        };
        let seg = Segment {
            t0,
            start: st.tail,
            end,
            profile: Profile::from_params(&profile),
        };
        let msg = SegmentMsg {
            seq: self.next_seq,
            t0,
            profile,
            axes,
        };
        self.next_seq = self.next_seq.wrapping_add(1);
        st.advance(&seg, mask, history);
        Some((msg, seg))
    }
}
