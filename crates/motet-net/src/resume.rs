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

use crate::digest::Digest;
use crate::journal::{Journal, JournalSegment};
use crate::plan_feed::replan;
use crate::run_record::{Continuation, RunRecord};
use motet_host::{check_move, Distributor, Machine, Subscription};
use motet_planner::{Command, Located, Move, MoveKind, PlanError, SourceLoc};
use motet_trajectory::{Point, Segment, MAX_AXES};
use motet_wire::service::Version;
use motet_wire::NodeMessage;

/// Segments before a window's end searched for its tail: more than a node's
/// queue holds, so the same boundary is found as the run found.
const TAIL_SPAN: usize = 128;

/// How far a node's clock may lead the host's when it reports a segment
/// finished, µs: far more than clock sync leaves.
const DONE_SLACK_US: f64 = 10_000.0;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ResumeError {
    #[error("the {what} {path} changed since the run (SHA-256 {now}; the run had {recorded}): resume needs the files the job ran with")]
    Changed {
        what: &'static str,
        path: String,
        recorded: Digest,
        now: Digest,
    },
    #[error(
        "{journal}: the journal is not this run's: its {what} is {got}, resume.toml has {want}"
    )]
    OtherRun {
        journal: String,
        what: &'static str,
        got: String,
        want: String,
    },
    #[error("{0}")]
    Record(String),
    #[error("the job does not plan as it did: {loc}: {error}")]
    Replan { loc: SourceLoc, error: PlanError },
    #[error("{journal}:{line}: segment {index} is not the one the job plans: {what}; the journal, the job or the machine file changed since the run")]
    Differs {
        journal: String,
        line: usize,
        index: u32,
        what: String,
    },
    #[error("{journal}: {recorded} segments recorded, but the job plans only {planned}; the journal, the job or the machine file changed since the run")]
    TooMany {
        journal: String,
        recorded: usize,
        planned: usize,
    },
    #[error("{journal}: the window ending at segment {end} has its tail from segment {got}, but the plan's tail starts at {want}")]
    Tail {
        journal: String,
        end: u32,
        got: u32,
        want: u32,
    },
    #[error("{journal}: a window says {done} segments were finished at {time} µs, but segment {} ends at {ended} µs", done - 1)]
    Done {
        journal: String,
        done: u32,
        time: u64,
        ended: f64,
    },
    #[error("node {node} does not answer on {link}: where it is cannot be known; bring it back (power, cable, `motet node`) and resume again")]
    Silent { node: String, link: String },
    #[error("node {node} on {link} is uid {uid}, but the run used uid {recorded}: is it the same board?")]
    OtherDevice {
        node: String,
        link: String,
        uid: String,
        recorded: String,
    },
    #[error("node {node} is still moving ({queued} segments queued); wait for it to stop")]
    Moving { node: String, queued: u16 },
    #[error("node {node} has committed {committed} segments, but the journal records {journal}: the journal is not the run's latest")]
    NodeAhead {
        node: String,
        committed: u32,
        journal: u32,
    },
    #[error(
        "node {node} rests at {at}, but {place} is at {want}: the node and the journal disagree"
    )]
    Elsewhere {
        node: String,
        place: String,
        at: String,
        want: String,
    },
    #[error("nodes {a} and {b} both drive {axis} and rest at different places ({va} and {vb}): the machine may be racked; put it right by hand and give --assume-position")]
    Disagree {
        a: String,
        b: String,
        axis: String,
        va: f64,
        vb: f64,
    },
    #[error("{nodes}: where {axes} {is} cannot be known. Home the machine or measure where it is, then tell motet with --assume-position {example}")]
    Unknown {
        nodes: String,
        axes: String,
        is: &'static str,
        example: String,
    },
    #[error(
        "--assume-position is not needed: every node kept its position (the machine rests at {at})"
    )]
    AssumeNotNeeded { at: String },
    #[error("--assume-position {axis}={given}, but node {node} knows that {axis} is at {known}")]
    AssumeConflict {
        axis: String,
        given: f64,
        node: String,
        known: f64,
    },
    #[error("--assume-position names no axis {0:?} of this machine")]
    AssumeAxis(String),
    #[error("resume would {what}: {source}")]
    Beyond {
        what: String,
        source: motet_host::MoveError,
    },
}

