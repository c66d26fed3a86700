//! The frame poll: every output due before the frame's end (steps of every
//! channel, tool events and refreshes, hosted graph frames), handed to the
//! board in time order, at most [`MAX_OUTPUTS_PER_POLL`] a poll.

use super::{Node, MAX_CHANNELS, MAX_OUTPUTS_PER_POLL};
use crate::board::Board;

impl<const Q: usize, const T: usize> Node<Q, T> {
    pub(super) fn poll_outputs<B: Board>(&mut self, until: f64, board: &mut B) {
        let mut budget = MAX_OUTPUTS_PER_POLL;
        // Heaters a reset forgot go off before anything else.
        let at = if self.now.is_finite() {
            self.now
        } else {
            until
        };
        self.control.forgotten_off(at, board);
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
        loop {
            // Graph frames and control ticks, in time order (a frame first
            // on a tie), each after every output before it.
            let frame = self.graph_next().unwrap_or(f64::INFINITY);
            let tick = self.control.next_tick(self.now);
            let t = frame.min(tick);
            if t >= until {
                break;
            }
            if !self.poll_trajectory(t, board, budget) || *budget == 0 {
                return false;
            }
            if frame <= tick {
                self.graph_frame(t, board);
            } else {
                self.control_tick(t, board);
            }
            *budget -= 1;
        }
        self.poll_trajectory(until, board, budget)
    }

    /// Every loop's tick due at `t`. A fault on a windowed node closes its
    /// run: no more seals, and it brakes on its committed tail, as every
    /// node does once the host stops the run.
    fn control_tick<B: Board>(&mut self, t: f64, board: &mut B) {
        let end = self.committed_len();
        let now = self.now;
        if self.control.tick(t, now, &self.segments, end, board) && self.windowed {
            self.close(None);
        }
    }

    fn poll_trajectory<B: Board>(&mut self, until: f64, board: &mut B, budget: &mut u32) -> bool {
        let end = self.committed_len();
        // Each channel's next step time (infinite: none). Within this loop
        // only a step changes its channel's next step, and only an event or
        // a refresh changes what is due besides steps, so both are kept and
        // updated where they change instead of asked for on every output.
        let mut next = [f64::INFINITY; MAX_CHANNELS];
        for (t, ch) in next.iter_mut().zip(self.channels.iter_mut()) {
            *t = ch.next_time_within(&self.segments, end);
        }
        // Time of the last output handed out.
        let mut last = None;
        loop {
            let (event_time, refresh, other) = self.others_due(until);
            // Every step before the next other output (or the frame's end):
            // the common case, in a loop of its own.
            let stop = if other < until { other } else { until };
            if !self.steps_before(stop, &mut next, end, board, budget, &mut last) {
                if let Some(t) = last {
                    self.pause_at(t);
                    return false;
                }
            }
            if other >= until {
                break;
            }
            // An event or a refresh is due at `other`, no later than any
            // step left. Ties: events, then refreshes, then steps.
            if let Some(t) = last.filter(|_| *budget == 0) {
                // Everything before `t` is out; what is due at `t` or
                // after waits for the next poll.
                self.pause_at(t);
                return false;
            }
            *budget = budget.saturating_sub(1);
            last = Some(other);
            match refresh {
                Some((i, u)) if event_time.is_none_or(|te| u < te) => {
                    self.refresh_tool(i, u, board)
                }
                _ => self.fire_event(board),
            }
        }
        self.now = until;
        self.retire();
        true
    }

    /// Hands out every step strictly before `stop`, earliest first (the
    /// lower channel on a tie), keeping each channel's next step time in
    /// `next`. False when the budget ran out first (`last` holds the time
    /// of the last output).
    #[inline]
    fn steps_before<B: Board>(
        &mut self,
        stop: f64,
        next: &mut [f64; MAX_CHANNELS],
        end: usize,
        board: &mut B,
        budget: &mut u32,
        last: &mut Option<f64>,
    ) -> bool {
        // Only the channels with a step to come take part (a channel with
        // none gets none within the poll: the committed segments do not
        // change), in channel order, their count a constant so that the
        // search for the earliest is unrolled: a few comparisons a step.
        let mut act = [0u8; MAX_CHANNELS];
        let mut m = 0;
        for (i, t) in next.iter().enumerate().take(self.channels.len()) {
            if *t < stop {
                act[m] = i as u8;
                m += 1;
            }
        }
        match m {
            0 => true,
            1 => self.merge::<1, B>(&act, stop, next, end, board, budget, last),
            2 => self.merge::<2, B>(&act, stop, next, end, board, budget, last),
            3 => self.merge::<3, B>(&act, stop, next, end, board, budget, last),
            4 => self.merge::<4, B>(&act, stop, next, end, board, budget, last),
            5 => self.merge::<5, B>(&act, stop, next, end, board, budget, last),
            6 => self.merge::<6, B>(&act, stop, next, end, board, budget, last),
            7 => self.merge::<7, B>(&act, stop, next, end, board, budget, last),
            _ => self.merge::<MAX_CHANNELS, B>(&act, stop, next, end, board, budget, last),
        }
    }

    /// [`Node::steps_before`] over the `N` channels `act`.
    #[inline(always)]
    // The loop's state as it stands in `poll_trajectory`: this runs for
    // every step, where a bundled state costs.
    #[allow(clippy::too_many_arguments)]
    fn merge<const N: usize, B: Board>(
        &mut self,
        act: &[u8; MAX_CHANNELS],
        stop: f64,
        next: &mut [f64; MAX_CHANNELS],
        end: usize,
        board: &mut B,
        budget: &mut u32,
        last: &mut Option<f64>,
    ) -> bool {
        use crate::time::{key, of_key};
        // Keys, not times: integers on a core without an FPU.
        let mut times = [key(0.0); N];
        for (t, &i) in times.iter_mut().zip(act.iter()) {
            *t = key(next[i as usize]);
        }
        let stop_key = key(stop);
        let mut left = *budget;
        // One output at least per poll, so that every poll gets on.
        let mut free = last.is_none();
        let mut at = None;
        loop {
            // Selects rather than branches: which channel is earliest
            // changes from step to step.
            let (mut bk, mut bt) = (0, times[0]);
            for (k, &t) in times.iter().enumerate().skip(1) {
                let earlier = t < bt;
                bk = if earlier { k } else { bk };
                bt = if earlier { t } else { bt };
            }
            // (Keys are never NaN.)
            if bt >= stop_key {
                break;
            }
            let bt = of_key(bt);
            if left == 0 {
                if !free {
                    break;
                }
            } else {
                left -= 1;
            }
            free = false;
            at = Some(bt);
            let ch = &mut self.channels[act[bk] as usize];
            board.step(ch.config().channel, ch.next_forward(), bt);
            times[bk] = key(ch.advance(&self.segments, end));
        }
        for (t, &i) in times.iter().zip(act.iter()) {
            next[i as usize] = of_key(*t);
        }
        *budget = left;
        if at.is_some() {
            *last = at;
        }
        // Out of budget with steps still due before `stop`.
        !(left == 0 && times.iter().any(|&t| t < stop_key) && last.is_some())
    }

    /// Ends a poll that ran out of budget at its last output's time `t`.
    fn pause_at(&mut self, t: f64) {
        self.now = t;
        self.retire();
    }
}
