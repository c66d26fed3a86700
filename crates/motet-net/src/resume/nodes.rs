//! Each node's answer checked against the run, and the machine's position
//! pieced together from the nodes that kept theirs.

use super::replayed::Replayed;
use super::{show, Evidence, NodeSeen, ResumeError};
use motet_host::{Machine, Subscription};
use motet_trajectory::{Point, MAX_AXES};

/// What a node's answer says about where it is.
pub(super) enum Seen {
    /// At rest at the end of its committed window (this many segments).
    Kept(u32),
    /// It no longer holds the run: where it is, the person must say.
    Lost(String),
    /// Tools only: nothing that holds a position.
    NoPosition,
}

/// Node `k`'s answer, checked: the device paired, at rest, on this run (or
/// lost with the reason), and where the journal says its window ended.
pub(super) fn check_node(
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
pub(super) type Known = [Option<(usize, f64)>; MAX_AXES];

/// Where the machine is, axis by axis, from the nodes kept (which must
/// agree on the axes they share).
pub(super) fn machine_position(
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
