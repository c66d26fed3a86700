//! The example machines in `examples/` load, and what they describe comes out
//! as intended: steps per unit, kinematics, joints, node split, start, limits.

use motet_host::Machine;
use motet_planner::ToolKind;
use motet_trajectory::kinematics::{Delta, FiveBar, Scara, NO_AXIS};
use motet_trajectory::{JointMap, KinematicsKind, ProfileKind, MAX_AXES};
use std::f64::consts::PI;
use std::path::PathBuf;

const INF: f64 = f64::INFINITY;

fn examples_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn load(file: &str) -> Machine {
    let path = examples_dir().join(file);
    Machine::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

struct Expect {
    file: &'static str,
    kinematics: KinematicsKind,
    profile: ProfileKind,
    /// (name, travel, path, max_jerk)
    axes: &'static [(&'static str, [f64; 2], bool, Option<f64>)],
    joints: &'static [&'static str],
    /// (actuator, joint, steps per joint unit)
    actuators: &'static [(&'static str, &'static str, f64)],
    /// (tool, kind, settle, motion stops for it)
    tools: &'static [(&'static str, ToolKind, f64, bool)],
    /// (node, actuators in channel order, tools in output order)
    nodes: &'static [(
        &'static str,
        &'static [&'static str],
        &'static [&'static str],
    )],
    /// Start, by axis in index order.
    start: &'static [f64],
    /// (joint, max velocity, max acceleration) for joints with limits of their own.
    joint_limits: &'static [(&'static str, f64, f64)],
    draw_feed: f64,
    tolerance: f64,
    junction_deviation: f64,
    min_radius: f64,
}

