//! Continuing a stopped job, and proving first that it is the same job.
//!
//! When sealing stops, the nodes run the committed window to its end but slow
//! down from the tail's first segment on, with every tool output off. The job
//! is therefore complete up to the start of that segment (`R`), and the
//! machine rests at the window's end (`P`). The resumed job travels from `P`
//! back to `R` with tools off, restores every tool to the value the job had
//! given it before that segment's command, and runs the job from that
//! command on.
//!
//! Nothing of that is taken on trust ([`prove`]):
//! - the machine file and the job must be the files the run was made from
//!   (their SHA-256 in `resume.toml` and in the journal's header);
//! - the planner is deterministic, so the run is planned again from its
//!   journal's header and every journaled segment must be exactly the plan's;
//!   the journal's own records are checksummed as well;
//! - every node must answer, be the device the run used, be at rest, and
//!   still hold the run (a node that restarted or ran something else since
//!   does not know where it is); a node that holds it rests where the plan
//!   says the end of its committed window is;
//! - a node that does not know where it is needs the person to say where the
//!   machine is (`assumed`); the job then continues from the last segment
//!   every node had reported finished;
//! - every point the resumed job travels to is checked against travel.

mod assumed;
mod commands;
mod error;
mod evidence;
mod nodes;
mod replayed;

pub use assumed::parse_assumed;
pub use commands::{resume_at, ResumeAt};
pub use error::ResumeError;
pub use evidence::{Evidence, NodePosition, NodeSeen};

use crate::run_record::Continuation;
use assumed::apply_assumed;
use motet_host::{check_move, Distributor, Machine};
use motet_planner::{Command, Located};
use motet_trajectory::Point;
use nodes::{check_node, machine_position, Seen};
use replayed::Replayed;

/// What to run to finish a stopped job.
#[derive(Clone, Debug, PartialEq)]
pub struct Resumption {
    /// Where the machine rests now.
    pub from: Point,
    /// Where the job continues.
    pub to: Point,
    /// The job command the job continues at.
    pub command: usize,
    /// The new run's commands: travel, tools restored, the rest of the job.
    pub commands: Vec<Located<Command>>,
    /// How the new run's commands follow from the job's.
    pub continues: Continuation,
    /// The committed window the nodes stopped on.
    pub window_end: u32,
    /// The segment of the stopped run the job continues at.
    pub segment: u32,
    /// Nodes whose position the person gave.
    pub assumed: Vec<String>,
    /// What the person should know before the machine moves.
    pub notes: Vec<String>,
}

/// Checks `ev` (see the module documentation) and gives what finishes the
/// job; `assumed` is where the person says the machine is, axis by axis.
pub fn prove(ev: &Evidence, assumed: Option<&[(usize, f64)]>) -> Result<Resumption, ResumeError> {
    let (m, r, j) = (ev.machine, ev.record, ev.journal);
    check_files(ev)?;
    let run = r.run_number().map_err(ResumeError::Record)?;
    let plan = Replayed::new(ev, run)?;
    plan.check_seals()?;
    let subs = Distributor::new(m).subscriptions;
    let mut kept: Vec<(usize, u32)> = Vec::new();
    let mut lost: Vec<(usize, String)> = Vec::new();
    for (k, sub) in subs.iter().enumerate().take(m.nodes.len()) {
        match check_node(ev, run, &plan, sub.axes, k)? {
            Seen::Kept(committed) => kept.push((k, committed)),
            Seen::Lost(why) => lost.push((k, why)),
            Seen::NoPosition => {}
        }
    }
    let window_end = kept.iter().map(|k| k.1).max().unwrap_or(j.committed());
    let (mut from, known) = machine_position(m, &subs, &kept, &plan, window_end)?;
    let needed: u8 = lost.iter().fold(0, |a, &(k, _)| a | subs[k].axes);
    let assumed_names = apply_assumed(m, assumed, &lost, needed, &known, &mut from)?;
    let (segment, mut notes) = continue_at(&plan, &kept, !lost.is_empty(), window_end)?;
    let (to, run_command) = match plan.plan.get(segment as usize) {
        Some((c, s)) => (s.start, *c),
        // Every segment ran: what is left are commands that do not move.
        None => (
            plan.rest_of(segment),
            plan.plan.last().map_or(0, |p| p.0 + 1),
        ),
    };
    let (command, prelude_to) = r.job_command(run_command);
    let to = prelude_to.unwrap_or(to);
    if j.committed() == 0 {
        notes.push(
            "nothing of the job was committed before the stop: it runs from its start".into(),
        );
    }
    let res = resume_at(ev.job, from, to, command);
    check_move(m, &from, &from).map_err(|source| ResumeError::Beyond {
        what: format!("start from {}", show(m, &from, u8::MAX)),
        source,
    })?;
    check_move(m, &from, &to).map_err(|source| ResumeError::Beyond {
        what: format!("travel to {}", show(m, &to, u8::MAX)),
        source,
    })?;
    let prelude = res.commands.len() - (ev.job.len() - res.command);
    Ok(Resumption {
        from,
        to,
        command: res.command,
        continues: Continuation {
            command: res.command,
            prelude,
            from: from.to_vec(),
            to: to.to_vec(),
            after_run: r.run.clone(),
            after_window: window_end,
        },
        commands: res.commands,
        window_end,
        segment,
        assumed: assumed_names,
        notes,
    })
}

/// The machine file and the job are the ones the run was made from.
fn check_files(ev: &Evidence) -> Result<(), ResumeError> {
    let r = ev.record;
    for (what, path, recorded, now) in [
        (
            "machine file",
            &r.machine,
            r.machine_sha256,
            ev.machine_sha256,
        ),
        ("job", &r.job, r.job_sha256, ev.job_sha256),
    ] {
        if recorded != now {
            return Err(ResumeError::Changed {
                what,
                path: path.display().to_string(),
                recorded,
                now,
            });
        }
    }
    Ok(())
}

/// Where the job continues: the first segment a tail slowed down, or,
/// with a node lost, the first one not every node had finished (with a
/// note of what may run twice).
fn continue_at(
    plan: &Replayed,
    kept: &[(usize, u32)],
    any_lost: bool,
    window_end: u32,
) -> Result<(u32, Vec<String>), ResumeError> {
    let mut segment = window_end;
    for &(_, end) in kept {
        segment = segment.min(plan.tail_of(end)?);
    }
    if kept.is_empty() {
        segment = segment.min(plan.tail_of(window_end)?);
    }
    let mut notes = Vec::new();
    if any_lost {
        let done = plan.journal.done().min(window_end);
        if done < segment {
            let again = segment - done;
            notes.push(format!(
                "the job continues from segment {done}, the last that every node had reported finished: up to {again} segment{} may run twice",
                if again == 1 { "" } else { "s" }
            ));
            segment = done;
        }
    }
    Ok((segment, notes))
}

/// `x=1.5, y=2` for the axes in `mask`.
pub(super) fn show(m: &Machine, p: &Point, mask: u8) -> String {
    m.axes
        .iter()
        .enumerate()
        .filter(|(i, _)| mask & (1 << i) != 0)
        .map(|(i, a)| format!("{}={}", a.name, p[i]))
        .collect::<Vec<_>>()
        .join(", ")
}
