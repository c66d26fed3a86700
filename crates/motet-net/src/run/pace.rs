//! The host's own pace: how late it runs, and the lead that covers it.
//!
//! A host on a busy computer is not always scheduled when it should be.
//! While it is not, nothing is sealed, and a node whose next seal has not
//! come when its contingency tail starts brakes and takes no more segments:
//! the run stops. So the run measures its own lateness: how long it went
//! between two turns (polls), and how long after a seal fell due it went out
//! (late turns, or the seal before still unacknowledged). It lengthens its
//! lead to twice the worst lateness seen on top of the least lead, at most
//! [`super::NetConfig::lead_max_us`], and reports each raise. The lead only
//! changes when windows are sealed, never what is sealed. When the nodes'
//! queues are full and still reach less than the lead (tiny moves), the
//! moves not yet planned are planned longer; that is journaled (a `pace`
//! record) so that `motet resume` plans them the same. If the host still
//! falls behind the committed window's tail start, the nodes are braking:
//! the run stops at once, saying how late the host was and what lead it had.

use super::{NetError, NetRun};
use crate::journal::JournalPace;

/// The feed is slowed again only for moves this much longer than before.
const SLOW_STEP: f64 = 1.05;

/// How much lead the worst lateness asks for: as much again in hand when a
/// stall as long as the worst one starts just as a seal falls due.
const LATENESS_FACTOR: u64 = 2;

/// Lateness within this fraction of the least lead is noise (a timer's
/// slack, a short preemption), not worth a longer lead.
const NOISE_FRACTION: u64 = 4;

/// A raise is reported once the lead is this many times the one last
/// reported (or the least lead), so a growing lateness does not flood.
const REPORT_STEP: f64 = 1.25;

/// What the run measured of its own pace.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PaceFigures {
    /// Longest time between two turns of the host, µs of host time.
    pub worst_gap_us: u64,
    /// Longest a due seal waited before it went out, µs.
    pub worst_seal_late_us: u64,
    /// Least time left before a tail would start when a seal went out, µs
    /// (infinite before the second seal).
    pub least_margin_us: f64,
    /// The lead the run ended with, µs.
    pub lead_us: u64,
}

/// The host's lateness, as measured while the run goes.
#[derive(Debug)]
pub(super) struct Pace {
    last_poll: Option<u64>,
    /// The gap that ended at the latest turn, µs.
    pub(super) last_gap_us: u64,
    /// When the host came back from its last stall: a node's silence
    /// before it says nothing (the host was not listening).
    pub(super) listening_since: u64,
    figures: PaceFigures,
    /// When the next seal falls due: the committed window's tail start
    /// less the lead, as of the last seal.
    due_at: Option<u64>,
    /// The lead the last window was sealed with, µs.
    sealed_lead: u64,
    /// How long before the tail it replaced the last seal went out, µs.
    last_margin: f64,
    /// Extra lead lateness asks for, µs.
    extra_us: u64,
    /// The most the lead is raised to, µs.
    lead_max_us: u64,
    reported_us: u64,
    notes: Vec<String>,
}

impl Pace {
    pub(super) fn new(lead_max_us: u64) -> Pace {
        Pace {
            last_poll: None,
            last_gap_us: 0,
            listening_since: 0,
            figures: PaceFigures {
                least_margin_us: f64::INFINITY,
                ..PaceFigures::default()
            },
            due_at: None,
            sealed_lead: 0,
            last_margin: f64::INFINITY,
            extra_us: 0,
            lead_max_us,
            reported_us: 0,
            notes: Vec::new(),
        }
    }

    /// The lead to keep, µs, given the least one (configured, or from the
    /// links' round trips): more by what lateness asks for, within the bound.
    pub(super) fn lead(&self, base: u64) -> u64 {
        (base + self.extra_us).min(self.lead_max_us.max(base))
    }

    /// A turn of the host at `now`: the time since the last is lateness.
    /// A gap longer than `deaf_us` was long enough to hide a node's
    /// answers: silence before it is not counted.
    pub(super) fn turn(&mut self, now: u64, base: u64, deaf_us: u64) {
        let gap = self.last_poll.map_or(0, |t| now.saturating_sub(t));
        self.last_poll = Some(now);
        self.last_gap_us = gap;
        if gap > deaf_us {
            self.listening_since = now;
        }
        self.figures.worst_gap_us = self.figures.worst_gap_us.max(gap);
        self.late(gap, base, "had no turn for");
    }

    /// A seal goes out at `now`, `margin` µs before the committed tail would
    /// start.
    pub(super) fn sealing(&mut self, now: u64, margin: f64, base: u64) {
        self.last_margin = margin;
        if margin.is_finite() {
            self.figures.least_margin_us = self.figures.least_margin_us.min(margin);
        }
        let late = self.due_at.map_or(0, |d| now.saturating_sub(d));
        self.figures.worst_seal_late_us = self.figures.worst_seal_late_us.max(late);
        self.late(late, base, "sealed a window late by");
    }

    /// The window just sealed has its tail start at `deadline`; the next
    /// seal falls due a lead before it (never before `now`: windows sealed
    /// one after another in one turn are not late).
    pub(super) fn sealed(&mut self, now: u64, deadline: f64, lead: u64) {
        self.sealed_lead = lead;
        self.due_at = deadline
            .is_finite()
            .then(|| (deadline - lead as f64).max(now as f64) as u64);
    }