const GT2_20: f64 = 3200.0 / 40.0; // 20 teeth × 2 mm, 1.8°, 1/16
const EXAMPLES: &[Expect] = &[
    Expect {
        file: "delta.toml",
        kinematics: KinematicsKind::Delta(Delta {
            radius: 105.0,
            arm: 215.0,
        }),
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [-85.0, 85.0], true, None),
            ("y", [-85.0, 85.0], true, None),
            ("z", [0.0, 200.0], true, None),
            ("e", [-INF, INF], false, None),
        ],
        joints: &["a", "b", "c", "e"],
        actuators: &[
            ("e_motor", "e", -3200.0 / (PI * 11.0)),
            ("tower_a", "a", GT2_20),
            ("tower_b", "b", GT2_20),
            ("tower_c", "c", GT2_20),
        ],
        tools: &[],
        nodes: &[("board", &["tower_a", "tower_b", "tower_c", "e_motor"], &[])],
        start: &[0.0, 0.0, 0.0, 0.0],
        joint_limits: &[
            ("a", 300.0, 4000.0),
            ("b", 300.0, 4000.0),
            ("c", 300.0, 4000.0),
        ],
        // Half the slowest path axis (z, 50 mm/s).
        draw_feed: 25.0,
        tolerance: 0.01,
        junction_deviation: 0.05,
        min_radius: 1.0,
    },
    Expect {
        file: "scara.toml",
        kinematics: KinematicsKind::Scara(Scara {
            l1: 150.0,
            l2: 120.0,
            elbow: 1.0,
        }),
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [-270.0, 270.0], true, None),
            ("y", [-270.0, 270.0], true, None),
        ],
        joints: &["shoulder", "elbow"],
        actuators: &[
            ("elbow_motor", "elbow", 5.0 * 3200.0 / 360.0),
            ("shoulder_motor", "shoulder", 5.0 * 3200.0 / 360.0),
        ],
        tools: &[("pen", ToolKind::Pen, 0.1, true)],
        nodes: &[("arm", &["shoulder_motor", "elbow_motor"], &["pen"])],
        start: &[150.0, 80.0],
        joint_limits: &[("shoulder", 120.0, 1200.0), ("elbow", 120.0, 1200.0)],
        draw_feed: 40.0,
        tolerance: 0.01,
        junction_deviation: 0.02,
        min_radius: 1.0,
    },
    Expect {
        file: "fivebar.toml",
        kinematics: KinematicsKind::FiveBar(FiveBar {
            s: 60.0,
            l1: 80.0,
            l2: 80.0,
            l3: 120.0,
            l4: 120.0,
            ext: 0.0,
        }),
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [-100.0, 160.0], true, None),
            ("y", [0.0, 220.0], true, None),
        ],
        joints: &["theta1", "theta2"],
        actuators: &[
            ("left_motor", "theta1", 4.0 * 3200.0 / 360.0),
            ("right_motor", "theta2", 4.0 * 3200.0 / 360.0),
        ],
        tools: &[("pen", ToolKind::Pen, 0.1, true)],
        nodes: &[("arm", &["left_motor", "right_motor"], &["pen"])],
        start: &[30.0, 130.0],
        joint_limits: &[("theta1", 150.0, 1500.0), ("theta2", 150.0, 1500.0)],
        draw_feed: 30.0,
        tolerance: 0.01,
        junction_deviation: 0.02,
        min_radius: 1.0,
    },
    Expect {
        file: "replicator.toml",
        kinematics: KinematicsKind::CARTESIAN,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [0.0, 285.0], true, None),
            ("y", [0.0, 152.0], true, None),
            ("z", [0.0, 155.0], true, None),
            ("e", [-INF, INF], false, None),
        ],
        joints: &["x", "y", "z", "e"],
        // The Replicator 2's: 18-tooth GT2 pulleys, an 8 mm lead screw, a
        // 10.58 mm drive gear (96.2752 steps/mm).
        actuators: &[
            ("a_motor", "e", 3200.0 / (PI * 10.58)),
            ("x_motor", "x", 3200.0 / 36.0),
            ("y_motor", "y", 3200.0 / 36.0),
            ("z_motor", "z", 400.0),
        ],
        tools: &[],
        nodes: &[("bot", &["x_motor", "y_motor", "z_motor", "a_motor"], &[])],
        start: &[0.0, 0.0, 0.0, 0.0],
        joint_limits: &[],
        // Half the slowest path axis (z, 19.5 mm/s).
        draw_feed: 9.75,
        tolerance: 0.01,
        junction_deviation: 0.05,
        min_radius: 1.0,
    },
    Expect {
        file: "printer.toml",
        kinematics: KinematicsKind::CARTESIAN,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [0.0, 220.0], true, None),
            ("y", [0.0, 220.0], true, None),
            ("z", [0.0, 250.0], true, None),
            ("e", [-INF, INF], false, None),
        ],
        joints: &["x", "y", "z", "e"],
        actuators: &[
            ("e_motor", "e", -3200.0 / (PI * 11.0)),
            ("x_motor", "x", GT2_20),
            ("y_motor", "y", GT2_20),
            ("z_motor", "z", 400.0),
        ],
        tools: &[],
        nodes: &[(
            "mainboard",
            &["x_motor", "y_motor", "z_motor", "e_motor"],
            &[],
        )],
        start: &[0.0, 0.0, 0.0, 0.0],
        joint_limits: &[],
        // Half the slowest path axis (z, 15 mm/s); e does not count.
        draw_feed: 7.5,
        tolerance: 0.01,
        junction_deviation: 0.05,
        min_radius: 1.0,
    },
    Expect {
        file: "printer-heated.toml",
        kinematics: KinematicsKind::CARTESIAN,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [0.0, 220.0], true, None),
            ("y", [0.0, 220.0], true, None),
            ("z", [0.0, 250.0], true, None),
            ("e", [-INF, INF], false, None),
        ],
        joints: &["x", "y", "z", "e"],
        actuators: &[
            ("e_motor", "e", -3200.0 / (PI * 11.0)),
            ("x_motor", "x", GT2_20),
            ("y_motor", "y", GT2_20),
            ("z_motor", "z", 400.0),
        ],
        tools: &[],
        nodes: &[(
            "mainboard",
            &["x_motor", "y_motor", "z_motor", "e_motor"],
            &[],
        )],
        start: &[0.0, 0.0, 0.0, 0.0],
        joint_limits: &[],
        // Half the slowest path axis (z, 15 mm/s); e does not count.
        draw_feed: 7.5,
        tolerance: 0.01,
        junction_deviation: 0.05,
        min_radius: 1.0,
    },
    Expect {
        file: "plotter.toml",
        kinematics: KinematicsKind::COREXY,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [0.0, 300.0], true, None),
            ("y", [0.0, 218.0], true, None),
        ],
        joints: &["a", "b"],
        actuators: &[
            ("motor_a", "a", 3200.0 / (PI * 9.0)),
            ("motor_b", "b", 3200.0 / (PI * 9.0)),
        ],
        tools: &[("pen", ToolKind::Pen, 0.12, true)],
        nodes: &[("ebb", &["motor_a", "motor_b"], &["pen"])],
        start: &[0.0, 0.0],
        joint_limits: &[("a", 350.0, 3000.0), ("b", 350.0, 3000.0)],
        draw_feed: 60.0,
        tolerance: 0.01,
        junction_deviation: 0.02,
        min_radius: 1.0,
    },
    Expect {
        file: "laser.toml",
        kinematics: KinematicsKind::CARTESIAN,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [0.0, 400.0], true, None),
            ("y", [0.0, 300.0], true, None),
        ],
        joints: &["x", "y"],
        actuators: &[
            ("x_motor", "x", 2.0 * GT2_20),
            ("y_left", "y", 2.0 * GT2_20),
            ("y_right", "y", -2.0 * GT2_20),
        ],
        tools: &[("laser", ToolKind::Laser, 0.0, false)],
        nodes: &[("gantry", &["x_motor", "y_left", "y_right"], &["laser"])],
        start: &[0.0, 0.0],
        joint_limits: &[],
        draw_feed: 200.0,
        tolerance: 0.005,
        junction_deviation: 0.01,
        min_radius: 1.0,
    },
    Expect {
        file: "clay-printer.toml",
        kinematics: KinematicsKind::POLAR,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [-150.0, 150.0], true, None),
            ("y", [-150.0, 150.0], true, None),
            ("z", [0.0, 300.0], true, None),
            ("e", [-INF, INF], false, None),
        ],
        joints: &["r", "theta", "z", "e"],
        actuators: &[
            ("arm", "r", 3200.0 / 8.0),
            // 10 mm lead, 3:1 gear, 1.8°, 1/8.
            ("auger", "e", 3.0 * 1600.0 / 10.0),
            ("lift", "z", 1600.0 / 2.0),
            // Steps per degree of table.
            ("turntable", "theta", 6.0 * 3200.0 / 360.0),
        ],
        tools: &[],
        nodes: &[
            ("table", &["turntable", "arm"], &[]),
            ("tower", &["lift", "auger"], &[]),
        ],
        start: &[100.0, 0.0, 0.0, 0.0],
        joint_limits: &[("r", 60.0, 600.0), ("theta", 120.0, 600.0)],
        draw_feed: 5.0,
        tolerance: 0.02,
        junction_deviation: 0.05,
        min_radius: 2.0,
    },
    Expect {
        file: "gestalt-3axis.toml",
        kinematics: KinematicsKind::CARTESIAN,
        profile: ProfileKind::SCurve,
        axes: &[
            ("x", [0.0, 150.0], true, Some(8000.0)),
            ("y", [0.0, 150.0], true, Some(8000.0)),
            ("z", [-20.0, 30.0], true, Some(4000.0)),
        ],
        joints: &["x", "y", "z"],
        actuators: &[
            ("x_stage", "x", 1600.0 / 6.35),
            ("y_stage", "y", 1600.0 / 6.35),
            ("z_stage", "z", -1600.0 / 6.35),
        ],
        tools: &[("spindle", ToolKind::Spindle, 0.5, true)],
        nodes: &[
            ("x_node", &["x_stage"], &[]),
            ("y_node", &["y_stage"], &[]),
            ("z_node", &["z_stage"], &["spindle"]),
        ],
        start: &[0.0, 0.0, 0.0],
        joint_limits: &[],
        draw_feed: 7.5,
        tolerance: 0.005,
        junction_deviation: 0.02,
        min_radius: 1.0,
    },
    Expect {
        file: "servo-mill.toml",
        kinematics: KinematicsKind::CARTESIAN,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [0.0, 200.0], true, None),
            ("y", [0.0, 150.0], true, None),
            ("z", [-60.0, 0.0], true, None),
        ],
        joints: &["x", "y", "z"],
        // Encoder counts: 1000 lines ×4 a turn of a 5 mm screw.
        actuators: &[
            ("x_servo", "x", 800.0),
            ("y_servo", "y", 800.0),
            ("z_servo", "z", 800.0),
        ],
        tools: &[("spindle", ToolKind::Spindle, 0.5, true)],
        nodes: &[
            ("xy", &["x_servo", "y_servo"], &[]),
            ("z", &["z_servo"], &["spindle"]),
        ],
        start: &[0.0, 0.0, 0.0],
        joint_limits: &[],
        draw_feed: 25.0,
        tolerance: 0.005,
        junction_deviation: 0.002,
        min_radius: 1.0,
    },
    Expect {
        file: "servo-printer.toml",
        kinematics: KinematicsKind::CARTESIAN,
        profile: ProfileKind::Trapezoid,
        axes: &[
            ("x", [0.0, 220.0], true, None),
            ("y", [0.0, 220.0], true, None),
            ("z", [0.0, 250.0], true, None),
            ("e", [-INF, INF], false, None),
        ],
        joints: &["x", "y", "z", "e"],
        actuators: &[
            ("e_motor", "e", -3200.0 / (PI * 11.0)),
            ("x_motor", "x", 100.0),
            ("y_motor", "y", 100.0),
            ("z_motor", "z", 400.0),
        ],
        tools: &[],
        nodes: &[(
            "mainboard",
            &["x_motor", "y_motor", "z_motor", "e_motor"],
            &[],
        )],
        start: &[0.0, 0.0, 0.0, 0.0],
        joint_limits: &[],
        draw_feed: 7.5,
        tolerance: 0.01,
        junction_deviation: 0.05,
        min_radius: 1.0,
    },
];

