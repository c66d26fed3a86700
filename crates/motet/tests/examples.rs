//! Every example machine runs its example job on simulated nodes within its
//! limits, and the executed path follows the commanded one.

use motet_host::Machine;
use motet_planner::{Command, Located};
use motet_sim::{simulate, SimResult};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn run(machine: &str, job: &str) -> (Machine, Vec<Located<Command>>, SimResult) {
    let m = Machine::load(&root().join("examples").join(machine)).unwrap();
    let path = root().join("examples/jobs").join(job);
    let cmds = motet_api::load_job(&m, &path, &motet_api::JobOptions::default())
        .unwrap()
        .commands;
    let r = simulate(&m, job, &cmds, &mut |_, _| {}).unwrap();
    (m, cmds, r)
}

const EXAMPLES: &[(&str, &str)] = &[
    ("plotter.toml", "drawing.svg"),
    ("printer.toml", "printer-vase-layers.gcode"),
    ("laser.toml", "laser-badge.gcode"),
    ("clay-printer.toml", "clay-vase.gcode"),
    ("gestalt-3axis.toml", "gestalt-3d.gcode"),
    ("scara.toml", "scara-star.gcode"),
    ("fivebar.toml", "fivebar-star.gcode"),
    ("delta.toml", "delta-vase.gcode"),
    ("modules/mill.toml", "mill-4axis.gcode"),
];

#[test]
fn every_example_runs_within_limits_and_on_time() {
    for (machine, job) in EXAMPLES {
        let (m, cmds, r) = run(machine, job);
        let rep = &r.report;
        let ctx = format!("{machine} {job}");
        assert!(
            rep.duration_s > 0.0 && rep.segments > 0,
            "{ctx}: nothing ran"
        );
        assert_eq!(rep.underruns, 0, "{ctx}: a node ran dry");
        assert!(
            rep.max_deviation_steps <= 0.5 + 1e-6,
            "{ctx}: deviation {} steps",
            rep.max_deviation_steps
        );
        assert!(
            rep.max_step_time_error_us <= 1.0,
            "{ctx}: step time error {} µs",
            rep.max_step_time_error_us
        );
        for a in &rep.axes {
            assert!(
                a.peak_velocity <= a.max_velocity * (1.0 + 1e-9),
                "{ctx}: axis {} speed {} > {}",
                a.name,
                a.peak_velocity,
                a.max_velocity
            );
            assert!(
                a.peak_acceleration <= a.max_acceleration * (1.0 + 1e-9),
                "{ctx}: axis {} accel {} > {}",
                a.name,
                a.peak_acceleration,
                a.max_acceleration
            );
        }
        for j in &rep.joints {
            if let Some(max) = j.max_velocity {
                assert!(
                    j.peak_velocity <= max * (1.0 + 1e-6),
                    "{ctx}: joint {} speed {} > {max}",
                    j.name,
                    j.peak_velocity
                );
            }
        }
        // Every actuator ends exactly where the last target puts it.
        let last = cmds
            .iter()
            .rev()
            .find_map(|c| {
                if let Command::Move(mv) = c.item {
                    Some(mv.target)
                } else {
                    None
                }
            })
            .unwrap();
        for (a, ar) in m.actuators.iter().zip(&rep.actuators) {
            let joint = &m.joints[a.joint];
            let reference = ar.position as f64 / a.steps_per_unit.abs();
            let want = (joint.map.value(&last, reference) * a.steps_per_unit.abs()).round() as i64;
            assert_eq!(
                ar.position, want,
                "{ctx}: actuator {} ends at {} steps, want {want}",
                a.name, ar.position
            );
            assert!(ar.steps > 0, "{ctx}: actuator {} never moved", a.name);
        }
    }
}

/// Distance from `p` to the segment `a`–`b`.
fn dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (wx, wy) = (b[0] - a[0], b[1] - a[1]);
    let ww = wx * wx + wy * wy;
    let t = if ww > 0.0 {
        (((p[0] - a[0]) * wx + (p[1] - a[1]) * wy) / ww).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((p[0] - a[0] - wx * t).powi(2) + (p[1] - a[1] - wy * t).powi(2)).sqrt()
}

