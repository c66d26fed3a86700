//! The session's heaters on simulated nodes and a simulated clock: a
//! job's temperature commands set the targets as the machine reaches them,
//! those it never reaches (cancelled before) do not, and an emergency stop
//! switches every heater off.

use motet_net::Phase;
use motet_planner::AuxChannel;
use motet_serve::jobs::read_upload;
use motet_serve::{serve_config, Session, SimNodes, State};
use std::path::Path;
use std::sync::Arc;

struct Rig {
    s: Session,
    now: u64,
    dir: tempfile::TempDir,
}

fn rig() -> Rig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/printer.toml");
    let m = motet_host::Machine::load(&path).unwrap();
    let nodes = Box::new(SimNodes::new(&m, m.start, serve_config()));
    let mut r = Rig {
        s: Session::new(Arc::new(m), nodes),
        now: 0,
        dir: tempfile::tempdir().unwrap(),
    };
    while !matches!(r.s.nodes().run().phase(), Phase::Done) {
        r.step();
    }
    r
}

impl Rig {
    fn step(&mut self) {
        self.now += 1_000;
        self.s.tick(self.now);
    }

    fn start(&mut self, gcode: &str) {
        let j = read_upload(
            self.s.machine(),
            self.dir.path(),
            1,
            "t.gcode",
            gcode.as_bytes(),
            &Default::default(),
        )
        .unwrap();
        self.s.start(Arc::new(j), None).unwrap();
    }

    fn target(&self, c: AuxChannel) -> f64 {
        self.s
            .heaters()
            .iter()
            .find(|h| h.channel == c)
            .unwrap()
            .target
    }
}

const JOB: &str = "M140 S60\nG1 X50 F3000\nM104 S200\nG1 X100\nG1 X150\nM104 S0\nM140 S0\n";

#[test]
fn a_jobs_temperatures_are_set_where_the_machine_reaches_them() {
    let mut r = rig();
    r.start(JOB);
    let mut seen = Vec::new();
    while r.s.state() != State::Idle {
        r.step();
        let at = (r.s.status().position[0], r.target(AuxChannel::Hotend(0)));
        if seen.last().map(|s: &(f64, f64)| s.1) != Some(at.1) {
            seen.push(at);
        }
    }
    // Off, then 200 °C from the move to X100 on (set where it starts), off at the end.
    let ons: Vec<_> = seen.iter().filter(|(_, t)| *t == 200.0).collect();
    assert_eq!(ons.len(), 1, "{seen:?}");
    assert!(
        (ons[0].0 - 50.0).abs() < 1.0,
        "set where the move after it starts: {seen:?}"
    );
    assert_eq!(r.target(AuxChannel::Hotend(0)), 0.0);
    assert_eq!(r.target(AuxChannel::Bed), 0.0);
}

#[test]
fn a_cancelled_job_sets_nothing_it_did_not_reach_and_an_emergency_stop_cools() {
    let mut r = rig();
    r.start(JOB);
    while r.s.status().position[0] < 10.0 {
        r.step();
    }
    assert_eq!(r.target(AuxChannel::Bed), 60.0, "reached");
    r.s.cancel(None).unwrap();
    while r.s.state() != State::Idle {
        r.step();
    }
    assert_eq!(r.target(AuxChannel::Hotend(0)), 0.0, "never reached");
    assert_eq!(r.target(AuxChannel::Bed), 60.0, "left as it was");
    r.s.estop();
    assert_eq!(r.target(AuxChannel::Bed), 0.0, "off on an emergency stop");
    let before = r.s.heaters()[1].temp;
    for _ in 0..10_000 {
        r.step();
    }
    assert!(r.s.heaters()[1].temp < before, "cooling");
}

#[test]
fn targets_out_of_range_or_for_missing_heaters_are_refused_and_change_nothing() {
    let mut r = rig();
    let e =
        r.s.set_heater_target(AuxChannel::Hotend(0), 300.0)
            .unwrap_err();
    assert!(e.to_string().contains("out of range (0 to 275)"), "{e}");
    let e =
        r.s.set_heater_target(AuxChannel::Chamber, 40.0)
            .unwrap_err();
    assert_eq!(
        e.to_string(),
        "no chamber heater (the machine's heaters: hotend, bed)"
    );
    assert!(r.s.set_heater_target(AuxChannel::Bed, -1.0).is_err());
    assert!(r.s.heaters().iter().all(|h| h.target == 0.0));
    // A job asking for too much: the machine runs, the target stays, and
    // the event log says why.
    r.start("M104 S400\nG1 X20 F3000\n");
    while r.s.state() != State::Idle {
        r.step();
    }
    assert_eq!(r.target(AuxChannel::Hotend(0)), 0.0);
    assert!(r
        .s
        .events
        .since(0)
        .into_iter()
        .any(|e| e.message.starts_with("temperature not set")));
}