/// The servo examples' loops and sensors as their files give them.
#[test]
fn servo_examples_have_their_loops() {
    let m = load("servo-mill.toml");
    for a in &m.actuators {
        let s = a.servo.as_ref().unwrap_or_else(|| panic!("{}", a.name));
        assert_eq!(
            (s.lines, s.rate_hz, s.following_limit),
            (1000, 10_000.0, 40.0)
        );
        assert!(
            s.gains.kp > 0.0 && s.gains.kv > 0.0,
            "{}: {:?}",
            a.name,
            s.gains
        );
    }
    let z = &m.actuators[2].servo.as_ref().unwrap().motor;
    assert_eq!((z.load, z.load_force), (1.5, 14.7));
    assert_eq!(m.sensors.len(), 1);
    assert_eq!(m.sensors[0].actuator, 0);
    assert_eq!(m.nodes[0].sensors, vec![0]);
    assert_eq!(m.nodes[0].sample_budget, 400.0);
    let p = load("servo-printer.toml");
    let servos: Vec<_> = p
        .actuators
        .iter()
        .filter(|a| a.servo.is_some())
        .map(|a| a.name.as_str())
        .collect();
    assert_eq!(servos, ["x_motor", "y_motor"]);
}

fn close(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
}

/// Checks one example against its expectations; returns the differences.
fn check(e: &Expect) -> Vec<String> {
    let m = load(e.file);
    let mut bad = Vec::new();
    let mut want = |ok: bool, what: String| {
        if !ok {
            bad.push(format!("{}: {what}", e.file));
        }
    };
    want(
        m.kinematics == e.kinematics,
        format!("kinematics {:?}", m.kinematics),
    );
    want(m.profile == e.profile, format!("profile {:?}", m.profile));
    want(
        m.file == examples_dir().join(e.file),
        format!("file {}", m.file.display()),
    );
    want(!m.name.is_empty(), "empty name".into());

    // Axes, in conventional order.
    let names: Vec<&str> = m.axes.iter().map(|a| a.name.as_str()).collect();
    let want_names: Vec<&str> = e.axes.iter().map(|a| a.0).collect();
    want(names == want_names, format!("axes {names:?}"));
    for (a, (name, travel, path, jerk)) in m.axes.iter().zip(e.axes) {
        want(
            a.travel == *travel,
            format!("axis {name}: travel {:?}", a.travel),
        );
        want(a.path == *path, format!("axis {name}: path {}", a.path));
        want(
            a.max_jerk == *jerk,
            format!("axis {name}: max_jerk {:?}", a.max_jerk),
        );
        want(
            m.axis(name) == names.iter().position(|n| n == name),
            format!("axis({name})"),
        );
    }
    want(m.axis("w").is_none(), "axis(w) exists".into());

    // Joints, and how they map machine axes.
    let joints: Vec<&str> = m.joints.iter().map(|j| j.name.as_str()).collect();
    want(joints == e.joints, format!("joints {joints:?}"));
    match (m.kinematics, m.kinematic_axes.map(|[x, y, _]| (x, y))) {
        (KinematicsKind::Cartesian(_), xy) => {
            want(xy.is_none(), format!("cartesian xy {xy:?}"));
            for (i, j) in m.joints.iter().enumerate() {
                want(
                    j.map == JointMap::axis(i),
                    format!("joint {}: map {:?}", j.name, j.map),
                );
            }
        }
        (KinematicsKind::CoreXY(_), Some((0, 1))) => {
            let mut a = [0.0; MAX_AXES];
            let mut b = [0.0; MAX_AXES];
            (a[0], a[1], b[0], b[1]) = (1.0, 1.0, 1.0, -1.0);
            want(
                m.joints[0].map == JointMap::Linear { coeffs: a },
                format!("corexy a {:?}", m.joints[0].map),
            );
            want(
                m.joints[1].map == JointMap::Linear { coeffs: b },
                format!("corexy b {:?}", m.joints[1].map),
            );
        }
        (KinematicsKind::Polar(_), Some((0, 1))) => {
            want(
                m.joints[0].map == JointMap::polar_radius(0, 1),
                format!("polar r {:?}", m.joints[0].map),
            );
            want(
                m.joints[1].map == JointMap::polar_angle(0, 1),
                format!("polar theta {:?}", m.joints[1].map),
            );
            want(m.joints[2].map == JointMap::axis(2), "polar z".into());
            want(m.joints[3].map == JointMap::axis(3), "polar e".into());
        }
        (k @ (KinematicsKind::Scara(_) | KinematicsKind::FiveBar(_)), Some((0, 1))) => {
            for j in 0..2 {
                want(
                    m.joints[j].map == k.joint_map(j, [0, 1, NO_AXIS.into()]),
                    format!("{} joint {j}: {:?}", k.name(), m.joints[j].map),
                );
            }
        }
        (k @ KinematicsKind::Delta(_), Some((0, 1))) => {
            for j in 0..3 {
                want(
                    m.joints[j].map == k.joint_map(j, [0, 1, 2]),
                    format!("delta joint {j}: {:?}", m.joints[j].map),
                );
            }
            want(m.joints[3].map == JointMap::axis(3), "delta e".into());
        }
        (k, xy) => want(false, format!("{k:?} with xy {xy:?}")),
    }

    // Actuators (alphabetical, as in the file's tables) and steps per unit.
    let actuators: Vec<&str> = m.actuators.iter().map(|a| a.name.as_str()).collect();
    let want_actuators: Vec<&str> = e.actuators.iter().map(|a| a.0).collect();
    want(
        actuators == want_actuators,
        format!("actuators {actuators:?}"),
    );
    for (a, (name, joint, steps)) in m.actuators.iter().zip(e.actuators) {
        want(
            m.joints[a.joint].name == *joint,
            format!("actuator {name}: joint {}", m.joints[a.joint].name),
        );
        want(
            close(a.steps_per_unit, *steps),
            format!(
                "actuator {name}: {} steps/unit, want {steps}",
                a.steps_per_unit
            ),
        );
    }

    // Tools.
    let tools: Vec<(&str, ToolKind, f64)> = m
        .tools
        .iter()
        .map(|t| (t.name.as_str(), t.kind, t.settle))
        .collect();
    let want_tools: Vec<(&str, ToolKind, f64)> = e.tools.iter().map(|t| (t.0, t.1, t.2)).collect();
    want(tools == want_tools, format!("tools {tools:?}"));
    want(m.tools.iter().all(|t| t.on_value == 1.0), "on_value".into());

    // Nodes, each with its actuators in channel order.
    let nodes: Vec<(&str, Vec<&str>, Vec<&str>)> = m
        .nodes
        .iter()
        .map(|n| {
            (
                n.name.as_str(),
                n.actuators
                    .iter()
                    .map(|&i| m.actuators[i].name.as_str())
                    .collect(),
                n.tools.iter().map(|&i| m.tools[i].name.as_str()).collect(),
            )
        })
        .collect();
    let want_nodes: Vec<(&str, Vec<&str>, Vec<&str>)> = e
        .nodes
        .iter()
        .map(|(n, a, t)| (*n, a.to_vec(), t.to_vec()))
        .collect();
    want(nodes == want_nodes, format!("nodes {nodes:?}"));
    want(
        m.nodes.iter().all(|n| n.queue == 64 && n.frame_us == 40.0),
        "node defaults".into(),
    );

    // Start: named values, 0 elsewhere (all of these travels include 0).
    let mut start = [0.0; MAX_AXES];
    start[..e.start.len()].copy_from_slice(e.start);
    want(m.start == start, format!("start {:?}", m.start));

    want(
        close(m.draw_feed, e.draw_feed),
        format!("draw_feed {}", m.draw_feed),
    );
    want(
        m.tolerance == e.tolerance,
        format!("tolerance {}", m.tolerance),
    );
    want(
        m.junction_deviation == e.junction_deviation,
        format!("junction_deviation {}", m.junction_deviation),
    );
    want(
        m.min_radius == e.min_radius,
        format!("min_radius {}", m.min_radius),
    );
    want(m.lookahead == 4096, format!("lookahead {}", m.lookahead));

    // The planner's limits.
    let l = m.limits();
    want(l.axes.len() == m.axes.len(), "limits: axis count".into());
    for (la, a) in l.axes.iter().zip(&m.axes) {
        want(
            la.max_velocity == a.max_velocity
                && la.max_acceleration == a.max_acceleration
                && la.max_jerk == a.max_jerk
                && la.path == a.path,
            format!("limits: axis {}", a.name),
        );
    }
    // Declared joint limits, and for every stepped joint a velocity no
    // faster than its motors' top step rate.
    let mut want_joints: Vec<(&str, f64, f64)> = Vec::new();
    for (k, j) in m.joints.iter().enumerate() {
        let spu = m
            .actuators
            .iter()
            .filter(|a| a.joint == k)
            .map(|a| a.steps_per_unit.abs())
            .fold(0.0, f64::max);
        let cap = if spu > 0.0 {
            motet_wire::MAX_STEP_RATE / spu
        } else {
            f64::INFINITY
        };
        match e.joint_limits.iter().find(|d| d.0 == j.name) {
            Some(&(name, v, acc)) => want_joints.push((name, v.min(cap), acc)),
            None if cap.is_finite() => want_joints.push((&j.name, cap, f64::INFINITY)),
            None => {}
        }
    }
    want(
        l.joints.len() == want_joints.len(),
        format!("limits: {} joint limits", l.joints.len()),
    );
    for (lj, (joint, v, acc)) in l.joints.iter().zip(&want_joints) {
        let j = m.joints.iter().find(|j| j.name == *joint).expect("joint");
        want(
            lj.map == j.map && lj.max_velocity == *v && lj.max_acceleration == *acc,
            format!("limits: joint {joint} {lj:?}"),
        );
    }
    want(
        l.junction_deviation == e.junction_deviation && l.profile == e.profile,
        "limits: motion".into(),
    );
    want(l.lookahead == m.lookahead, "limits: lookahead".into());
    let timing: Vec<(f64, bool)> = l.tools.iter().map(|t| (t.settle, t.stop)).collect();
    let want_timing: Vec<(f64, bool)> = e.tools.iter().map(|t| (t.2, t.3)).collect();
    want(timing == want_timing, format!("limits: tools {timing:?}"));

    // What job sources see.
    let t = m.job_target();
    let axes: Vec<(&str, [f64; 2], bool)> = t
        .axes
        .iter()
        .map(|a| (a.name.as_str(), a.travel, a.path))
        .collect();
    let want_axes: Vec<(&str, [f64; 2], bool)> = e.axes.iter().map(|a| (a.0, a.1, a.2)).collect();
    want(axes == want_axes, format!("job target: axes {axes:?}"));
    let tools: Vec<(&str, ToolKind)> = t.tools.iter().map(|x| (x.name.as_str(), x.kind)).collect();
    let want_tools: Vec<(&str, ToolKind)> = e.tools.iter().map(|x| (x.0, x.1)).collect();
    want(tools == want_tools, format!("job target: tools {tools:?}"));
    want(t.start == m.start, "job target: start".into());
    want(
        t.tolerance == e.tolerance && close(t.draw_feed, e.draw_feed),
        "job target: tolerance, draw_feed".into(),
    );
    want(
        t.primary_tool() == if e.tools.is_empty() { None } else { Some(0) },
        "job target: primary tool".into(),
    );
    for (i, a) in e.axes.iter().enumerate() {
        want(
            t.axis(&a.0.to_uppercase()) == Some(i),
            format!("job target: axis {}", a.0),
        );
    }
    bad
}