#[test]
fn plotter_draws_the_svg_within_one_step() {
    let (m, cmds, r) = run("plotter.toml", "drawing.svg");
    // The commanded pen-down polylines.
    let mut lines: Vec<([f64; 2], [f64; 2])> = vec![];
    let (mut pos, mut down) = ([m.start[0], m.start[1]], false);
    for c in &cmds {
        match c.item {
            Command::Tool { value, .. } => down = value > 0.0,
            Command::Move(mv) => {
                let next = [mv.target[0], mv.target[1]];
                if down {
                    lines.push((pos, next));
                }
                pos = next;
            }
            _ => {}
        }
    }
    let step = 1.0 / m.actuators[0].steps_per_unit.abs();
    // CoreXY: half a step on each motor is at most one step in x or y.
    let allowed = step + 1e-9;
    let mut checked = 0;
    for s in r.strokes.iter().filter(|s| s.tool_on) {
        for p in &s.points {
            let d = lines
                .iter()
                .map(|(a, b)| dist(*p, *a, *b))
                .fold(f64::INFINITY, f64::min);
            assert!(
                d <= allowed,
                "executed point {p:?} is {d} mm from the drawing (one step = {step} mm)"
            );
            checked += 1;
        }
    }
    assert!(checked > 500, "too few executed points checked: {checked}");
    // The rendered points are a thinned subset; the report checks every step
    // instant against the commanded path, which is the SVG's polylines.
    assert!(
        r.report.max_path_deviation_mm <= allowed,
        "deviation {} mm",
        r.report.max_path_deviation_mm
    );
    // And all of the drawing was drawn: executed pen-down length matches.
    let commanded: f64 = lines
        .iter()
        .map(|(a, b)| ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt())
        .sum();
    let drawn = r.report.tool_on_distance_mm;
    assert!(
        (drawn - commanded).abs() < 1e-6 * commanded,
        "drew {drawn} mm of {commanded} mm"
    );
}

#[test]
fn laser_gantry_motors_mirror_each_other() {
    let (_, _, r) = run("laser.toml", "laser-badge.gcode");
    let by = |n: &str| {
        r.report
            .actuators
            .iter()
            .find(|a| a.name == n)
            .unwrap()
            .clone()
    };
    let (l, rt) = (by("y_left"), by("y_right"));
    assert_eq!(l.steps, rt.steps);
    assert_eq!(
        l.position, rt.position,
        "positions count in joint direction, so mirrored motors agree"
    );
    assert!(
        r.report.tool_events >= 8,
        "laser power changes: {}",
        r.report.tool_events
    );
}

#[test]
fn gestalt_nodes_each_drive_their_own_axis() {
    let (m, _, r) = run("gestalt-3axis.toml", "gestalt-3d.gcode");
    assert_eq!(m.nodes.len(), 3);
    for a in &r.report.actuators {
        let node = m.nodes.iter().find(|n| n.name == a.node).unwrap();
        assert_eq!(node.actuators.len(), 1);
        assert!(a.steps > 0);
    }
}

#[test]
fn delta_prints_the_spiral_on_its_path() {
    let (m, _, r) = run("delta.toml", "delta-vase.gcode");
    // Every step instant's executed tool point (the carriages' forward
    // kinematics) against the commanded path: within two carriage steps,
    // where a wrong forward or inverse would be off by millimetres.
    let step = 1.0 / m.actuators[1].steps_per_unit.abs();
    assert!(
        r.report.max_path_deviation_mm <= 2.0 * step,
        "deviation {} mm (a step is {step} mm)",
        r.report.max_path_deviation_mm
    );
    // The spiral climbs: z moved under all three carriages together.
    let z = r.report.axes.iter().find(|a| a.name == "z").unwrap();
    assert!(z.peak_velocity > 0.0, "z never moved");
}

