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
        let (mut length, mut dwell) = (None, 0.0);
        if flags & F_LENGTH != 0 {
            let n = r.u64()?;
            if n == 0 {
                length = Some(0.0);
                dwell = r.f64()?;
            } else {
                length = Some(n as f64 * c.quantum);
            }
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
        let mut axes = Vec::new();
        for (i, e) in end.iter_mut().enumerate() {
            if mask & (1 << i) != 0 {
                let k = index(st.tail[i], c.quantum)?.checked_add(r.i64()?)?;
                *e = k as f64 * c.quantum;
                // At most MAX_AXES spans: cannot overflow.
                let _ = axes.push(AxisSpan {
                    axis: i as u8,
                    from: st.tail[i],
                    to: *e,
                });
            }
        }
        let length = match length {
            Some(l) => l,
            None => c.derived_length(&st.tail, &end)?,
        };
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
        st.advance(&seg, mask);
        Some((msg, seg))
    }
}
