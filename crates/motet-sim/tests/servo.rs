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

pub const GAINS: &str = "rate_hz = 10000
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
