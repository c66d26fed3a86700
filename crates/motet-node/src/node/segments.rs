//! The segment queue: segments taken in one by one or in batches, checked
//! against what the channels can follow, and retired once run.

use super::{Node, MAX_STEP_RATE};
use motet_trajectory::{JointPath, Profile, Segment, MAX_AXES};
use motet_wire::stream::{BatchReader, StreamState};
use motet_wire::{Refusal, SegmentBatch, SegmentMsg};

impl<const Q: usize, const T: usize> Node<Q, T> {
    pub(super) fn push_segment(&mut self, m: &SegmentMsg) -> Result<(), Refusal> {
        if m.seq != self.next_seq {
            return Err(Refusal::OutOfOrder {
                expected: self.next_seq,
                got: m.seq,
            });
        }
        if self.stopped {
            return Err(Refusal::Stopped);
        }
        if self.segments.is_full() {
            return Err(Refusal::QueueFull);
        }
        let mut start = self.queue_end;
        let mut end = self.queue_end;
        for span in &m.axes {
            let i = span.axis as usize;
            if i >= MAX_AXES || !span.from.is_finite() || !span.to.is_finite() {
                return Err(Refusal::Malformed);
            }
            start[i] = span.from;
            end[i] = span.to;
        }
        let p = &m.profile;
        if ![p.length, p.v0, p.vc, p.v1, p.accel, p.jerk, p.dwell, m.t0]
            .iter()
            .all(|x| x.is_finite())
        {
            return Err(Refusal::Malformed);
        }
        let seg = Segment {
            t0: m.t0,
            start,
            end,
            profile: Profile::from_params(p),
        };
        self.check_segment(&seg)?;
        // Checked above: the queue has room.
        let _ = self.segments.push_back(seg);
        self.queue_end = end;
        self.next_seq = self.next_seq.wrapping_add(1);
        if self.windowed {
            // Runs only once sealed.
            self.pending += 1;
            return Ok(());
        }
        self.starved = false;
        let t0 = m.t0.max(self.now);
        for t in self.tools.iter_mut() {
            t.wake(t0);
        }
        Ok(())
    }

    /// Takes a whole batch or, refused, none of it: a first pass decodes and
    /// checks every segment as [`Node::push_segment`] will, the second pushes.
    pub(super) fn push_batch(&mut self, b: &SegmentBatch) -> Result<(), Refusal> {
        let start = StreamState {
            tail: self.queue_end,
            ..self.stream_state
        };
        let mut reader = BatchReader::new(self.stream, b).map_err(|_| Refusal::Malformed)?;
        if reader.next_seq() != self.next_seq {
            return Err(Refusal::OutOfOrder {
                expected: self.next_seq,
                got: reader.next_seq(),
            });
        }
        let mut state = start;
        let mut n = 0;
        while let Some(item) = reader.next(&mut state) {
            let (m, _) = item.map_err(|_| Refusal::Malformed)?;
            if !segment_is_finite(&m) {
                return Err(Refusal::Malformed);
            }
            // Axes a batch does not carry keep the queue end's values throughout.
            let (mut start, mut end) = (self.queue_end, self.queue_end);
            for span in &m.axes {
                start[span.axis as usize] = span.from;
                end[span.axis as usize] = span.to;
            }
            let seg = Segment {
                t0: m.t0,
                start,
                end,
                profile: Profile::from_params(&m.profile),
            };
            self.check_segment(&seg)?;
            n += 1;
        }
        if n == 0 {
            return Err(Refusal::Malformed);
        }
        if n > Q - self.segments.len() {
            return Err(Refusal::QueueFull);
        }
        let mut reader = BatchReader::new(self.stream, b).map_err(|_| Refusal::Malformed)?;
        let mut state = start;
        while let Some(Ok((m, _))) = reader.next(&mut state) {
            self.push_segment(&m)?;
        }
        self.stream_state = state;
        Ok(())
    }

    /// A segment the node can run: every channel within [`MAX_STEP_RATE`].
    /// (A late one, after an underrun, is taken: its steps catch up, at most
    /// [`MAX_OUTPUTS_PER_POLL`](super::MAX_OUTPUTS_PER_POLL) a poll.)
    fn check_segment(&self, seg: &Segment) -> Result<(), Refusal> {
        if self.steppable(seg) {
            Ok(())
        } else {
            Err(Refusal::Malformed)
        }
    }

    /// Whether every channel can follow `seg` within [`MAX_STEP_RATE`] on
    /// average over the segment. (The peak may be higher for a moment: a
    /// polar angle turns through up to half a turn as a line passes its
    /// centre, a bounded number of steps however fast.)
    fn steppable(&self, seg: &Segment) -> bool {
        let p = &seg.profile;
        let length = p.length();
        if length <= 0.0 {
            return true;
        }
        let seconds = p.duration();
        self.channels.iter().all(|ch| {
            let c = ch.config();
            let mut travel = JointPath::new(&c.map, seg, 0.0).max_rate(0.0, length) * length;
            if c.map.is_angle() {
                // A straight line subtends less than half a turn.
                travel = travel.min(180.0);
            }
            let steps = travel * c.steps_per_unit.abs();
            // NaN is refused too; a segment that moves no joint always passes.
            steps == 0.0 || steps <= MAX_STEP_RATE * seconds
        })
    }

    /// Drops segments that every channel is done with and whose time has passed.
    pub(super) fn retire(&mut self) {
        let done = self
            .channels
            .iter()
            .map(|c| c.segments_done())
            .min()
            .unwrap_or(usize::MAX)
            .min(self.control.segments_done());
        let done = done.min(self.committed_len());
        let mut n = 0;
        let mut exit_speed = 0.0;
        while n < done {
            match self.segments.front() {
                Some(s) if s.t1() <= self.now => {
                    exit_speed = s.profile.v1();
                    self.segments.pop_front();
                    n += 1;
                }
                _ => break,
            }
        }
        for ch in self.channels.iter_mut() {
            ch.drop_segments(n);
        }
        self.control.drop_segments(n);
        if n > 0 && self.segments.is_empty() && exit_speed > 0.0 && !self.starved {
            // Out of trajectory while not at rest: the host fell behind.
            self.underruns += 1;
            self.starved = true;
        }
    }
}

/// The checks [`Node::push_segment`] makes on a message's values.
fn segment_is_finite(m: &SegmentMsg) -> bool {
    let p = &m.profile;
    m.axes
        .iter()
        .all(|s| (s.axis as usize) < MAX_AXES && s.from.is_finite() && s.to.is_finite())
        && [p.length, p.v0, p.vc, p.v1, p.accel, p.jerk, p.dwell, m.t0]
            .iter()
            .all(|x| x.is_finite())
}
