//! Extreme values: the planner refuses commands whose values are out of their
//! range, or that would make the plan last longer than `ranges::JOB_S`, and
//! a refused command leaves the plan exactly as it was.

use motet_planner::*;

fn limits() -> Limits {
    let axis = AxisLimits {
        max_velocity: 100.0,
        max_acceleration: 1000.0,
        max_jerk: None,
        path: true,
    };
    Limits {
        axes: vec![axis, axis],
        joints: vec![],
        junction_deviation: 0.05,
        profile: motet_trajectory::ProfileKind::Trapezoid,
        tools: vec![ToolTiming {
            stop: true,
            settle: ranges::SETTLE_S.max,
        }],
        lookahead: 64,
        stop_horizon: 0,
        min_move_s: 0.0,
        max_move_s: 0.0,
    }
}

fn mv(x: f64, y: f64, feed: f64) -> Command {
    Command::Move(Move {
        target: [x, y, 0.0, 0.0, 0.0, 0.0],
        feed,
        kind: MoveKind::Feed,
    })
}

/// Everything the planner gives for `cmds`, skipping refused ones.
fn plan(cmds: &[Command]) -> (Vec<Planned>, Vec<String>) {
    let mut p = Planner::new(limits(), [0.0; 6], 0.0);
    let mut errors = vec![];
    for c in cmds {
        if let Err(e) = p.push(c) {
            errors.push(e.to_string());
        }
    }
    p.finish();
    let mut out = vec![];
    while let Some(x) = p.pop() {
        out.push(x);
    }
    (out, errors)
}

#[test]
fn out_of_range_commands_are_refused_and_change_nothing() {
    let before = [mv(10.0, 10.0, 50.0), mv(20.0, 5.0, 50.0)];
    let after = [mv(30.0, 30.0, 50.0), Command::Dwell { seconds: 1.0 }];
    for (bad, message) in [
        (
            Command::Dwell { seconds: 2e13 },
            "dwell must be from 0 to 86400 s, got 2e13",
        ),
        (
            Command::Dwell { seconds: -1.0 },
            "dwell must be from 0 to 86400 s, got -1",
        ),
        (
            Command::Dwell {
                seconds: f64::INFINITY,
            },
            "dwell must be from 0 to 86400 s, got inf",
        ),
        (mv(1e300, 0.0, 50.0), "coordinate 0 must be from"),
        (
            mv(50.0, 50.0, 1e-300),
            "the job would last at least 1.5e298 h",
        ),
        (mv(1e8, 0.0, 1e-300), "the job would last for ever"),
        (mv(1e6, 0.0, 1e-3), "the job would last at least 27777"),
    ] {
        let with: Vec<Command> = before.iter().chain([&bad]).chain(&after).copied().collect();
        let without: Vec<Command> = before.iter().chain(&after).copied().collect();
        let (planned, errors) = plan(&with);
        assert_eq!(errors.len(), 1, "{bad:?}: {errors:?}");
        assert!(errors[0].contains(message), "{bad:?}: {}", errors[0]);
        assert_eq!(planned, plan(&without).0, "{bad:?} changed the plan");
    }
}

#[test]
fn a_plan_may_last_up_to_the_longest_job_and_no_longer() {
    // 30 dwells of a day fill the 30 days exactly; one more second is refused.
    let day = Command::Dwell {
        seconds: ranges::DWELL_S.max,
    };
    let mut p = Planner::new(limits(), [0.0; 6], 0.0);
    for _ in 0..30 {
        p.push(&day).unwrap();
    }
    assert_eq!(p.clock(), ranges::JOB_S.max * 1e6);
    let e = p.push(&Command::Dwell { seconds: 1.0 }).unwrap_err();
    assert!(matches!(e, PlanError::TooLong { .. }), "{e}");
    // A pen switch stands still for its settle time: counted the same way.
    let e = p
        .push(&Command::Tool {
            tool: 0,
            value: 1.0,
        })
        .unwrap_err();
    assert!(matches!(e, PlanError::TooLong { .. }), "{e}");
    // The cap counts from the plan's own start, as a scripted session's
    // planner starts where the last one ended.
    let mut later = Planner::new(limits(), [0.0; 6], 1e12);
    later.push(&day).unwrap();
}

#[test]
fn queued_moves_count_toward_the_longest_job() {
    // 0.001 mm/s over 100 mm is 1e5 s a move: the 26th move would pass 30
    // days while all of them are still held for lookahead.
    let mut p = Planner::new(limits(), [0.0; 6], 0.0);
    let mut refused = None;
    for k in 1..40 {
        let x = if k % 2 == 1 { 100.0 } else { 0.0 };
        if let Err(e) = p.push(&mv(x, 0.0, 1e-3)) {
            refused = Some((k, e));
            break;
        }
    }
    let (k, e) = refused.expect("refused");
    assert!(matches!(e, PlanError::TooLong { .. }), "{e}");
    assert_eq!(k, 26);
    p.finish();
    assert!(p.clock() <= ranges::JOB_S.max * 1e6);
}
