//! Servo actuators in the simulator: the node's loop on the DC motor
//! plant follows the benchmark-like moves within its target, an unstable
//! gain set is caught by the following-error limit (naming the actuator),
//! a gain change applies mid-move, a limit switch cuts the drive, samples
//! stay within the wire budget, and a lost encoder stops the run by name.

use motet_host::Machine;
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_sim::{simulate, SimError};
use std::path::Path;

/// A one-axis servo machine: `servo` and `motor` are the tables' bodies.
fn machine(servo: &str, motor: &str, extra: &str) -> Machine {
    let text = format!(
        r#"
name = "servo axis"
[axes.x]
travel = [0, 200]
max_velocity = 150
max_acceleration = 2000
[actuators.x_servo]
joint = "x"
chain = [{{ leadscrew = {{ lead = 5.0 }} }}, {{ encoder = {{ lines = 1000 }} }}]
[actuators.x_servo.servo]
{servo}
[actuators.x_servo.motor]
{motor}
{extra}
"#
    );
    Machine::parse(&text, Path::new("servo.toml")).unwrap()
}

/// Gains `motet tune` found for this axis, rounded.
const GAINS: &str = "rate_hz = 10000
kp = 0.002
ki = 0.25
kd = 1.5e-5
kv = 3.27e-6
ka = 2.5e-8
kf = 0.004
integral_limit = 0.2
derivative_hz = 500
following_limit = 40";

fn moves(xs: &[f64], feed: f64) -> Vec<Located<Command>> {
    xs.iter()
        .map(|&x| {
            let mut target = [0.0; 6];
            target[0] = x;
            Located {
                item: Command::Move(Move {
                    target,
                    feed,
                    kind: MoveKind::Feed,
                }),
                loc: SourceLoc::default(),
            }
        })
        .collect()
}

#[test]
fn follows_within_its_target() {
    let m = machine(GAINS, "load = 2.0", "");
    let r = simulate(
        &m,
        "moves",
        &moves(&[100.0, 10.0, 150.0, 0.0], 150.0),
        &mut |_, _| {},
    )
    .unwrap()
    .report;
    let f = r.actuators[0].following.clone().unwrap();
    eprintln!("{f:?}");
    assert!(f.max_cruise_counts <= 2.0, "{f:?}");
    assert!(f.max_accel_counts <= 10.0, "{f:?}");
    assert!(f.ticks as f64 >= r.duration_s * 10_000.0 * 0.99, "{f:?}");
}

