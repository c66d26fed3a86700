//! Driving machines call by call.

use motet_api::{ApiError, Event, Machine, PlanError};
use std::sync::{Arc, Mutex};

fn machine(name: &str) -> Machine {
    Machine::open(format!(
        "{}/../../examples/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

fn get(v: &[(String, f64)], axis: &str) -> f64 {
    v.iter().find(|(n, _)| n == axis).unwrap().1
}

#[test]
fn moves_are_executed_and_the_machine_ends_where_asked() {
    let mut m = machine("plotter.toml");
    m.move_to(&[("x", 20.0), ("y", 30.0)], None).unwrap();
    m.set_tool("pen", 1.0).unwrap();
    for k in 0..50 {
        let a = k as f64 * 0.3;
        m.move_to(
            &[("x", 100.0 + 40.0 * a.cos()), ("y", 100.0 + 40.0 * a.sin())],
            Some(50.0),
        )
        .unwrap();
    }
    m.jog(&[("x", -5.0)], None).unwrap();
    m.set_tool("pen", 0.0).unwrap();
    m.wait().unwrap();
    let target = m.target();
    let pos = m.position();
    for axis in ["x", "y"] {
        // Within one step of where it was asked to be (113 steps/mm).
        assert!(
            (get(&pos, axis) - get(&target, axis)).abs() < 0.01,
            "{axis}: {pos:?} vs {target:?}"
        );
    }
    let r = m.report();
    assert_eq!(r.underruns, 0);
    assert!(r.max_deviation_steps <= 0.5 + 1e-6);
    assert!(r.tool_on_distance_mm > 100.0);
}

#[test]
fn streaming_starts_before_the_script_ends() {
    // Segments reach the nodes while calls are still coming: after many moves
    // the machine has already moved, with only the lookahead held back.
    let mut m = machine("plotter.toml");
    for k in 0..400 {
        let x = 10.0 + (k % 2) as f64 * 100.0;
        let y = 10.0 + k as f64 * 0.4;
        m.move_to(&[("x", x), ("y", y)], Some(200.0)).unwrap();
    }
    assert!(
        m.time() > 0.0,
        "the simulated machine should be running before wait()"
    );
    assert!(
        m.lookahead() < 50,
        "lookahead holds {} moves",
        m.lookahead()
    );
    m.wait().unwrap();
    assert_eq!(m.report().underruns, 0);
}

#[test]
fn refused_calls_leave_queued_motion_untouched() {
    let mut m = machine("printer.toml");
    m.move_to(&[("x", 50.0), ("y", 50.0)], Some(100.0)).unwrap();
    let before = m.target();
    // (call, expected error)
    type Call = Box<dyn Fn(&mut Machine) -> Result<(), ApiError>>;
    let bad: Vec<(Call, &str)> = vec![
        (
            Box::new(|m| m.move_to(&[("x", 500.0)], None)),
            "beyond the axis's travel",
        ),
        (
            Box::new(|m| m.move_to(&[("q", 1.0)], None)),
            "unknown axis `q`",
        ),
        (
            Box::new(|m| m.move_to(&[("x", 10.0)], Some(-1.0))),
            "feed must be from 0.001 to 100000 units/s, got -1",
        ),
        (
            Box::new(|m| m.move_to(&[("x", 10.0)], Some(1e-300))),
            "feed must be from 0.001 to 100000 units/s, got 1e-300",
        ),
        (
            Box::new(|m| m.jog(&[("x", 1.0)], Some(f64::INFINITY))),
            "feed must be from 0.001 to 100000 units/s, got inf",
        ),
        (
            Box::new(|m| m.move_to(&[("x", f64::NAN)], None)),
            "x=NaN: not a number",
        ),
        (
            Box::new(|m| m.move_to(&[("x", 1e308)], None)),
            "beyond the axis's travel",
        ),
        (
            Box::new(|m| m.jog(&[("x", 1e308), ("y", 1e308)], None)),
            "beyond the axis's travel",
        ),
        (
            Box::new(|m| m.set_tool("laser", 2.0)),
            "tool value must be from 0 to 1, got 2",
        ),
        (
            Box::new(|m| m.jog(&[("z", -1.0)], None)),
            "beyond the axis's travel",
        ),
        (
            Box::new(|m| m.set_tool("laser", 1.0)),
            "unknown tool `laser`",
        ),
        (
            Box::new(|m| m.dwell(-2.0)),
            "dwell must be from 0 to 86400 s, got -2",
        ),
        (
            Box::new(|m| m.dwell(1e14)),
            "dwell must be from 0 to 86400 s, got 1e14",
        ),
    ];
    for (call, want) in bad {
        let err = call(&mut m).unwrap_err().to_string();
        assert!(err.contains(want), "{err} should contain {want}");
        assert_eq!(m.target(), before);
    }
    m.wait().unwrap();
    assert!((get(&m.position(), "x") - 50.0).abs() < 0.02);
}

#[test]
fn polar_centre_is_refused() {
    let mut m = machine("clay-printer.toml");
    let err = m.move_to(&[("x", -100.0), ("y", 0.0)], None).unwrap_err();
    assert!(matches!(err, ApiError::Unreachable(_)), "{err}");
    m.move_to(&[("x", 0.0), ("y", 100.0)], Some(30.0)).unwrap();
    m.wait().unwrap();
}

#[test]
fn events_report_tool_changes_in_time_order() {
    let mut m = machine("plotter.toml");
    let seen = Arc::new(Mutex::new(Vec::new()));
    let s = seen.clone();
    m.on_event(move |e| s.lock().unwrap().push(e.clone()));
    m.move_to(&[("x", 10.0)], None).unwrap();
    m.set_tool("pen", 1.0).unwrap();
    m.move_to(&[("x", 40.0)], None).unwrap();
    m.set_tool("pen", 0.0).unwrap();
    m.wait().unwrap();
    let seen = seen.lock().unwrap();
    let tools: Vec<(String, f32)> = seen
        .iter()
        .filter_map(|e| {
            if let Event::Tool { tool, value, .. } = e {
                Some((tool.clone(), *value))
            } else {
                None
            }
        })
        .collect();
    assert_eq!(
        tools,
        vec![("pen".to_string(), 1.0), ("pen".to_string(), 0.0)]
    );
    let times: Vec<f64> = seen
        .iter()
        .map(|e| match e {
            Event::Tool { time, .. } | Event::Idle { time } => *time,
        })
        .collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
    assert!(matches!(seen.last(), Some(Event::Idle { .. })));
}

#[test]
fn the_machine_can_go_on_after_wait() {
    let mut m = machine("gestalt-3axis.toml");
    m.move_to(&[("x", 30.0), ("y", 20.0), ("z", 5.0)], Some(20.0))
        .unwrap();
    m.wait().unwrap();
    let t1 = m.time();
    m.move_to(&[("x", 10.0)], Some(20.0)).unwrap();
    m.dwell(0.5).unwrap();
    m.wait().unwrap();
    assert!(
        m.time() >= t1 + 0.5 + 20.0 / 20.0 - 1e-6,
        "time {} after {t1}",
        m.time()
    );
    assert!((get(&m.position(), "x") - 10.0).abs() < 0.01);
    let tmp = tempfile::Builder::new()
        .prefix("motet-api-")
        .tempdir()
        .unwrap();
    let dir = tmp.path().join("out");
    m.save(&dir).unwrap();
    assert!(dir.join("path.png").exists() && dir.join("report.json").exists());
}

#[test]
fn a_reversal_needs_a_rest_and_a_smooth_stream_does_not() {
    // (moves as (x, y), rests expected: the end, plus one per full reversal)
    let cases: &[(&[(f64, f64)], usize)] = &[
        (&[(10.0, 10.0), (20.0, 10.0), (30.0, 12.0), (40.0, 16.0)], 1),
        (&[(10.0, 10.0), (40.0, 10.0), (20.0, 10.0)], 2),
    ];
    for (moves, want) in cases {
        let mut m = machine("plotter.toml");
        for (x, y) in moves.iter() {
            m.move_to(&[("x", *x), ("y", *y)], Some(50.0)).unwrap();
        }
        m.wait().unwrap();
        assert_eq!(m.report().rests, *want, "{moves:?}");
    }
}

/// What a run did: steps and final position of every actuator, distances.
fn outcome(m: &Machine) -> (Vec<(u64, i64)>, f64, f64) {
    let r = m.report();
    (
        r.actuators.iter().map(|a| (a.steps, a.position)).collect(),
        r.tool_on_distance_mm,
        r.travel_distance_mm,
    )
}

/// A script of calls on the plotter: zigzag strokes, pen changes, a dwell,
/// a wait halfway.
fn script(m: &mut Machine, go: &mut dyn FnMut(&mut Machine, usize) -> Result<(), ApiError>) {
    for k in 0..300 {
        go(m, k).unwrap();
    }
}

fn call(m: &mut Machine, k: usize) -> Result<(), ApiError> {
    match k {
        100 => m.set_tool("pen", 1.0),
        150 => m.dwell(0.25),
        200 => m.wait(),
        250 => m.set_tool("pen", 0.0),
        _ => {
            let x = 10.0 + (k % 2) as f64 * 120.0;
            let y = 10.0 + k as f64 * 0.5;
            m.move_to(&[("x", x), ("y", y)], Some(150.0))
        }
    }
}

#[test]
fn interrupted_calls_lose_and_repeat_nothing() {
    let mut whole = machine("plotter.toml");
    script(&mut whole, &mut call);
    whole.wait().unwrap();

    // (interrupt at every n-th question)
    for every in [1, 3, 40] {
        let mut m = machine("plotter.toml");
        let mut asked = 0usize;
        m.on_interrupt(move || {
            asked += 1;
            asked.is_multiple_of(every)
        });
        let mut interrupted = 0;
        script(&mut m, &mut |m, k| match call(m, k) {
            // A wait must finish before the script goes on, as it did
            // above; any other call already accepted its command.
            Err(ApiError::Interrupted) if k == 200 => {
                interrupted += 1;
                while let Err(ApiError::Interrupted) = m.wait() {
                    interrupted += 1;
                }
                Ok(())
            }
            Err(ApiError::Interrupted) => {
                interrupted += 1;
                Ok(())
            }
            r => r,
        });
        assert!(!m.is_idle());
        while let Err(e) = m.wait() {
            assert!(matches!(e, ApiError::Interrupted), "{e}");
            interrupted += 1;
        }
        assert!(m.is_idle());
        assert!(interrupted > 0, "every {every}: never interrupted");
        assert_eq!(outcome(&m), outcome(&whole), "every {every}");
        assert_eq!(m.target(), whole.target());
    }
}

#[test]
fn an_interrupted_job_keeps_the_commands_queued_so_far() {
    let job = format!(
        "{}/../../examples/jobs/drawing.svg",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut whole = machine("plotter.toml");
    let n = whole.run_job(&job, false).unwrap();
    let mut m = machine("plotter.toml");
    let stop = Arc::new(Mutex::new(true));
    let s = stop.clone();
    let mut asked = 0;
    m.on_interrupt(move || {
        asked += 1;
        asked == 200 && *s.lock().unwrap()
    });
    assert!(matches!(m.run_job(&job, false), Err(ApiError::Interrupted)));
    assert_ne!(
        m.target(),
        whole.target(),
        "the whole job of {n} commands was queued"
    );
    *stop.lock().unwrap() = false;
    m.wait().unwrap();
    for ((axis, p), (_, t)) in m.position().iter().zip(m.target()) {
        assert!((p - t).abs() < 0.01, "{axis}: at {p}, queued to {t}");
    }
}

#[test]
fn save_makes_its_folder_but_no_missing_parent() {
    let mut m = machine("plotter.toml");
    m.move_to(&[("x", 10.0)], None).unwrap();
    m.wait().unwrap();
    let tmp = tempfile::Builder::new()
        .prefix("motet-api-save-")
        .tempdir()
        .unwrap();
    let base = tmp.path().join("base");
    let deep = base.join("missing").join("out");
    let err = m.save(&deep).unwrap_err();
    assert!(matches!(err, ApiError::NoParent { .. }), "{err}");
    let msg = err.to_string();
    assert!(
        msg.ends_with(&format!("the directory {} does not exist", base.display())),
        "{msg}"
    );
    assert!(!base.exists(), "nothing is created");
    std::fs::create_dir(&base).unwrap();
    m.save(base.join("out")).unwrap();
    assert!(base.join("out/path.png").exists());
}

#[test]
fn a_day_long_dwell_runs_and_the_clock_jumps_over_it() {
    // The longest dwell there is, then wait(): the simulated clock jumps over
    // the idle day (a per-speed laser output stays quiet through it too).
    let mut m = machine("laser.toml");
    m.move_to(&[("x", 10.0)], Some(50.0)).unwrap();
    m.dwell(86_400.0).unwrap();
    m.move_to(&[("x", 20.0)], Some(50.0)).unwrap();
    m.wait().unwrap();
    let t = m.time();
    assert!((86_400.0..86_401.0).contains(&t), "{t}");
    assert!((get(&m.position(), "x") - 20.0).abs() < 0.01);
    let r = m.report();
    assert!(r.speed_factor.is_finite() && r.duration_s.is_finite());
}

#[test]
fn a_session_plans_at_most_thirty_days_between_waits() {
    let mut m = machine("plotter.toml");
    m.move_to(&[("x", 10.0)], None).unwrap();
    for _ in 0..29 {
        m.dwell(86_400.0).unwrap();
    }
    let before = m.target();
    let err = m.dwell(86_400.0).unwrap_err();
    assert!(
        matches!(err, ApiError::Plan(PlanError::TooLong { .. })),
        "{err}"
    );
    assert!(
        err.to_string().contains("motet plans at most 720 h"),
        "{err}"
    );
    assert_eq!(m.target(), before);
    // What was queued still runs; after the wait a new plan starts.
    m.wait().unwrap();
    m.dwell(60.0).unwrap();
}

#[test]
fn targets_within_half_a_step_of_travel_are_clamped_and_counted() {
    let mut m = machine("plotter.toml");
    // Half a step of the plotter's belts is 0.0044 mm.
    m.move_to(&[("x", 10.0), ("y", 10.0)], None).unwrap();
    m.move_to(&[("x", -0.0031)], None).unwrap();
    assert_eq!(get(&m.target(), "x"), 0.0);
    m.jog(&[("y", -10.002)], None).unwrap();
    assert_eq!(get(&m.target(), "y"), 0.0);
    let err = m.move_to(&[("x", -0.005)], None).unwrap_err();
    assert!(
        err.to_string().contains("beyond the axis's travel"),
        "{err}"
    );
    m.wait().unwrap();
    let r = m.report();
    assert_eq!(r.clamped_moves, 2);
    assert!(
        (r.max_clamp_mm - 0.0031).abs() < 1e-12,
        "{}",
        r.max_clamp_mm
    );
}

/// Calls `k` of a long drawing session on the plotter: short moves round a
/// circle, the pen lowered and lifted every `pen_every` calls.
fn circling(m: &mut Machine, k: usize, pen_every: usize) -> Result<(), ApiError> {
    if k.is_multiple_of(pen_every) {
        let down = (k / pen_every).is_multiple_of(2);
        return m.set_tool("pen", if down { 1.0 } else { 0.0 });
    }
    let a = k as f64 * 0.02;
    m.move_to(
        &[("x", 150.0 + 60.0 * a.cos()), ("y", 109.0 + 60.0 * a.sin())],
        Some(200.0),
    )
}

fn polylines(svg: &str) -> usize {
    svg.matches("<polyline").count()
}

#[test]
fn a_long_session_holds_no_more_of_its_path_than_one_stroke() {
    // (calls, pen lowered and lifted every so many calls): many short
    // strokes, and long ones over many turns.
    for (calls, pen_every) in [(30_000, 7), (12_000, 5_000)] {
        let mut m = machine("plotter.toml");
        let mut most = m.held();
        for k in 0..calls {
            circling(&mut m, k, pen_every).unwrap();
            most = most.max(m.held());
        }
        m.wait().unwrap();
        // Every stroke finished is drawn at once; only the one being drawn
        // is held, and it is cut into pieces of at most this many points.
        assert!(
            most.path_points <= motet_sim::path::MAX_STROKE_POINTS,
            "pen every {pen_every}: {most:?}"
        );
        assert!(
            most.node_segments <= motet_sim::NODE_QUEUE,
            "pen every {pen_every}: {most:?}"
        );
        // And nothing of the path was lost on the way.
        let tmp = tempfile::Builder::new()
            .prefix("motet-api-long-")
            .tempdir()
            .unwrap();
        m.save(tmp.path()).unwrap();
        let svg = std::fs::read_to_string(tmp.path().join("path.svg")).unwrap();
        let strokes = calls / pen_every;
        assert!(
            polylines(&svg) >= strokes,
            "pen every {pen_every}: {} polylines for {strokes} pen changes",
            polylines(&svg)
        );
    }
}

#[test]
fn each_save_writes_the_whole_drawing_so_far() {
    let mut m = machine("plotter.toml");
    let tmp = tempfile::Builder::new()
        .prefix("motet-api-saves-")
        .tempdir()
        .unwrap();
    let mut before: Option<(String, Vec<u8>)> = None;
    for (part, calls) in [0..300, 300..600, 600..900].into_iter().enumerate() {
        for k in calls {
            circling(&mut m, k, 40).unwrap();
        }
        let dir = tmp.path().join(format!("save-{part}"));
        m.save(&dir).unwrap();
        let svg = std::fs::read_to_string(dir.join("path.svg")).unwrap();
        let png = std::fs::read(dir.join("path.png")).unwrap();
        assert!(svg.ends_with(motet_render::SVG_END), "save {part}");
        if let Some((svg0, png0)) = before {
            // The earlier drawing, then what was drawn since.
            let head = svg0.strip_suffix(motet_render::SVG_END).unwrap();
            assert!(svg.starts_with(head), "save {part}");
            assert!(polylines(&svg) > polylines(&svg0), "save {part}");
            assert_ne!(png, png0, "save {part}");
        }
        before = Some((svg, png));
    }
}
