//! Windowed mode: segments and events held pending until a seal commits
//! them, and the committed window's contingency tail, on which the node
//! stops by itself when no seal follows.

use super::Node;
use crate::board::Board;
use motet_trajectory::Contingency;
use motet_wire::Refusal;

impl<const Q: usize, const T: usize> Node<Q, T> {
    /// Windowed mode for the run `run`, from rest: what is sent from now on
    /// waits for a seal.
    pub(super) fn open_window(&mut self, run: u32) -> Result<(), Refusal> {
        if self.segments.is_empty() {
            self.windowed = true;
            self.closed = false;
            self.last_window = (0, 0);
            self.run = run;
            Ok(())
        } else {
            Err(Refusal::NotAtRest)
        }
    }

    /// Segments that run: all but the pending ones.
    pub(super) fn committed_len(&self) -> usize {
        self.segments.len() - self.pending
    }

    /// Whether a seal can be taken at all: windowed, not stopped, not
    /// closed.
    pub(super) fn takes_seals(&self) -> Result<(), Refusal> {
        if !self.windowed {
            return Err(Refusal::BadConfig);
        }
        if self.stopped {
            return Err(Refusal::TailStarted);
        }
        if self.closed {
            return Err(Refusal::Closed);
        }
        Ok(())
    }

    /// Commits the pending segments and events, if the window they close can
    /// still stop on its tail.
    pub(super) fn seal(&mut self, next_seq: u32) -> Result<(), Refusal> {
        self.takes_seals()?;
        if next_seq != self.next_seq {
            return Err(Refusal::OutOfOrder {
                expected: self.next_seq,
                got: next_seq,
            });
        }
        if self.pending > 0 {
            // The queue may have retired the window's head; the tail is found
            // from the end, so a tail still ahead of `now` is found the same.
            let c = Contingency::of(self.segments.iter()).map_err(|_| Refusal::TailStarted)?;
            if c.start_time < self.now {
                return Err(Refusal::TailStarted);
            }
            let first = self.segments.get(self.committed_len()).map(|s| s.t0);
            self.last_window = (self.pending, self.pending_events);
            self.tail_start = Some(c.start_time);
            self.pending = 0;
            self.starved = false;
            if let Some(t0) = first {
                for t in self.tools.iter_mut() {
                    t.wake(t0.max(self.now));
                }
            }
        } else if self.pending_events > 0 {
            self.last_window = (0, self.pending_events);
        }
        self.pending_events = 0;
        Ok(())
    }

    /// The run stops for every node at the committed end `keep` (a group
    /// stop), or where it is (`None`: a member of the group fell silent).
    /// What is pending is dropped and no more seals are taken. A node whose
    /// last window ends beyond `keep` takes that window back when the
    /// window before it ends at `keep` and that one's tail has not started:
    /// nothing of the window taken back has run, and every node then brakes
    /// on the same tail. Returns the committed end the node stops at.
    pub fn close(&mut self, keep: Option<u32>) -> u32 {
        self.drop_pending();
        self.closed = true;
        let committed = self.next_seq;
        let (segs, events) = self.last_window;
        let Some(keep) = keep.filter(|&k| k != committed) else {
            return committed;
        };
        let back = committed.wrapping_sub(keep) as usize;
        if self.stopped || segs == 0 || back != segs || segs > self.segments.len() {
            return committed;
        }
        let kept = self.segments.len() - segs;
        let Ok(c) = Contingency::of(self.segments.iter().take(kept)) else {
            return committed;
        };
        if c.start_time < self.now {
            return committed;
        }
        // The window taken back starts where the kept ones end.
        if let Some(s) = self.segments.get(kept) {
            self.queue_end = s.start;
        }
        for _ in 0..segs {
            self.segments.pop_back();
        }
        for _ in 0..events.min(self.events.len()) {
            self.events.pop_back();
        }
        self.next_seq = keep;
        self.tail_start = Some(c.start_time);
        self.last_window = (0, 0);
        keep
    }

    /// Drops the segments and events not sealed.
    fn drop_pending(&mut self) {
        // The first pending segment starts where the committed ones end.
        if let Some(s) = self.segments.get(self.committed_len()) {
            self.queue_end = s.start;
        }
        for _ in 0..self.pending {
            self.segments.pop_back();
        }
        self.next_seq = self.next_seq.wrapping_sub(self.pending as u32);
        self.pending = 0;
        for _ in 0..self.pending_events.min(self.events.len()) {
            self.events.pop_back();
        }
        self.pending_events = 0;
    }

    /// The committed window's tail takes over at `at`: the tail's profiles
    /// replace the planned ones, anything not yet committed or due later is
    /// dropped, every tool goes to 0, and the node stops taking segments.
    pub(super) fn stop_on_tail<B: Board>(&mut self, at: f64, board: &mut B) {
        for _ in 0..self.pending {
            self.segments.pop_back();
        }
        self.next_seq = self.next_seq.wrapping_sub(self.pending as u32);
        self.pending = 0;
        self.pending_events = 0;
        self.events.clear();
        self.last_window = (0, 0);
        if let Ok(c) = Contingency::of(self.segments.iter()) {
            let mut walk = c.walk();
            for j in c.start..c.len {
                if let Some(s) = self.segments.get_mut(j) {
                    *s = walk.next(s);
                }
            }
            for ch in self.channels.iter_mut() {
                ch.retime(&self.segments, c.start);
            }
            self.queue_end = c.stop;
        }
        for t in self.tools.iter_mut() {
            t.set(0.0, 0.0, at, None);
            board.set_tool(t.output(), 0.0, at);
        }
        self.control.heaters_off(at, board);
        self.tail_start = None;
        self.stopped = true;
    }
}