/// Gains whose loop is unstable (a proportional gain far past the ultimate
/// one): the following-error limit stops the run, naming the actuator,
/// long before the axis reaches a limit switch.
#[test]
fn an_unstable_loop_is_caught_by_its_following_limit() {
    let unstable = GAINS
        .replace("kp = 0.002", "kp = 0.05")
        .replace("kd = 1.5e-5", "kd = 0");
    let m = machine(&unstable, "load = 2.0", "");
    let err = simulate(&m, "moves", &moves(&[100.0, 10.0], 150.0), &mut |_, _| {})
        .err()
        .expect("the loop trips");
    let SimError::Fault(text) = err else {
        panic!("{err}")
    };
    assert!(
        text.contains("node main: actuator x_servo: following error"),
        "{text}"
    );
    assert!(!text.contains("limit switch"), "{text}");
    let value: f64 = text
        .split("following error ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(value.abs() > 40.0 && value.abs() < 200.0, "{text}");
}

/// Gains sent while the axis moves take hold at once: a drive limit of
/// 1 % mid-move leaves the motor behind its set point until the limit trips.
#[test]
fn gains_change_mid_move() {
    use motet_planner::Planner;
    let m = machine(GAINS, "load = 2.0", "");
    let mut sim = motet_sim::SimMachine::new(&m).unwrap();
    let mut planner = Planner::new(m.limits(), m.start, 0.0);
    for c in moves(&[150.0], 150.0) {
        planner.push(&c.item).unwrap();
    }
    planner.finish();
    while let Some(item) = planner.pop() {
        sim.submit(item).unwrap();
    }
    sim.run_until(300_000.0);
    assert_eq!(sim.fault(), None, "good gains follow");
    let mut g = m.actuators[0].servo.as_ref().unwrap().gains;
    g.output_limit = 0.01;
    sim.set_servo_gains("x_servo", g).unwrap();
    sim.run_until(400_000.0);
    let f = sim.fault().expect("a 1 % drive cannot follow").to_string();
    assert!(f.contains("actuator x_servo: following error"), "{f}");
    // Bad gains are refused by the node, named.
    g.kp = f32::NAN;
    assert!(sim.set_servo_gains("x_servo", g).is_err());
}

/// An encoder that stops reporting mid-job stops the run, naming the
/// actuator and its encoder.
#[test]
fn a_lost_encoder_stops_the_run() {
    let m = machine(GAINS, "load = 2.0\nencoder_fails_s = 0.5", "");
    let err = simulate(&m, "moves", &moves(&[100.0, 10.0], 150.0), &mut |_, _| {})
        .err()
        .expect("stopped");
    let text = err.to_string();
    assert!(
        text.contains("actuator x_servo: encoder stopped reporting at 0.5"),
        "{text}"
    );
}

/// The samples stay within the node's budget (frames included), lose
/// nothing, and plot beside the path.
#[test]
fn samples_fit_the_budget_and_plot() {
    let sensor = "[sensors.acc]\nkind = \"accelerometer\"\nactuator = \"x_servo\"\nrate_hz = 2000\n[nodes.n]\nactuators = [\"x_servo\"]\nsensors = [\"acc\"]\nsample_budget = 300";
    let m = machine(GAINS, "load = 2.0", sensor);
    let commands = moves(&[100.0, 10.0, 150.0, 0.0], 150.0);
    let run = motet_sim::simulate_stream(
        &m,
        "moves",
        commands.into_iter().map(Ok::<_, std::convert::Infallible>),
        4,
        &mut |_, _| {},
        &mut |_| {},
    )
    .unwrap();
    let mut total = 0.0;
    for s in &run.loops.store.series {
        assert!(
            s.received > 50 && s.dropped == 0,
            "{}: {} / {}",
            s.name,
            s.received,
            s.dropped
        );
        let batches = s.bytes as f64 / 150.0 + 1.0;
        total += (s.bytes as f64 + 16.0 * batches) / run.report.duration_s;
    }
    assert!(total <= 300.0, "{total} B/s");
    let dir = tempfile::tempdir().unwrap();
    let files =
        motet_sim::plots::write_plots(&m, &run.loops.store, &run.loops.planned, 0.0, dir.path())
            .unwrap();
    assert_eq!(files, ["servo-x_servo.png", "sensor-acc.png"]);
    for f in files {
        let bytes = std::fs::read(dir.path().join(f)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
    }
    // The accelerometer follows the planned acceleration: its readings
    // correlate with the plan's at the same instants.
    let acc = run
        .loops
        .store
        .series
        .iter()
        .find(|s| s.name == "sensor acc")
        .unwrap();
    let plan = &run.loops.planned.series[0];
    let planned_at = |t: f64| {
        plan.all_points()
            .take_while(|p| p.t_us <= t)
            .last()
            .map_or(0.0, |p| p.value)
    };
    let (mut dot, mut nm, mut np) = (0.0, 0.0, 0.0);
    for p in acc.all_points() {
        let q = planned_at(p.t_us);
        dot += p.value * q;
        nm += p.value * p.value;
        np += q * q;
    }
    let r = dot / (nm.sqrt() * np.sqrt());
    assert!(r > 0.5, "correlation {r}");
}

/// A limit switch beyond the travel opens when the carriage runs past it,
/// and cuts the drive: the motor coasts to a stop just past it.
#[test]
fn a_limit_switch_cuts_the_drive() {
    use motet_node::Board;
    let m = machine(GAINS, "load = 2.0\nlimit_margin = 1.0", "");
    let mut plants = motet_sim::servo::ServoPlants::of_node(&m, 0, &m.start, 0.0);
    plants.drive(0, 0.3, 0.0);
    let mut t = 0.0;
    while !plants.limit(0, t) {
        t += 100.0;
        assert!(t < 5e6, "never reached the switch");
    }
    let at = plants.get_mut(0).unwrap().joint();
    assert!(at > 201.0 && at < 201.5, "{at}");
    // Driven on, it still stops: the switch is in the drive's line.
    plants.drive(0, 0.3, t);
    plants.get_mut(0).unwrap().advance(t + 2e6);
    let p = plants.get_mut(0).unwrap();
    assert_eq!(p.motor().omega(), 0.0);
    assert!(p.joint() < 215.0, "{}", p.joint());
}

/// `motet tune` on an axis that carries a weight: the steps either way tell
/// the friction (4 mN·m, 0.004 duty) from the weight (14.7 N on a 5 mm
/// lead, 0.0117 duty), the fitted reaction curve has the motor's lags
/// (the current's 0.42 ms, the whole 7.62 ms of this inertia), and the
/// gains follow the check move within the targets.
#[test]
fn tuning_tells_friction_from_a_weight_and_finds_the_lags() {
    use motet_sim::tune::{tune, Method, Rule};
    let m = machine(GAINS, "load = 1.5\nload_force = 14.7", "");
    let t = tune(&m, "x_servo", Method::Step, Rule::Model).unwrap();
    let id = &t.identified;
    // (what, found, true, relative tolerance)
    let cases = [
        ("friction", id.friction_duty, 0.004, 0.05),
        ("load", id.load_duty, 0.0117, 0.05),
        ("Kv", id.kv, 304_100.0, 0.01),
        ("lag at speed", id.lag_s, 7.62e-3, 0.02),
        ("delay", id.delay_s, 0.45e-3, 0.2),
    ];
    for (what, found, want, tol) in cases {
        assert!(
            ((found - want) / want).abs() <= tol,
            "{what}: {found} against {want}"
        );
    }
    assert_eq!(t.gains.lead, id.delay_s as f32);
    let f = t.check.report.actuators[0].following.clone().unwrap();
    assert!(f.max_settled_cruise_counts <= 2.0, "{f:?}");
    assert!(f.max_accel_counts <= 10.0, "{f:?}");
}
