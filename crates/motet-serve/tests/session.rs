//! The session on simulated nodes, ticked on a simulated clock: jobs, holds,
//! cancels, stops and jogs end where they should.

use motet_net::Phase;
use motet_serve::jobs::read_upload;
use motet_serve::{serve_config, ActionError, Session, SimNodes, State};
use std::path::Path;
use std::sync::Arc;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

struct Rig {
    s: Session,
    now: u64,
    _dir: tempfile::TempDir,
    dir: std::path::PathBuf,
}

impl Rig {
    fn new(machine: &str) -> Rig {
        let m = motet_host::Machine::load(&root().join(machine)).unwrap();
        let nodes = Box::new(SimNodes::new(&m, m.start, serve_config()));
        let dir = tempfile::tempdir().unwrap();
        let mut r = Rig {
            s: Session::new(Arc::new(m), nodes),
            now: 0,
            dir: dir.path().to_path_buf(),
            _dir: dir,
        };
        // The nodes' clocks settle before anything runs.
        while !matches!(r.s.nodes().run().phase(), Phase::Done) {
            assert!(r.now < 10_000_000, "nodes never ready");
            r.run_for(10_000);
        }
        r
    }

    fn job(&self, file: &str) -> Arc<motet_serve::jobs::StoredJob> {
        let bytes = std::fs::read(root().join(file)).unwrap();
        let name = Path::new(file).file_name().unwrap().to_str().unwrap();
        let j = read_upload(
            self.s.machine(),
            &self.dir,
            1,
            name,
            &bytes,
            &Default::default(),
        )
        .unwrap();
        Arc::new(j)
    }

    /// Ticks for `us` of simulated time, 1 ms at a time.
    fn run_for(&mut self, us: u64) {
        let end = self.now + us;
        while self.now < end {
            self.now += 1_000;
            self.s.tick(self.now);
        }
    }

    /// Ticks until the state is `want` (at most `max_us`).
    fn until(&mut self, want: State, max_us: u64) {
        let end = self.now + max_us;
        while self.s.state() != want {
            assert!(
                self.now < end,
                "still {:?} after {max_us} µs, want {want:?}",
                self.s.state()
            );
            self.now += 1_000;
            self.s.tick(self.now);
        }
    }
}