#[test]
fn every_example_matches_its_expectations() {
    let bad: Vec<String> = EXAMPLES.iter().flat_map(check).collect();
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn every_example_file_loads_and_is_covered() {
    let mut files: Vec<String> = std::fs::read_dir(examples_dir())
        .expect("examples directory")
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "{files:?}");
    for f in &files {
        let m = load(f);
        assert!(!m.nodes.is_empty(), "{f}: no nodes");
        // Every actuator is on exactly one node.
        let mut on = vec![0; m.actuators.len()];
        for n in &m.nodes {
            for &a in &n.actuators {
                on[a] += 1;
            }
        }
        assert!(on.iter().all(|&k| k == 1), "{f}: {on:?}");
        // Every joint is driven.
        for (j, joint) in m.joints.iter().enumerate() {
            assert!(
                m.actuators.iter().any(|a| a.joint == j),
                "{f}: joint {} undriven",
                joint.name
            );
        }
        assert!(
            EXAMPLES.iter().any(|e| e.file == f),
            "{f} has no expectations in EXAMPLES"
        );
    }
}

#[test]
fn parse_of_the_text_equals_load() {
    for e in EXAMPLES {
        let path = examples_dir().join(e.file);
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(
            Machine::parse(&text, &path).unwrap(),
            load(e.file),
            "{}",
            e.file
        );
    }
}