/// What a node answered when asked where it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodePosition {
    pub run: u32,
    pub committed: u32,
    pub stopped: bool,
    pub queued: u16,
    pub at: Point,
}

impl NodePosition {
    /// From a node's answer to `Where`.
    pub fn from_message(m: &NodeMessage) -> Option<NodePosition> {
        match *m {
            NodeMessage::Position {
                run,
                committed,
                stopped,
                queued,
                at,
            } => Some(NodePosition {
                run,
                committed,
                stopped,
                queued,
                at,
            }),
            _ => None,
        }
    }
}

/// What the probe found at one machine node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeSeen {
    /// No answer.
    Silent,
    /// It answered: the device it is, and where it is (`None`: it did not
    /// say).
    Answered {
        uid: u64,
        firmware: Version,
        position: Option<NodePosition>,
    },
}

/// Everything a resume is decided on.
pub struct Evidence<'a> {
    pub machine: &'a Machine,
    /// SHA-256 of the machine file and of the job file as they are now.
    pub machine_sha256: Digest,
    pub job: &'a [Located<Command>],
    pub job_sha256: Digest,
    pub record: &'a RunRecord,
    pub journal: &'a Journal,
    /// The journal's path, for errors.
    pub journal_path: &'a str,
    /// One per machine node, in the machine's order.
    pub nodes: &'a [NodeSeen],
}

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

/// The job planned again, checked segment by segment against the journal.
struct Replayed<'a> {
    plan: Vec<(usize, Segment)>,
    start: Point,
    journal: &'a Journal,
    journal_path: &'a str,
}

