//! Frame equivalence: polling every 40 µs frame and jumping from deadline to
//! deadline give bit-identical outputs, whatever the queue capacity.

use crate::common;

use common::*;
use motet_node::Node;
use motet_planner::Command;
use motet_trajectory::ProfileKind;
use motet_wire::HostMessage;

/// Jobs that stay at least 30 mm from the polar centre.
fn jobs() -> Vec<(&'static str, Vec<Command>)> {
    let mut out = Vec::new();

    // Pen down, one and a half turns with the radius and z changing, pen up.
    let mut ring = vec![Command::Tool {
        tool: 0,
        value: 1.0,
    }];
    let turns: Vec<(f64, f64, f64)> = (0..27)
        .map(|i| {
            (
                20.0,
                60.0 + 30.0 * ((i as f64) * 0.7).sin(),
                1.0 + 0.1 * (i % 5) as f64,
            )
        })
        .collect();
    ring.extend(ring_moves(START, &turns, 120.0));
    ring.push(Command::Tool {
        tool: 0,
        value: 0.0,
    });
    ring.push(rapid(60.0, 0.0, 1.0));
    out.push(("ring", ring));

    // A star: sharp corners, the laser switched on the fly, a dwell, reversals.
    let mut star = Vec::new();
    let points: Vec<(f64, f64, f64)> = (0..16)
        .map(|i| {
            (
                if i % 2 == 0 { 55.0 } else { -35.0 },
                if i % 2 == 0 { 95.0 } else { 45.0 },
                1.0,
            )
        })
        .collect();
    let moves = ring_moves(START, &points, 100.0);
    for (i, m) in moves.into_iter().enumerate() {
        if i % 3 == 0 {
            star.push(Command::Tool {
                tool: 1,
                value: (i % 2) as f32 * 0.5 + 0.25,
            });
        }
        if i == 7 {
            star.push(Command::Dwell { seconds: 0.013 });
        }
        star.push(m);
    }
    star.push(Command::Tool {
        tool: 2,
        value: 1.0,
    });
    star.push(Command::Tool {
        tool: 1,
        value: 0.0,
    });
    out.push(("star", star));

    // Many short chords winding backwards twice round the centre (angle wraps).
    let spiral: Vec<(f64, f64, f64)> = (0..80)
        .map(|i| (-9.5, 40.0 + 0.6 * i as f64, 1.0))
        .collect();
    out.push(("spiral", ring_moves(START, &spiral, 90.0)));
    out
}

fn run_both<const Q: usize>(msgs: &[HostMessage]) -> (Run, Run) {
    let mut a = Node::<Q>::new();
    let framed = run(&mut a, msgs, Drive::Frames(40.0));
    let mut b = Node::<Q>::new();
    let jumped = run(&mut b, msgs, Drive::Jump);
    (framed, jumped)
}

#[test]
fn frames_and_jumps_give_identical_outputs() {
    let mut cases = 0;
    for profile in [ProfileKind::Trapezoid, ProfileKind::SCurve] {
        for (job, cmds) in jobs() {
            let planned = plan(limits(profile), START, &cmds);
            for machine in [cartesian(), corexy(), polar()] {
                let msgs = machine.stream(&planned);
                let runs = [
                    run_both::<2>(&msgs),
                    run_both::<8>(&msgs),
                    run_both::<64>(&msgs),
                ];
                let reference = runs[2].0.keys();
                let steps = runs[2].0.steps().len();
                assert!(
                    steps > 1000,
                    "{job} on {}: only {steps} steps",
                    machine.name
                );
                for (q, (framed, jumped)) in [2, 8, 64].iter().zip(&runs) {
                    let what = format!("{job} on {} ({profile:?}), Node<{q}>", machine.name);
                    assert_eq!(
                        framed.keys(),
                        reference,
                        "{what}: frames differ from Node<64> frames"
                    );
                    assert_eq!(jumped.keys(), reference, "{what}: jumps differ from frames");
                    assert_eq!(framed.positions, jumped.positions, "{what}");
                    assert_eq!(framed.status.underruns, 0, "{what}: frames underran");
                    assert_eq!(jumped.status.underruns, 0, "{what}: jumps underran");
                    assert!(
                        jumped.polls < framed.polls,
                        "{what}: jumping polled more than framing"
                    );
                }
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 18);
}

/// Odd frame lengths (not dividing any segment time) give the same outputs too.
#[test]
fn frame_length_does_not_matter() {
    let (_, cmds) = jobs().remove(1);
    let planned = plan(limits(ProfileKind::SCurve), START, &cmds);
    let msgs = polar().stream(&planned);
    let reference = run(&mut Node::<8>::new(), &msgs, Drive::Jump).keys();
    for frame in [1.0, 7.3, 40.0, 333.333, 1000.0, 25_000.0] {
        let r = run(&mut Node::<8>::new(), &msgs, Drive::Frames(frame));
        assert_eq!(r.keys(), reference, "frame {frame} µs");
    }
}
