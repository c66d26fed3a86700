//! Every example machine's limits, as they are and with jerk-limited ramps
//! (each axis's jerk 20 times its acceleration where the file sets none):
//! random jobs, planned whole or move by move, under any lookahead, give
//! segments whose two ramps fit within the segment's length. The planner
//! lowers speeds instead of producing a ramp longer than its move.

use motet_host::Machine;
use motet_planner::{Command, Limits, Move, MoveKind, Planned, Planner};
use motet_trajectory::{ProfileKind, MAX_AXES};
use proptest::prelude::*;
use std::path::PathBuf;

const EXAMPLES: [&str; 5] = [
    "clay-printer.toml",
    "gestalt-3axis.toml",
    "laser.toml",
    "plotter.toml",
    "printer.toml",
];

/// Each example's limits, and the same with S-curves.
fn all_limits() -> Vec<(String, Machine, Limits)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut out = Vec::new();
    for f in EXAMPLES {
        let m = Machine::load(&dir.join(f)).unwrap();
        let l = m.limits();
        let mut s = l.clone();
        s.profile = ProfileKind::SCurve;
        for a in &mut s.axes {
            a.max_jerk = a.max_jerk.or(Some(20.0 * a.max_acceleration));
        }
        out.push((f.to_string(), m.clone(), l));
        out.push((format!("{f} with S-curves"), m, s));
    }
    out
}

/// Moves from the machine's start, each axis within its travel (or ±50 where
/// travel is unbounded), long and tiny mixed, rapid or fed.
fn job(m: &Machine, steps: &[([f64; MAX_AXES], f64, bool)]) -> Vec<Command> {
    let mut pos = m.start;
    steps
        .iter()
        .map(|(d, feed, tiny)| {
            for (i, a) in m.axes.iter().enumerate() {
                let [lo, hi] = a.travel;
                let (lo, hi) = if lo.is_finite() && hi.is_finite() {
                    (lo, hi)
                } else {
                    (pos[i] - 50.0, pos[i] + 50.0)
                };
                let k = if *tiny { 0.001 } else { 0.3 };
                pos[i] = (pos[i] + d[i] * k * (hi - lo)).clamp(lo, hi);
            }
            Command::Move(Move {
                target: pos,
                feed: *feed,
                kind: if feed.is_finite() {
                    MoveKind::Feed
                } else {
                    MoveKind::Rapid
                },
            })
        })
        .collect()
}

fn check(name: &str, l: &Limits, m: &Machine, cmds: &[Command], one_by_one: bool) {
    let mut p = Planner::new(l.clone(), m.start, 0.0);
    let mut segs = Vec::new();
    let mut take = |p: &mut Planner| {
        while let Some(x) = p.pop() {
            if let Planned::Segment(s) = x {
                segs.push(s);
            }
        }
    };
    for c in cmds {
        p.push(c).unwrap();
        if one_by_one {
            take(&mut p);
        }
    }
    p.finish();
    take(&mut p);
    for (i, s) in segs.iter().enumerate() {
        let pr = &s.profile;
        assert!(
            pr.ramps_length() <= pr.length() * (1.0 + 1e-9) + 1e-12,
            "{name}: segment {i}: ramps need {} of {} ({:?})",
            pr.ramps_length(),
            pr.length(),
            pr.params()
        );
    }
}

fn arb_steps() -> impl Strategy<Value = Vec<([f64; MAX_AXES], f64, bool)>> {
    prop::collection::vec(
        (
            prop::array::uniform6(-1.0..1.0f64),
            prop_oneof![Just(f64::INFINITY), 0.5..300.0f64],
            prop::bool::weighted(0.3),
        ),
        1..50,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    #[test]
    fn ramps_fit_on_every_example_machine(steps in arb_steps(), lookahead in 2usize..40, one_by_one in any::<bool>()) {
        for (name, m, l) in all_limits() {
            let mut l = l;
            l.lookahead = lookahead;
            check(&name, &l, &m, &job(&m, &steps), one_by_one);
        }
    }
}