    /// The host was `late` µs behind: the lead grows to cover twice that.
    fn late(&mut self, late: u64, base: u64, what: &str) {
        if late <= base / NOISE_FRACTION || LATENESS_FACTOR * late <= self.extra_us {
            return;
        }
        self.extra_us = LATENESS_FACTOR * late;
        let lead = self.lead(base);
        if lead as f64 >= REPORT_STEP * self.reported_us.max(base) as f64 {
            self.reported_us = lead;
            let most = if lead >= self.lead_max_us {
                " (its most)"
            } else {
                ""
            };
            self.notes.push(format!(
                "the host fell behind: it {what} {}; lead raised to {}{most}",
                ms(late),
                ms(lead)
            ));
        }
    }

    /// Something to say about the run's pace.
    pub(super) fn note(&mut self, note: String) {
        self.notes.push(note);
    }

    /// What was measured, with the lead now kept.
    pub(super) fn figures(&self, base: u64) -> PaceFigures {
        PaceFigures {
            lead_us: self.lead(base),
            ..self.figures
        }
    }
}

/// µs as milliseconds, for the person.
pub(super) fn ms(us: u64) -> String {
    format!("{:.0} ms", us as f64 / 1000.0)
}

impl NetRun {
    /// What the run has to say about its pace since last asked (a lead
    /// raised because the host fell behind), one line each, for a warning.
    pub fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.pace.notes)
    }

    /// What the run measured of its own pace.
    pub fn pace(&self) -> PaceFigures {
        self.pace.figures(self.base_lead_us())
    }

    /// The nodes' queues are full and still reach less than `lead` ahead:
    /// the moves not yet planned are planned longer (at least the lead over
    /// the queue's usable length), journaled so that a resume plans them
    /// the same. What is planned stays as planned.
    pub(super) fn slow_feed(&mut self, lead: u64) -> Result<(), NetError> {
        let horizon = self.machine.limits().stop_horizon;
        let usable = self.capacity().saturating_sub(horizon).max(1);
        let want = lead as f64 * 1e-6 / usable as f64;
        let line = self.pending_commands_mut().1.first().map(|c| c.loc.line);
        let Some(feed) = self.feed.as_mut() else {
            return Ok(());
        };
        let had = feed.min_move_s();
        if want <= had * SLOW_STEP || feed.exhausted() {
            return Ok(());
        }
        let command = feed.slow(want);
        if let Some(j) = self.journal.as_mut() {
            j.pace(&JournalPace {
                command,
                min_move_s: want,
            })?;
        }
        let from = line.map_or_else(String::new, |l| format!(" from job line {l} on"));
        self.pace.note(format!(
            "the nodes' queues hold less than the lead of {}: short moves{from} are slowed to take at least {:.1} ms (were {:.1} ms)",
            ms(lead),
            want * 1e3,
            had * 1e3
        ));
        Ok(())
    }

    /// The host is past the committed window's tail start with more to
    /// seal: every node is braking on its tail. Stops the run, saying why.
    pub(super) fn check_behind(&mut self, now: u64) {
        let t = now as f64;
        let braking = self.deadline.is_finite() && self.deadline <= t;
        if !matches!(self.phase, super::Phase::Streaming) || !braking {
            return;
        }
        let lead = ms(self.pace.sealed_lead);
        let gap = self.pace.last_gap_us;
        let why = if gap as f64 > t - self.deadline {
            let reach = ms((self.deadline - (t - gap as f64)).max(0.0) as u64);
            format!("the host had no turn for {}, and the committed window reached only {reach} beyond its last turn (lead {lead})", ms(gap))
        } else if self.peers.iter().any(|p| p.seal_in_flight()) || self.group_busy() {
            format!("the last seal was not acknowledged within the lead of {lead} (a node or its link is slow)")
        } else if self.queued_on_nodes(now) >= self.capacity() {
            format!(
                "the nodes' queues were full with less than the lead of {lead} of motion in them"
            )
        } else {
            format!("the host could not seal the next window within the lead of {lead}")
        };
        let reason = format!(
            "{why}: every node braked on its tail from segment {}, {} before the host's turn",
            self.tail_start,
            ms((t - self.deadline) as u64),
        );
        self.stop(&reason, now);
    }

    /// Why a node's refusal to take more segments stopped it, with the
    /// host's pace: a node refuses once it braked on its tail.
    pub(super) fn pace_context(&self) -> String {
        let p = &self.pace;
        let gap = if p.last_gap_us > self.base_lead_us() / NOISE_FRACTION {
            format!("the host had just had no turn for {}; ", ms(p.last_gap_us))
        } else {
            String::new()
        };
        let margin = if p.last_margin.is_finite() {
            format!(
                "the last window went out {} before the tail it replaced would start, ",
                ms(p.last_margin.max(0.0) as u64)
            )
        } else {
            String::new()
        };
        format!(
            "{gap}{margin}with a lead of {}; the host's longest time without a turn was {}",
            ms(p.sealed_lead),
            ms(p.figures.worst_gap_us),
        )
    }
}
