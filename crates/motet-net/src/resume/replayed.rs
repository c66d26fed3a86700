//! The job planned again from the journal's header and checked, segment by
//! segment and seal by seal, against what the journal recorded.

use super::{Evidence, ResumeError};
use crate::journal::{Journal, JournalSegment};
use crate::plan_feed::replan;
use motet_host::Machine;
use motet_trajectory::{Point, Segment, MAX_AXES};

/// Segments before a window's end searched for its tail: more than a node's
/// queue holds, so the same boundary is found as the run found.
const TAIL_SPAN: usize = 128;

/// How far a node's clock may lead the host's when it reports a segment
/// finished, µs: far more than clock sync leaves.
const DONE_SLACK_US: f64 = 10_000.0;

/// The job planned again, checked segment by segment against the journal.
pub(super) struct Replayed<'a> {
    /// The plan's segments, each with the job command it came from: every
    /// journaled one and the one after.
    pub(super) plan: Vec<(usize, Segment)>,
    /// Where the run started (the rest point before segment 0).
    start: Point,
    /// The run's journal the plan was checked against.
    pub(super) journal: &'a Journal,
    /// The journal's path, for errors.
    journal_path: &'a str,
}

impl<'a> Replayed<'a> {
    /// The plan, again, against the journal. One segment more than
    /// recorded: a window that ended at rest continues with the next. A
    /// journal with no header is of a run that stopped before its
    /// trajectory started.
    pub(super) fn new(ev: &'a Evidence, run: u32) -> Result<Replayed<'a>, ResumeError> {
        let (m, r, j) = (ev.machine, ev.record, ev.journal);
        let start = r.start(m.start);
        let jp = || ev.journal_path.to_string();
        let plan = match &j.header {
            None => Vec::new(),
            Some(h) => {
                for (what, got, want) in [
                    ("run", format!("{:08x}", h.run), format!("{run:08x}")),
                    (
                        "machine file",
                        h.machine.to_string(),
                        r.machine_sha256.to_string(),
                    ),
                    ("job", h.job.to_string(), r.job_sha256.to_string()),
                    ("start", format!("{:?}", h.start), format!("{start:?}")),
                ] {
                    if got != want {
                        return Err(ResumeError::OtherRun {
                            journal: jp(),
                            what,
                            got,
                            want,
                        });
                    }
                }
                let extras = (&j.paces[..], &j.holds[..]);
                replan(m, r.run_commands(ev.job), h, extras, j.segments.len() + 1)
                    .map_err(|(loc, error)| ResumeError::Replan { loc, error })?
            }
        };
        if plan.len() < j.segments.len() {
            return Err(ResumeError::TooMany {
                journal: jp(),
                recorded: j.segments.len(),
                planned: plan.len(),
            });
        }
        for (i, s) in j.segments.iter().enumerate() {
            if let Some(what) = difference(m, s, &plan[i]) {
                return Err(ResumeError::Differs {
                    journal: jp(),
                    line: j.segment_line(i as u32).unwrap_or(0),
                    index: i as u32,
                    what,
                });
            }
        }
        Ok(Replayed {
            plan,
            start,
            journal: j,
            journal_path: ev.journal_path,
        })
    }

    /// Where the machine rests when the committed window ends at `end`.
    pub(super) fn rest_of(&self, end: u32) -> Point {
        match end.checked_sub(1) {
            None => self.start,
            Some(i) => self.plan[i as usize].1.end,
        }
    }

    /// The tail start of the window ending at `end`, checked against the
    /// plan when the journal has its seal.
    pub(super) fn tail_of(&self, end: u32) -> Result<u32, ResumeError> {
        let Some(seal) = self.journal.seal_ending(end) else {
            return Ok(end);
        };
        let lo = (end as usize).saturating_sub(TAIL_SPAN);
        let segs: Vec<&Segment> = self.plan[lo..end as usize].iter().map(|p| &p.1).collect();
        let (deadline, pos) = crate::tail::deadline(segs);
        let want = (lo + pos) as u32;
        if deadline.is_finite() && seal.tail != want {
            return Err(ResumeError::Tail {
                journal: self.journal_path.to_string(),
                end,
                got: seal.tail,
                want,
            });
        }
        Ok(seal.tail)
    }

    /// Every window's tail is where the plan puts it, and no window claims
    /// segments finished before they could have ended.
    pub(super) fn check_seals(&self) -> Result<(), ResumeError> {
        let j = self.journal;
        for seal in j.seals.iter().chain(j.stop.as_ref().map(|s| &s.seal)) {
            self.tail_of(seal.end)?;
            if let Some(last) = seal.done.checked_sub(1) {
                let ended = self.plan[last as usize].1.t1();
                if ended > seal.time as f64 + DONE_SLACK_US {
                    return Err(ResumeError::Done {
                        journal: self.journal_path.to_string(),
                        done: seal.done,
                        time: seal.time,
                        ended,
                    });
                }
            }
        }
        Ok(())
    }
}

/// How a journaled segment differs from the planned one, if it does.
fn difference(m: &Machine, s: &JournalSegment, planned: &(usize, Segment)) -> Option<String> {
    let (command, p) = planned;
    if s.command != *command {
        return Some(format!(
            "it came from command {}, the plan's from command {command}",
            s.command
        ));
    }
    if s.t0 != p.t0 || s.t1 != p.t1() {
        return Some(format!(
            "it runs {:?}..{:?} µs, the plan's {:?}..{:?} µs",
            s.t0,
            s.t1,
            p.t0,
            p.t1()
        ));
    }
    for (what, a, b) in [("start", s.start, p.start), ("end", s.end, p.end)] {
        if let Some(i) = (0..MAX_AXES).find(|&i| a[i].to_bits() != b[i].to_bits()) {
            let axis = m
                .axes
                .get(i)
                .map_or_else(|| format!("axis {i}"), |a| a.name.clone());
            return Some(format!(
                "its {what} has {axis}={:?}, the plan's {axis}={:?}",
                a[i], b[i]
            ));
        }
    }
    None
}