impl<'a> Replayed<'a> {
    /// The plan, again, against the journal. One segment more than
    /// recorded: a window that ended at rest continues with the next. A
    /// journal with no header is of a run that stopped before its
    /// trajectory started.
    fn new(ev: &'a Evidence, run: u32) -> Result<Replayed<'a>, ResumeError> {
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
                replan(m, r.run_commands(ev.job), h, j.segments.len() + 1)
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
    fn rest_of(&self, end: u32) -> Point {
        match end.checked_sub(1) {
            None => self.start,
            Some(i) => self.plan[i as usize].1.end,
        }
    }

    /// The tail start of the window ending at `end`, checked against the
    /// plan when the journal has its seal.
    fn tail_of(&self, end: u32) -> Result<u32, ResumeError> {
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
    fn check_seals(&self) -> Result<(), ResumeError> {
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

/// What a node's answer says about where it is.
enum Seen {
    /// At rest at the end of its committed window (this many segments).
    Kept(u32),
    /// It no longer holds the run: where it is, the person must say.
    Lost(String),
    /// Tools only: nothing that holds a position.
    NoPosition,
}

/// Node `k`'s answer, checked: the device paired, at rest, on this run (or
/// lost with the reason), and where the journal says its window ended.
fn check_node(
    ev: &Evidence,
    run: u32,
    plan: &Replayed,
    axes: u8,
    k: usize,
) -> Result<Seen, ResumeError> {
    let (m, r, j) = (ev.machine, ev.record, ev.journal);
    let spec = &m.nodes[k];
    let rn = r.nodes.get(k);
    let link = rn.map_or_else(String::new, |n| n.link.clone());
    let silent = || ResumeError::Silent {
        node: spec.name.clone(),
        link: link.clone(),
    };
    let (uid, firmware, pos) = match ev.nodes.get(k) {
        Some(NodeSeen::Answered {
            uid,
            firmware,
            position,
        }) => (*uid, *firmware, position.ok_or_else(silent)?),
        _ => return Err(silent()),
    };
    let uid_text = crate::pairing_file::format_uid(uid);
    if let Some(n) = rn.filter(|n| n.uid != uid_text) {
        return Err(ResumeError::OtherDevice {
            node: spec.name.clone(),
            link,
            uid: uid_text,
            recorded: n.uid.clone(),
        });
    }
    if pos.queued > 0 {
        return Err(ResumeError::Moving {
            node: spec.name.clone(),
            queued: pos.queued,
        });
    }
    if spec.actuators.is_empty() {
        return Ok(Seen::NoPosition);
    }
    // A resumed run that stopped before it reconfigured this node: the
    // node still holds the run before, at rest where this one started.
    let before = r.continues.as_ref().is_some_and(|c| {
        format!("{:08x}", pos.run) == c.after_run && pos.committed == c.after_window
    });
    let committed = if before { 0 } else { pos.committed };
    if pos.run != run && !before {
        let why = if pos.run == 0 {
            let was = rn.map_or(String::new(), |n| n.firmware.clone());
            if was != firmware.to_string() && !was.is_empty() {
                format!(
                    "node {} restarted with firmware {firmware} (the run had {was})",
                    spec.name
                )
            } else {
                format!("node {} restarted and holds no run", spec.name)
            }
        } else {
            format!(
                "node {} ran another job since (run {:08x})",
                spec.name, pos.run
            )
        };
        return Ok(Seen::Lost(why));
    }
    if committed > j.committed() {
        return Err(ResumeError::NodeAhead {
            node: spec.name.clone(),
            committed,
            journal: j.committed(),
        });
    }
    let want = plan.rest_of(committed);
    if (0..m.axes.len()).any(|i| axes & (1 << i) != 0 && want[i] != pos.at[i]) {
        return Err(ResumeError::Elsewhere {
            node: spec.name.clone(),
            place: match committed {
                0 => "where the run started".to_string(),
                c => format!("the end of segment {}", c - 1),
            },
            at: show(m, &pos.at, axes),
            want: show(m, &want, axes),
        });
    }
    Ok(Seen::Kept(committed))
}

/// Each axis's value and the node that reported it.
type Known = [Option<(usize, f64)>; MAX_AXES];

/// Where the machine is, axis by axis, from the nodes kept (which must
/// agree on the axes they share).
fn machine_position(
    m: &Machine,
    subs: &[Subscription],
    kept: &[(usize, u32)],
    plan: &Replayed,
    window_end: u32,
) -> Result<(Point, Known), ResumeError> {
    let mut from = plan.rest_of(window_end);
    let mut known: Known = [None; MAX_AXES];
    for &(k, end) in kept {
        let p = plan.rest_of(end);
        for (i, slot) in known.iter_mut().enumerate().take(m.axes.len()) {
            if subs[k].axes & (1 << i) == 0 {
                continue;
            }
            match *slot {
                Some((other, v)) if v != p[i] => {
                    return Err(ResumeError::Disagree {
                        a: m.nodes[other].name.clone(),
                        b: m.nodes[k].name.clone(),
                        axis: m.axes[i].name.clone(),
                        va: v,
                        vb: p[i],
                    })
                }
                _ => *slot = Some((k, p[i])),
            }
            from[i] = p[i];
        }
    }
    Ok((from, known))
}

/// The axes of lost nodes (`needed`) from what the person says; returns the
/// lost nodes' names. Refuses a position not needed, an axis missing, or
/// one that contradicts a node that knows.
fn apply_assumed(
    m: &Machine,
    assumed: Option<&[(usize, f64)]>,
    lost: &[(usize, String)],
    needed: u8,
    known: &Known,
    from: &mut Point,
) -> Result<Vec<String>, ResumeError> {
    let lost_why = || {
        lost.iter()
            .map(|l| l.1.clone())
            .collect::<Vec<_>>()
            .join("; ")
    };
    let given = match assumed {
        None if needed != 0 => {
            let axes: Vec<&str> = (0..m.axes.len())
                .filter(|i| needed & (1 << i) != 0)
                .map(|i| m.axes[i].name.as_str())
                .collect();
            return Err(ResumeError::Unknown {
                nodes: lost_why(),
                is: if axes.len() == 1 { "is" } else { "are" },
                example: axes
                    .iter()
                    .map(|a| format!("{a}=…"))
                    .collect::<Vec<_>>()
                    .join(","),
                axes: axes.join(", "),
            });
        }
        None => return Ok(Vec::new()),
        Some(_) if needed == 0 => {
            return Err(ResumeError::AssumeNotNeeded {
                at: show(m, from, u8::MAX),
            })
        }
        Some(given) => given,
    };
    for i in (0..m.axes.len()).filter(|i| needed & (1 << i) != 0) {
        let v = given
            .iter()
            .rev()
            .find(|g| g.0 == i)
            .map(|g| g.1)
            .ok_or_else(|| ResumeError::Unknown {
                nodes: lost_why(),
                is: "is",
                axes: m.axes[i].name.clone(),
                example: format!("{}=…", m.axes[i].name),
            })?;
        from[i] = v;
    }
    for &(i, v) in given {
        if i >= m.axes.len() {
            return Err(ResumeError::AssumeAxis(i.to_string()));
        }
        if needed & (1 << i) != 0 {
            continue;
        }
        if let Some((k, known)) = known[i] {
            if (v - known).abs() > 1e-6 * (1.0 + known.abs()) {
                return Err(ResumeError::AssumeConflict {
                    axis: m.axes[i].name.clone(),
                    given: v,
                    node: m.nodes[k].name.clone(),
                    known,
                });
            }
        }
    }
    Ok(lost.iter().map(|&(k, _)| m.nodes[k].name.clone()).collect())
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

/// `x=1.5, y=2` for the axes in `mask`.
fn show(m: &Machine, p: &Point, mask: u8) -> String {
    m.axes
        .iter()
        .enumerate()
        .filter(|(i, _)| mask & (1 << i) != 0)
        .map(|(i, a)| format!("{}={}", a.name, p[i]))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The commands that finish `commands` from command `command`, with the
/// machine at rest at `from` and the job continuing at `to`.
pub fn resume_at(
    commands: &[Located<Command>],
    from: Point,
    to: Point,
    command: usize,
) -> ResumeAt {
    let command = command.min(commands.len());
    let here = commands
        .get(command)
        .map(|c| c.loc)
        .or_else(|| commands.last().map(|c| c.loc))
        .unwrap_or(SourceLoc { line: 0, column: 0 });
    let mut out = Vec::new();
    if to != from {
        out.push(Located {
            loc: here,
            item: Command::Move(Move {
                target: to,
                feed: f64::INFINITY,
                kind: MoveKind::Rapid,
            }),
        });
    }
    // The tools as the job left them before `command`.
    let mut tools: Vec<Option<Located<Command>>> = Vec::new();
    for c in &commands[..command] {
        let t = match c.item {
            Command::Tool { tool, .. } | Command::ToolPerSpeed { tool, .. } => tool as usize,
            _ => continue,
        };
        if tools.len() <= t {
            tools.resize(t + 1, None);
        }
        tools[t] = Some(c.clone());
    }
    out.extend(tools.into_iter().flatten());
    out.extend_from_slice(&commands[command..]);
    ResumeAt {
        from,
        to,
        command,
        commands: out,
    }
}

/// [`resume_at`]'s result.
#[derive(Clone, Debug, PartialEq)]
pub struct ResumeAt {
    pub from: Point,
    pub to: Point,
    pub command: usize,
    pub commands: Vec<Located<Command>>,
}

/// Parses `--assume-position x=10,y=20.5` against the machine's axes.
pub fn parse_assumed(m: &Machine, text: &str) -> Result<Vec<(usize, f64)>, String> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, value) = part
            .split_once('=')
            .ok_or_else(|| format!("`{part}`: expected AXIS=VALUE, e.g. x=10.5"))?;
        let i = m
            .axes
            .iter()
            .position(|a| a.name == name.trim())
            .ok_or_else(|| {
                format!(
                    "`{part}`: the machine has no axis `{}` (it has: {})",
                    name.trim(),
                    m.axes
                        .iter()
                        .map(|a| a.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("`{part}`: `{}` is not a number", value.trim()))?;
        out.push((i, v));
    }
    if out.is_empty() {
        return Err("give at least one AXIS=VALUE, e.g. x=10.5,y=20".into());
    }
    Ok(out)
}