#[test]
fn start_defaults_to_the_lower_travel_end_when_zero_is_outside() {
    let text = r#"
name = "offset"
[axes.x]
travel = [10, 100]
max_velocity = 10
max_acceleration = 100
[axes.y]
travel = [-50, -5]
max_velocity = 10
max_acceleration = 100
[axes.z]
travel = [-5, 5]
max_velocity = 10
max_acceleration = 100
[actuators.x]
joint = "x"
chain = [{ leadscrew = { lead = 2 } }, { stepper = { step_angle = 0.9 } }]
[actuators.y]
joint = "y"
chain = [{ leadscrew = { lead = 2 } }, { stepper = { step_angle = 0.9 } }]
[actuators.z]
joint = "z"
chain = [{ leadscrew = { lead = 2 } }, { stepper = { step_angle = 0.9 } }]
"#;
    let m = Machine::parse(text, std::path::Path::new("offset.toml")).unwrap();
    assert_eq!(m.start[..3], [10.0, -50.0, 0.0]);
    // No [nodes]: one node drives everything.
    assert_eq!(m.nodes.len(), 1);
    assert_eq!(m.nodes[0].name, "main");
    assert_eq!(m.nodes[0].actuators, vec![0, 1, 2]);
    assert!(m.actuators.iter().all(|a| close(a.steps_per_unit, 200.0)));
}