/// The distance from `p` to the job's path (its moves, travel included).
fn off_path(job: &motet_serve::jobs::StoredJob, p: [f64; 2]) -> f64 {
    let mut best = f64::INFINITY;
    for s in &job.preview.strokes {
        for w in s.points.windows(2) {
            let (a, b) = (w[0], w[1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 {
                (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            best = best.min((p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy));
        }
    }
    best
}

fn last_target(job: &motet_serve::jobs::StoredJob) -> [f64; 2] {
    job.commands
        .iter()
        .rev()
        .find_map(|c| match c.item {
            motet_planner::Command::Move(m) => Some([m.target[0], m.target[1]]),
            _ => None,
        })
        .unwrap()
}

fn xy(s: &Session) -> [f64; 2] {
    let p = s.position();
    [p[0], p[1]]
}

/// Positions are compared within 1 µm: the nodes run the trajectory
/// quantized to 0.1 µm (far below a step).
///
/// What a test does after starting the job, and what must hold after.
#[derive(Clone, Copy, Debug)]
enum Script {
    /// Run to the end.
    Finish,
    /// Hold after this long, check the rest point, resume, finish.
    HoldResume(u64),
    /// Hold twice.
    HoldTwice(u64, u64),
    /// Cancel after this long.
    Cancel(u64),
    /// Emergency stop after this long.
    EStop(u64),
}

fn run_script(script: Script) {
    let mut r = Rig::new("examples/plotter.toml");
    let job = r.job("examples/jobs/drawing.svg");
    r.s.start(job.clone(), Some("a")).unwrap();
    let end = last_target(&job);
    let near = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-3;
    let long = 200_000_000;
    let hold = |r: &mut Rig, after: u64| {
        r.run_for(after);
        assert_eq!(r.s.state(), State::Running, "{script:?}");
        r.s.pause(Some("a")).unwrap();
        r.until(State::Paused, 10_000_000);
        let at = xy(&r.s);
        assert!(
            off_path(&job, at) < 1e-3,
            "{script:?}: held at {at:?}, off the path"
        );
        // At rest: time passes, nothing moves.
        r.run_for(300_000);
        assert_eq!(xy(&r.s), at, "{script:?}");
        let progress = r.s.status().job.unwrap().progress;
        assert!(
            progress > 0.0 && progress < 1.0,
            "{script:?}: progress {progress}"
        );
        r.s.resume(Some("a")).unwrap();
    };
    match script {
        Script::Finish => {}
        Script::HoldResume(t) => hold(&mut r, t),
        Script::HoldTwice(a, b) => {
            hold(&mut r, a);
            hold(&mut r, b);
        }
        Script::Cancel(t) | Script::EStop(t) => {
            r.run_for(t);
            if matches!(script, Script::Cancel(_)) {
                r.s.cancel(Some("a")).unwrap();
                r.until(State::Idle, 10_000_000);
            } else {
                r.s.estop();
                r.until(State::Stopped, 10_000_000);
            }
            let at = xy(&r.s);
            assert!(
                off_path(&job, at) < 1e-3,
                "{script:?}: stopped at {at:?}, off the path"
            );
            assert!(!near(at, end), "{script:?}: stopped at the job's end");
            assert!(r.s.status().job.is_none());
            let outcomes: Vec<&str> = r.s.history().map(|h| h.outcome.as_str()).collect();
            let want = if matches!(script, Script::Cancel(_)) {
                "cancelled"
            } else {
                "emergency stop"
            };
            assert_eq!(outcomes, [want], "{script:?}");
            return;
        }
    }
    r.until(State::Idle, long);
    assert!(
        near(xy(&r.s), end),
        "{script:?}: ended at {:?}, not {end:?}",
        xy(&r.s)
    );
    let finished =
        r.s.events
            .since(0)
            .iter()
            .filter(|e| e.message.contains("finished"))
            .count();
    assert_eq!(finished, 1, "{script:?}");
}

#[test]
fn jobs_end_where_they_should_after_holds_cancels_and_stops() {
    for script in [
        Script::Finish,
        Script::HoldResume(2_000_000),
        Script::HoldTwice(1_500_000, 4_000_000),
        Script::Cancel(3_000_000),
        Script::EStop(2_500_000),
    ] {
        run_script(script);
    }
}

#[test]
fn actions_in_the_wrong_state_change_nothing() {
    let mut r = Rig::new("examples/plotter.toml");
    let job = r.job("examples/jobs/drawing.svg");
    for (what, got) in [
        ("pause", r.s.pause(None)),
        ("resume", r.s.resume(None)),
        ("cancel", r.s.cancel(None)),
        ("unlock", r.s.unlock()),
    ] {
        assert!(
            matches!(
                got,
                Err(ActionError::WrongState {
                    state: State::Idle,
                    ..
                })
            ),
            "{what}: {got:?}"
        );
    }
    r.s.start(job.clone(), Some("a")).unwrap();
    r.run_for(500_000);
    for (what, got) in [
        ("start", r.s.start(job.clone(), Some("a"))),
        ("jog", r.s.jog(&[("x".into(), 1.0)], true, None, Some("a"))),
        ("tool", r.s.set_tool("pen", 1.0, Some("a"))),
        (
            "position",
            r.s.set_position(&[("x".into(), 1.0)], Some("a")),
        ),
    ] {
        assert!(
            matches!(
                got,
                Err(ActionError::WrongState {
                    state: State::Running,
                    ..
                })
            ),
            "{what}: {got:?}"
        );
    }
    // Another client may not hold the job until it takes control; anyone
    // may stop it.
    assert!(matches!(
        r.s.pause(Some("b")),
        Err(ActionError::NotController)
    ));
    assert!(matches!(r.s.pause(None), Err(ActionError::NotController)));
    r.s.take_control("b");
    r.s.pause(Some("b")).unwrap();
    r.until(State::Paused, 10_000_000);
    assert!(matches!(
        r.s.resume(Some("a")),
        Err(ActionError::NotController)
    ));
    r.s.estop();
    assert_eq!(r.s.state(), State::Stopped);
}

#[test]
fn jogs_tools_and_positions() {
    let mut r = Rig::new("examples/plotter.toml");
    r.s.jog(
        &[("x".into(), 10.0), ("Y".into(), 5.0)],
        true,
        Some(50.0),
        None,
    )
    .unwrap();
    r.until(State::Idle, 5_000_000);
    assert_eq!(xy(&r.s), [10.0, 5.0]);
    r.s.jog(&[("x".into(), 2.0)], false, None, None).unwrap();
    r.until(State::Idle, 5_000_000);
    assert_eq!(xy(&r.s), [2.0, 5.0]);
    for (axes, relative, feed) in [
        (vec![("x".to_string(), -50.0)], true, None),
        (vec![("q".to_string(), 1.0)], true, None),
        (vec![("x".to_string(), 1.0)], true, Some(0.0)),
        (vec![("x".to_string(), 1e9)], false, None),
    ] {
        let got = r.s.jog(&axes, relative, feed, None);
        assert!(got.is_err(), "{axes:?} {relative} {feed:?}");
        assert_eq!(r.s.state(), State::Idle, "{got:?} started something");
    }
    r.s.set_tool("pen", 1.0, None).unwrap();
    r.until(State::Idle, 5_000_000);
    assert!(r.s.set_tool("laser", 1.0, None).is_err());
    assert!(r.s.set_tool("pen", 2.0, None).is_err());
    r.s.set_position(&[("x".into(), 0.0), ("y".into(), 0.0)], None)
        .unwrap();
    assert_eq!(xy(&r.s), [0.0, 0.0]);
    // The nodes take the new position: a jog from it lands where asked.
    r.s.jog(&[("x".into(), 3.0)], true, None, None).unwrap();
    r.until(State::Idle, 5_000_000);
    assert_eq!(xy(&r.s), [3.0, 0.0]);
}

#[test]
fn a_job_waits_at_its_pauses_for_the_person() {
    let mut r = Rig::new("examples/plotter.toml");
    let job = r.job("examples/jobs/two-pens.svg");
    let pauses = job
        .commands
        .iter()
        .filter(|c| matches!(c.item, motet_planner::Command::Pause { optional: false }))
        .count();
    assert!(pauses > 0, "the two-pen drawing has a pen change");
    r.s.start(job.clone(), None).unwrap();
    let mut waited = 0;
    loop {
        r.run_for(1_000);
        match r.s.state() {
            State::Paused => {
                waited += 1;
                let at = xy(&r.s);
                r.run_for(200_000);
                assert_eq!(xy(&r.s), at, "moved while waiting for the pen");
                r.s.resume(None).unwrap();
            }
            State::Idle => break,
            State::Running => {}
            s => panic!("{s:?}"),
        }
        assert!(r.now < 600_000_000, "never finished");
    }
    assert_eq!(waited, pauses);
    let end = last_target(&job);
    let p = xy(&r.s);
    assert!(
        (p[0] - end[0]).hypot(p[1] - end[1]) < 1e-3,
        "ended at {p:?}, not {end:?}"
    );
    let said = r.s.events.since(0);
    assert_eq!(
        said.iter()
            .filter(|e| e.message.contains("the job pauses"))
            .count(),
        pauses
    );
}

#[test]
fn stops_before_the_nodes_are_ready_settle_at_once_where_the_machine_was() {
    // No settling here: the nodes' clocks are still being measured.
    for how in ["pause", "cancel", "estop"] {
        let m = motet_host::Machine::load(&root().join("examples/plotter.toml")).unwrap();
        let nodes = Box::new(SimNodes::new(&m, m.start, serve_config()));
        let mut s = Session::new(Arc::new(m), nodes);
        let dir = tempfile::tempdir().unwrap();
        let bytes = std::fs::read(root().join("examples/jobs/drawing.svg")).unwrap();
        let job = Arc::new(
            read_upload(
                s.machine(),
                dir.path(),
                1,
                "drawing.svg",
                &bytes,
                &Default::default(),
            )
            .unwrap(),
        );
        s.tick(1_000);
        s.start(job.clone(), None).unwrap();
        s.tick(2_000);
        assert!(s.status().connecting);
        match how {
            "pause" => s.pause(None).unwrap(),
            "cancel" => s.cancel(None).unwrap(),
            _ => s.estop(),
        }
        let want = match how {
            "pause" => State::Paused,
            "cancel" => State::Idle,
            _ => State::Stopped,
        };
        assert_eq!(s.state(), want, "{how}");
        assert_eq!(s.position()[..2], [0.0, 0.0], "{how}");
        // Ticking on does not turn it into an alarm or a finished job.
        let mut now = 2_000;
        while now < 6_000_000 {
            now += 1_000;
            s.tick(now);
        }
        assert_eq!(s.state(), want, "{how}: {:?}", s.events.since(0));
        if how == "pause" {
            s.resume(None).unwrap();
            while s.state() != State::Idle {
                now += 1_000;
                s.tick(now);
                assert!(now < 300_000_000, "never finished");
            }
            let end = last_target(&job);
            let p = xy(&s);
            assert!((p[0] - end[0]).hypot(p[1] - end[1]) < 1e-3, "{p:?} {end:?}");
        }
    }
}
