//! The event queue and the tool outputs it drives: each event sets the tools
//! on its track at its time, to a fixed value or to one that follows the
//! path speed (then refreshed as the speed changes).

use super::Node;
use crate::board::Board;
use motet_wire::Refusal;

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Event {
    track: u8,
    time: f64,
    value: f32,
    /// Path speed at which the output reaches `value`; 0 for a fixed output.
    feed: f32,
}

impl<const Q: usize, const T: usize> Node<Q, T> {
    pub(super) fn push_event(
        &mut self,
        track: u8,
        time: f64,
        value: f32,
        feed: f32,
    ) -> Result<(), Refusal> {
        // A NaN time would never come due and block the event queue for good.
        if !(time.is_finite() && value.is_finite()) {
            return Err(Refusal::Malformed);
        }
        if self.stopped {
            return Err(Refusal::Stopped);
        }
        self.events
            .push_back(Event {
                track,
                time,
                value,
                feed,
            })
            .map_err(|_| Refusal::QueueFull)?;
        if self.windowed {
            self.pending_events += 1;
        }
        Ok(())
    }

    /// An event whose value is reached at path speed `feed`, which must be a
    /// speed (the value follows speed / `feed`).
    pub(super) fn push_event_per_speed(
        &mut self,
        track: u8,
        time: f64,
        value: f32,
        feed: f32,
    ) -> Result<(), Refusal> {
        if !(feed.is_finite() && feed > 0.0) {
            return Err(Refusal::Malformed);
        }
        self.push_event(track, time, value, feed)
    }

    /// Whether a committed event is queued.
    pub(super) fn event_due(&self) -> Option<f64> {
        if self.events.len() > self.pending_events {
            self.events.front().map(|e| e.time)
        } else {
            None
        }
    }

    /// The committed event due before `until`, the earliest tool refresh
    /// due before it (the first tool on a tie), and the earlier of their
    /// times (infinite: neither).
    pub(super) fn others_due(&self, until: f64) -> (Option<f64>, Option<(usize, f64)>, f64) {
        let event_time = self.event_due().filter(|&t| t < until);
        let refresh = self
            .tools
            .iter()
            .enumerate()
            .filter_map(|(i, t)| t.next_update().map(|u| (i, u)))
            .filter(|&(_, u)| u < until)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let first = event_time
            .unwrap_or(f64::INFINITY)
            .min(refresh.map_or(f64::INFINITY, |r| r.1));
        (event_time, refresh, first)
    }

    pub(super) fn fire_event<B: Board>(&mut self, board: &mut B) {
        if let Some(e) = self.events.pop_front() {
            let speed = if e.feed > 0.0 {
                self.speed_at(e.time)
            } else {
                None
            };
            self.control.set_target(e.track, e.value);
            for t in self.tools.iter_mut().filter(|t| t.config.track == e.track) {
                let v = t.set(e.value, e.feed, e.time, speed);
                board.set_tool(t.output(), v, e.time);
            }
        }
    }

    /// Refreshes tool `i`'s output, which follows the path speed, at `u`.
    pub(super) fn refresh_tool<B: Board>(&mut self, i: usize, u: f64, board: &mut B) {
        let speed = self.speed_at(u);
        let still = self.still_until(u);
        let tool = &mut self.tools[i];
        if let Some(v) = tool.refresh(u, speed) {
            board.set_tool(tool.output(), v, u);
        }
        // Standing still (a dwell, a wait for the next segment),
        // the speed stays 0 and so does the output: no refresh
        // until motion resumes, however long the dwell.
        if let Some(t) = still {
            tool.defer(t);
        }
    }

    /// Path speed at host time `t`, from the queued segments; `None` when nothing
    /// is queued at or after `t`.
    fn speed_at(&self, t: f64) -> Option<f64> {
        let n = self.committed_len();
        let last = self.segments.get(n.checked_sub(1)?)?;
        if t >= last.t1() {
            return None;
        }
        for s in self.segments.iter().take(n) {
            if t < s.t0 {
                return Some(0.0);
            }
            if t < s.t1() {
                return Some(s.profile.state((t - s.t0) * 1e-6).1);
            }
        }
        None
    }

    /// When motion resumes if the machine stands still at host time `t`
    /// (inside a dwell, or before the next committed segment starts).
    fn still_until(&self, t: f64) -> Option<f64> {
        for s in self.segments.iter().take(self.committed_len()) {
            if t < s.t0 {
                return Some(s.t0);
            }
            if t < s.t1() {
                return (s.profile.length() <= 0.0).then(|| s.t1());
            }
        }
        None
    }
}
