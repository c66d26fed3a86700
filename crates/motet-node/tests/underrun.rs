//! Underruns: running out of segments while moving is counted once; running out
//! at rest is not an underrun.

use crate::common;

use common::*;
use motet_node::Node;
use motet_planner::{Command, Planned};
use motet_trajectory::ProfileKind;
use motet_wire::HostMessage;

/// Straight runs (junctions taken at speed) separated by a pen change (a stop).
fn job() -> Vec<Command> {
    vec![
        feed(70.0, 0.0, 1.0, 100.0),
        feed(80.0, 0.0, 1.0, 100.0),
        feed(90.0, 0.0, 1.0, 100.0),
        feed(100.0, 0.0, 1.0, 100.0),
        Command::Tool {
            tool: 0,
            value: 1.0,
        },
        feed(100.0, 10.0, 1.0, 100.0),
        feed(100.0, 20.0, 1.0, 100.0),
        feed(100.0, 30.0, 1.0, 100.0),
    ]
}

/// Index just past the `n`th segment message of the stream.
fn after_segment(msgs: &[HostMessage], n: usize) -> usize {
    msgs.iter()
        .enumerate()
        .filter(|(_, m)| matches!(m, HostMessage::Segment(_)))
        .nth(n)
        .unwrap()
        .0
        + 1
}

fn check<const Q: usize>(machine: &Machine, profile: ProfileKind) {
    let planned = plan(limits(profile), START, &job());
    let segs: Vec<_> = planned
        .iter()
        .filter_map(|p| {
            if let Planned::Segment(s) = p {
                Some(*s)
            } else {
                None
            }
        })
        .collect();
    let msgs = machine.stream(&planned);
    let what = format!("{} {profile:?} Node<{Q}>", machine.name);
    let whole = run(&mut Node::<Q>::new(), &msgs, Drive::Jump);
    assert_eq!(
        whole.status.underruns, 0,
        "{what}: a complete trajectory ends at rest"
    );

    for drive in [Drive::Jump, Drive::Frames(40.0)] {
        for (n, seg) in segs.iter().enumerate() {
            // Send segments 0..=n only, run dry, then send the rest.
            let cut = after_segment(&msgs, n);
            let mut node = Node::<Q>::new();
            let first = run(&mut node, &msgs[..cut], drive);
            assert!(first.now >= seg.t1(), "{what}: polled past the end");
            let moving = seg.profile.v1() > 0.0;
            let expected = moving as u32;
            assert_eq!(
                first.status.underruns,
                expected,
                "{what} {drive:?}: ran dry after segment {n} (exit {})",
                seg.profile.v1()
            );
            // More polling does not count the same underrun again.
            node.poll(first.now + 1e6, &mut Recorder::default());
            assert_eq!(node.status().underruns, expected, "{what}");
            // The rest is accepted; it ends at rest, so no further underrun.
            let rest = run(&mut node, &msgs[cut..], Drive::Jump);
            assert_eq!(rest.status.underruns, expected, "{what}");
            assert_eq!(rest.positions, whole.positions, "{what}: final position");
            if !moving {
                // Stopping at rest loses nothing: the same outputs as a whole run.
                let mut keys = first.keys();
                keys.extend(rest.keys());
                assert_eq!(
                    keys,
                    whole.keys(),
                    "{what}: split at rest after segment {n}"
                );
            }
        }
    }
}

#[test]
fn running_dry_while_moving_is_an_underrun() {
    let planned = plan(limits(ProfileKind::Trapezoid), START, &job());
    let exits: Vec<f64> = planned
        .iter()
        .filter_map(|p| {
            if let Planned::Segment(s) = p {
                Some(s.profile.v1())
            } else {
                None
            }
        })
        .collect();
    assert!(
        exits.iter().filter(|&&v| v > 0.0).count() >= 4,
        "job has junctions at speed: {exits:?}"
    );
    assert!(
        exits.iter().filter(|&&v| v == 0.0).count() >= 2,
        "job has stops: {exits:?}"
    );
    for profile in [ProfileKind::Trapezoid, ProfileKind::SCurve] {
        for machine in [cartesian(), corexy(), polar()] {
            check::<2>(&machine, profile);
            check::<8>(&machine, profile);
            check::<64>(&machine, profile);
        }
    }
}

/// Polling up to a time before the end of the last queued segment is no underrun.
#[test]
fn no_underrun_before_the_end() {
    let planned = plan(limits(ProfileKind::Trapezoid), START, &job());
    let msgs = cartesian().stream(&planned);
    let cut = after_segment(&msgs, 1);
    let mut node = Node::<8>::new();
    for m in &msgs[..cut] {
        assert_eq!(send(&mut node, m), None);
    }
    let end = node.front_end().unwrap();
    let mut rec = Recorder::default();
    node.poll(end, &mut rec);
    assert_eq!(node.queued(), 1, "the first segment retires at its end");
    let end2 = match &msgs[cut - 1] {
        HostMessage::Segment(s) => {
            s.t0 + motet_trajectory::Profile::from_params(&s.profile).duration() * 1e6
        }
        _ => unreachable!(),
    };
    node.poll(end2 - 1.0, &mut rec);
    assert_eq!(node.status().underruns, 0, "not yet at the end");
    assert_eq!(node.queued(), 1);
    node.poll(end2 + 40.0, &mut rec);
    assert_eq!(node.status().underruns, 1);
    assert_eq!(node.queued(), 0);
}