/// A node run as a board without a floating-point unit runs it
/// (`[nodes.NAME] fixed_time_us`, the Pico's 0.05 µs): the same steps, to
/// the same places, each within the tolerance of its exact time.
#[test]
fn a_node_in_fixed_point_time_takes_the_same_steps_within_its_tolerance() {
    for (machine, job, node) in [
        ("plotter.toml", "drawing.svg", "[nodes.ebb]"),
        (
            "printer.toml",
            "printer-vase-layers.gcode",
            "[nodes.mainboard]",
        ),
    ] {
        let (m, cmds, exact) = run(machine, job);
        let text = std::fs::read_to_string(root().join("examples").join(machine)).unwrap();
        assert!(text.contains(node), "{machine} has no {node}");
        let fixed_text = text.replace(node, &format!("{node}\nfixed_time_us = 0.05"));
        let fixed_m = Machine::parse(&fixed_text, &root().join("examples").join(machine)).unwrap();
        assert!(fixed_m.nodes.iter().all(|n| n.fixed_time_us == 0.05));
        let fixed = simulate(&fixed_m, job, &cmds, &mut |_, _| {}).unwrap();
        let (e, f) = (&exact.report, &fixed.report);
        for (a, b) in e.actuators.iter().zip(&f.actuators) {
            assert_eq!(
                (a.steps, a.position),
                (b.steps, b.position),
                "{machine}: {}",
                a.name
            );
        }
        // Within the tolerance, and not exact: fixed-point time is in use.
        assert!(
            f.max_step_time_error_us <= 0.05 + 1e-3 && f.max_step_time_error_us > 1e-4,
            "{machine}: {} µs",
            f.max_step_time_error_us
        );
        let fastest = m
            .actuators
            .iter()
            .filter_map(|a| a.max_step_hz)
            .fold(0.0, f64::max);
        assert!(
            f.max_deviation_steps <= 0.5 + fastest * 0.051e-6,
            "{machine}: {} steps",
            f.max_deviation_steps
        );
    }
}

/// The servo examples run their jobs with every servo within its targets
/// (two counts once a cruise has settled, ten in accelerations), each
/// ending within two counts of its last target;
/// `motet run` writes their plots beside the path and lists them.
#[test]
fn servo_examples_follow_and_plot() {
    for (machine, job) in [
        ("servo-mill.toml", "servo-pocket.gcode"),
        ("servo-printer.toml", "printer-vase-layers.gcode"),
    ] {
        let (m, cmds, r) = run(machine, job);
        let last = cmds
            .iter()
            .rev()
            .find_map(|c| match c.item {
                Command::Move(mv) => Some(mv.target),
                _ => None,
            })
            .unwrap();
        for (a, ar) in m.actuators.iter().zip(&r.report.actuators) {
            let Some(f) = &ar.following else { continue };
            assert!(f.max_accel_counts <= 10.0, "{machine}: {} {f:?}", a.name);
            assert!(
                f.max_settled_cruise_counts <= 2.0,
                "{machine}: {} {f:?}",
                a.name
            );
            assert!(f.rms_counts <= 1.0, "{machine}: {} {f:?}", a.name);
            let want = m.joints[a.joint].map.value(&last, 0.0) * a.steps_per_unit;
            assert!(
                (ar.position as f64 - want).abs() <= 2.0,
                "{machine}: {} at {} counts, want {want}",
                a.name,
                ar.position
            );
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "run",
            "examples/servo-mill.toml",
            "examples/jobs/servo-pocket.gcode",
            "--quiet",
            "--out",
        ])
        .arg(dir.path())
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    let plots: Vec<&str> = report["plots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap())
        .collect();
    assert_eq!(
        plots,
        [
            "servo-x_servo.png",
            "servo-y_servo.png",
            "sensor-x_accel.png",
            "servo-z_servo.png"
        ]
    );
    for p in plots {
        assert!(
            std::fs::metadata(dir.path().join(p)).unwrap().len() > 1000,
            "{p}"
        );
    }
}
