//! The frame poll: every output due before the frame's end (steps of every
//! channel, tool events and refreshes, hosted graph frames), handed to the
//! board in time order, at most [`MAX_OUTPUTS_PER_POLL`] a poll.

use super::{Node, MAX_CHANNELS, MAX_OUTPUTS_PER_POLL};
use crate::board::Board;
use crate::channel::Step;

impl<const Q: usize, const T: usize> Node<Q, T> {
    pub(super) fn poll_outputs<B: Board>(&mut self, until: f64, board: &mut B) {
        let mut budget = MAX_OUTPUTS_PER_POLL;
        if let Some(ts) = self.tail_start.filter(|&t| t < until) {
            if !self.poll_until(ts, board, &mut budget) {
                // Stopped short of the tail: the next poll gets there.
                return;
            }
            self.stop_on_tail(ts, board);
        }
        self.poll_until(until, board, &mut budget);
    }

    /// Runs to `until`; false when the budget ran out first (the node's time
    /// is then that of its last output).
    fn poll_until<B: Board>(&mut self, until: f64, board: &mut B, budget: &mut u32) -> bool {
        while let Some(t) = self.graph_next().filter(|&t| t < until) {
            if !self.poll_trajectory(t, board, budget) || *budget == 0 {
                return false;
            }
            self.graph_frame(t, board);
            *budget -= 1;
        }
        self.poll_trajectory(until, board, budget)
    }

    fn poll_trajectory<B: Board>(&mut self, until: f64, board: &mut B, budget: &mut u32) -> bool {
        let end = self.committed_len();
        // Each channel's next step time (infinite: none). Within this loop
        // only a step changes its channel's next step, and only an event or
        // a refresh changes what is due besides steps, so both are kept and
        // updated where they change instead of asked for on every output.
        let n = self.channels.len();
        let mut next = [f64::INFINITY; MAX_CHANNELS];
        for (t, ch) in next.iter_mut().zip(self.channels.iter_mut()) {
            *t = time_of(ch.next_step_within(&self.segments, end));
        }
        let mut others = self.others_due(until);
        // Time of the last output handed out.
        let mut last = None;
        loop {
            let (bi, bt, second) = earliest(&next[..n], until);
            let (event_time, refresh, other) = others;
            if bi != usize::MAX && bt < other {
                // Only steps are due first: the common case, taken directly.
                let limit = if second < other { second } else { other };
                match self.step_run(bi, bt, limit, end, board, budget, &mut last) {
                    Some(t) => next[bi] = t,
                    None => {
                        if let Some(t) = last {
                            self.pause_at(t);
                            return false;
                        }
                    }
                }
                continue;
            }
            let best = (bi != usize::MAX).then_some((bi, bt));
            // Ties: events, then refreshes, then steps.
            let step_time = best.map(|(_, t)| t);
            let next_out = [step_time, event_time, refresh.map(|r| r.1)]
                .into_iter()
                .flatten()
                .min_by(f64::total_cmp);
            match (next_out, last) {
                (None, _) => break,
                (Some(_), Some(t)) if *budget == 0 => {
                    // Everything before `t` is out; what is due at `t` or
                    // after waits for the next poll.
                    self.pause_at(t);
                    return false;
                }
                _ => {}
            }
            *budget = budget.saturating_sub(1);
            last = next_out;
            if let Some((i, u)) = refresh {
                if event_time.is_none_or(|te| u < te) && step_time.is_none_or(|ts| u <= ts) {
                    self.refresh_tool(i, u, board);
                    others = self.others_due(until);
                    continue;
                }
            }
            match (best, event_time) {
                (None, None) => break,
                (Some((_, ts)), Some(te)) if te <= ts => {
                    self.fire_event(board);
                    others = self.others_due(until);
                }
                (None, Some(_)) => {
                    self.fire_event(board);
                    others = self.others_due(until);
                }
                (Some((i, _)), _) => {
                    let ch = &mut self.channels[i];
                    let id = ch.config().channel;
                    if let Some((t, dir)) = ch.take_step() {
                        board.step(id, dir, t);
                    }
                    next[i] = time_of(ch.next_step_within(&self.segments, end));
                }
            }
        }
        self.now = until;
        self.retire();
        true
    }

    /// Steps channel `i`, whose next step (at `from`) is the earliest output,
    /// while its next step is still strictly before `limit`, the next other
    /// output, without looking at the others again (a tie goes back to the
    /// full rule of [`Node::poll_trajectory`]). Returns the channel's next
    /// step time, or `None` when the budget ran out after an output (`last`
    /// holds its time).
    #[inline]
    // The loop's state as it stands in `poll_trajectory`: this runs for
    // nearly every step, where a recomputed `end` or a bundled state costs.
    #[allow(clippy::too_many_arguments)]
    fn step_run<B: Board>(
        &mut self,
        i: usize,
        from: f64,
        limit: f64,
        end: usize,
        board: &mut B,
        budget: &mut u32,
        last: &mut Option<f64>,
    ) -> Option<f64> {
        let ch = &mut self.channels[i];
        let id = ch.config().channel;
        let mut at = from;
        loop {
            if *budget == 0 && last.is_some() {
                return None;
            }
            *budget = budget.saturating_sub(1);
            *last = Some(at);
            if let Some((t, dir)) = ch.take_step() {
                board.step(id, dir, t);
            }
            let t = time_of(ch.next_step_within(&self.segments, end));
            if t < limit {
                at = t;
            } else {
                return Some(t);
            }
        }
    }

    /// Ends a poll that ran out of budget at its last output's time `t`.
    fn pause_at(&mut self, t: f64) {
        self.now = t;
        self.retire();
    }
}

/// The earliest of the channels' next step times `next` before `until`: its
/// channel (the first on a tie; `usize::MAX` for none), its time (`until`
/// for none), and the time of the next earliest (at most `until`).
#[inline]
fn earliest(next: &[f64], until: f64) -> (usize, f64, f64) {
    let (mut bi, mut bt, mut second) = (usize::MAX, until, until);
    for (i, &t) in next.iter().enumerate() {
        if t < bt {
            second = bt;
            (bi, bt) = (i, t);
        } else if t < second {
            second = t;
        }
    }
    (bi, bt, second)
}

/// A step's time; infinite for none.
#[inline]
fn time_of(step: Option<Step>) -> f64 {
    step.map_or(f64::INFINITY, |s| s.time)
}
