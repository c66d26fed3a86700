//! Machine-file errors in closed-loop tables (servos, their motors,
//! sensors, a node's loops): each names what is wrong and points at it.

use motet_host::Machine;
use std::path::Path;

/// A servo axis: line 8 is its chain, 9 its servo table, 10 a gain.
const BASE: &[&str] = &[
    r#"name = "m""#,
    r#"[axes.x]"#,
    r#"travel = [0, 100]"#,
    r#"max_velocity = 100"#,
    r#"max_acceleration = 1000"#,
    r#"[actuators.xm]"#,
    r#"joint = "x""#,
    r#"chain = [{ leadscrew = { lead = 5.0 } }, { encoder = { lines = 1000 } }]"#,
    r#"[actuators.xm.servo]"#,
    r#"kp = 0.002"#,
];

/// Lines replaced or added: (line, text).
type Edits = &'static [(usize, &'static str)];

/// (what, edits, expected line, message part)
const CASES: &[(&str, Edits, usize, &str)] = &[
    (
        "a gain out of range",
        &[(10, "kp = -1")],
        10,
        "actuator xm: servo kp must be from 0 to 1000",
    ),
    ("a NaN gain", &[(10, "kp = nan")], 10, "servo kp"),
    (
        "a loop rate out of range",
        &[(11, "rate_hz = 20")],
        11,
        "servo rate_hz must be from 100 to 50000",
    ),
    (
        "a following limit below a count",
        &[(11, "following_limit = 0.5")],
        11,
        "following_limit",
    ),
    (
        "an unknown key in servo",
        &[(11, "gain = 3")],
        11,
        "unknown field `gain`",
    ),
    (
        "a derivative filter above half the rate",
        &[(11, "rate_hz = 1000"), (12, "derivative_hz = 800")],
        12,
        "derivative_hz must be at most half of rate_hz",
    ),
    (
        "an encoder chain without a servo table",
        &[(9, "[actuators.xm.motor]"), (10, "load = 1")],
        8,
        "its chain ends in an encoder, a servo's: add [actuators.xm.servo]",
    ),
    (
        "a servo table on a stepper chain",
        &[(
            8,
            r#"chain = [{ leadscrew = { lead = 5.0 } }, { stepper = { step_angle = 1.8 } }]"#,
        )],
        9,
        "a servo's chain ends in an encoder",
    ),
    (
        "an encoder with no lines",
        &[(
            8,
            r#"chain = [{ leadscrew = { lead = 5.0 } }, { encoder = { lines = 0 } }]"#,
        )],
        8,
        "encoder lines must be from 1 to",
    ),
    (
        "an encoder before the end of the chain",
        &[(
            8,
            r#"chain = [{ leadscrew = { lead = 5.0 } }, { encoder = { lines = 100 } }, { microstep = 4 }]"#,
        )],
        8,
        "element 3 takes full steps but the chain gives it encoder counts",
    ),
    (
        "a motor value out of range",
        &[(11, "[actuators.xm.motor]"), (12, "resistance = 0")],
        12,
        "actuator xm: motor resistance must be from 0.001 to 1000",
    ),
    (
        "an unknown motor key",
        &[(11, "[actuators.xm.motor]"), (12, "colour = 1")],
        12,
        "unknown field `colour`",
    ),
    (
        "a sensor of an unknown kind",
        &[
            (11, "[sensors.acc]"),
            (12, r#"kind = "thermometer""#),
            (13, r#"actuator = "xm""#),
        ],
        12,
        "sensor acc: unknown kind `thermometer`",
    ),
    (
        "a sensor on an unknown actuator",
        &[
            (11, "[sensors.acc]"),
            (12, r#"kind = "accelerometer""#),
            (13, r#"actuator = "ym""#),
        ],
        13,
        "sensor acc: unknown actuator `ym`",
    ),
    (
        "a node listing an unknown sensor",
        &[
            (11, "[nodes.n]"),
            (12, r#"actuators = ["xm"]"#),
            (13, r#"sensors = ["acc"]"#),
        ],
        13,
        "node n: unknown sensor `acc`",
    ),
    (
        "a sample budget out of range",
        &[
            (11, "[nodes.n]"),
            (12, r#"actuators = ["xm"]"#),
            (13, "sample_budget = -5"),
        ],
        13,
        "node n: sample_budget must be from 0",
    ),
];

#[test]
fn closed_loop_mistakes_are_located() {
    for (what, edits, line, message) in CASES {
        let mut lines: Vec<String> = BASE.iter().map(|s| s.to_string()).collect();
        for (n, text) in edits.iter() {
            if *n <= lines.len() {
                lines[n - 1] = text.to_string();
            } else {
                lines.resize(n - 1, String::new());
                lines.push(text.to_string());
            }
        }
        let text = lines.join("\n");
        let e = Machine::parse(&text, Path::new("m.toml"))
            .err()
            .unwrap_or_else(|| panic!("{what}: accepted\n{text}"));
        assert_eq!(e.line, *line, "{what}: {e}\n{text}");
        assert!(e.message.contains(message), "{what}: {e}");
        assert!(
            e.to_string().starts_with(&format!("m.toml:{line}:")),
            "{what}: {e}"
        );
    }
}

#[test]
fn the_base_is_valid() {
    let m = Machine::parse(&BASE.join("\n"), Path::new("m.toml")).unwrap();
    let s = m.actuators[0].servo.as_ref().unwrap();
    assert_eq!(m.actuators[0].steps_per_unit, 800.0);
    assert_eq!((s.lines, s.gains.kp), (1000, 0.002));
}
