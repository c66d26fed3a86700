//! Extreme values end to end: every value out of its range (docs/ranges.md)
//! is refused by `motet check` and `motet run` with its place (file:line:column,
//! or the flag), before anything runs; coordinates within half a step of the
//! travel are clamped and counted; reports never hold NaN or infinity.

use std::path::Path;
use tempfile::TempDir;

mod common;
use common::{motet, root};

fn scratch(name: &str) -> TempDir {
    common::scratch("extreme", name)
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

fn plotter() -> String {
    std::fs::read_to_string(root().join(PLOTTER)).unwrap()
}

/// The plotter's machine file with one text replaced.
fn plotter_with(from: &str, to: &str) -> String {
    let text = plotter();
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

const PLOTTER: &str = "examples/plotter.toml";
const MOVES: &str = "G21\nG90\nG1 X10 Y10 F600\nM3\nG1 X20 Y20\nM5\n";

#[test]
fn values_out_of_range_are_refused_where_they_are() {
    let tmp = scratch("refused");
    let dir = tmp.path();
    let d = dir.display().to_string();
    let days = "G21\nG1 X1 F600\n".to_string() + &"G4 S86400\n".repeat(31);
    // (machine file name and text, job name and text, extra flags, expected
    // part of the error)
    type Case = (
        &'static str,
        String,
        &'static str,
        String,
        &'static [&'static str],
        String,
    );
    let cases: Vec<Case> = vec![
        (
            "plotter.toml",
            plotter(),
            "dwell.gcode",
            "G21\nG90\nG1 X10 Y10 F600\nG4 S20000000000000\nG1 X20 Y20\n".into(),
            &[],
            format!("{d}/dwell.gcode:4:4: G4 S (dwell) must be from 0 to 86400 s, got 2e13"),
        ),
        (
            "settle.toml",
            plotter_with("settle = 0.12", "settle = 1e10"),
            "pen.gcode",
            MOVES.into(),
            &[],
            format!("{d}/settle.toml:39:10: tool pen: settle must be from 0 to 3600 s, got 1e10"),
        ),
        (
            "velocity.toml",
            plotter_with("max_velocity = 250", "max_velocity = 1e-300"),
            "pen.gcode",
            MOVES.into(),
            &[],
            format!(
                "{d}/velocity.toml:16:16: axis x: max_velocity must be from 0.001 to 100000 units/s, got 1e-300"
            ),
        ),
        (
            "travel.toml",
            plotter_with("travel = [0, 300]", "travel = [-1e308, 1e308]"),
            "pen.gcode",
            MOVES.into(),
            &[],
            format!(
                "{d}/travel.toml:15:10: axis x: travel must be from -1000000 to 1000000 mm, got -1e308"
            ),
        ),
        (
            "plotter.toml",
            plotter(),
            "month.gcode",
            days,
            &[],
            format!("{d}/month.gcode:32:1: the job would last at least 721 h by here; motet plans at most 720 h (30 days)"),
        ),
        (
            "plotter.toml",
            plotter(),
            "pen.gcode",
            MOVES.into(),
            &["--nodes", "spawn", "--lead-ms", "1e12"],
            "invalid value '1e12' for '--lead-ms <LEAD_MS>': must be from 1 to 60000 ms".into(),
        ),
        (
            "plotter.toml",
            plotter(),
            "pen.gcode",
            MOVES.into(),
            &["--nodes", "spawn", "--time-scale", "0"],
            "invalid value '0' for '--time-scale <TIME_SCALE>': must be from 0.01 to 1000".into(),
        ),
        (
            "plotter.toml",
            plotter(),
            "pen.gcode",
            MOVES.into(),
            &["--nodes", "spawn", "--sync-ms", "NaN"],
            "invalid value 'NaN' for '--sync-ms <SYNC_MS>': must be from 1 to 60000 ms".into(),
        ),
    ];
    for (mname, mtext, jname, jtext, flags, want) in &cases {
        let m = write(dir, mname, mtext);
        let j = write(dir, jname, jtext);
        let out = dir.join(format!("out-{jname}"));
        let mut commands = vec![vec!["run", &m, &j, "--out", out.to_str().unwrap()]];
        commands[0].extend(flags.iter());
        if flags.is_empty() {
            commands.push(vec!["check", &m, &j]);
        }
        for args in commands {
            let (ok, _, stderr) = motet(&args);
            assert!(!ok, "{args:?} should fail");
            assert!(
                stderr.contains(want.as_str()),
                "{args:?}: want {want}\ngot: {stderr}"
            );
            assert!(!stderr.contains("panicked"), "{stderr}");
            assert!(
                !out.exists(),
                "{args:?}: nothing is written for a refused job"
            );
        }
    }
}

#[test]
fn flags_out_of_range_are_refused_by_name() {
    for (args, want) in [
        (
            vec!["node", "--sim", "--ppm", "1e9"],
            "'--ppm <PPM>': must be from -10000 to 10000 ppm",
        ),
        (
            vec!["node", "--sim", "--idle-exit", "1e9"],
            "'--idle-exit <IDLE_EXIT>': must be from 0 to 3600 s",
        ),
        (
            vec![
                "nodes",
                "scan",
                "--link",
                "udp:127.0.0.1:1",
                "--wait",
                "1e9",
            ],
            "'--wait <WAIT>': must be from 0 to 3600 s",
        ),
        (
            vec!["bench", "--repeat", "0"],
            "'--repeat <REPEAT>': must be from 1 to 1000",
        ),
        (
            vec!["bench-net", "--faults", "2"],
            "'--faults <FAULTS>': must be from 0 to 1",
        ),
        (
            vec!["bench-net", "--jitter-us", "99999999999"],
            "'--jitter-us <JITTER_US>'",
        ),
        (
            vec!["bench-wire", PLOTTER, "x.gcode", "--microsteps", "0"],
            "'--microsteps <MICROSTEPS>': must be from 1 to 256",
        ),
        (
            vec![
                "dance",
                PLOTTER,
                "g.toml",
                "--pendulums",
                "--seconds",
                "1e9",
            ],
            "'--seconds <SECONDS>': must be from 0 to 3600 s",
        ),
    ] {
        let (ok, _, stderr) = motet(&args);
        assert!(!ok, "{args:?} should fail");
        assert!(
            stderr.contains(want),
            "{args:?}: want {want}\ngot: {stderr}"
        );
    }
}

/// Every number in a report is finite: serde_json writes NaN and infinity as
/// null, so a report holds no null.
fn assert_finite(v: &serde_json::Value, at: &str) {
    match v {
        serde_json::Value::Null => panic!("{at} is null (NaN or infinity)"),
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                assert_finite(x, &format!("{at}[{i}]"));
            }
        }
        serde_json::Value::Object(o) => {
            for (k, x) in o {
                assert_finite(x, &format!("{at}.{k}"));
            }
        }
        _ => {}
    }
}

#[test]
fn the_slowest_machine_reports_finite_figures() {
    // The lowest velocity allowed, the longest dwell allowed, a pen that
    // settles for an hour: long, but every figure a number.
    let tmp = scratch("slow");
    let dir = tmp.path();
    let m = write(
        dir,
        "slow.toml",
        &plotter_with("max_velocity = 250", "max_velocity = 0.001").replacen(
            "settle = 0.12",
            "settle = 3600",
            1,
        ),
    );
    let j = write(dir, "slow.gcode", "G21\nG1 X0.01 F600\nM3\nG4 S86400\nM5\n");
    let out = dir.join("out");
    let (ok, stdout, stderr) = motet(&["run", &m, &j, "--out", out.to_str().unwrap()]);
    assert!(ok, "{stderr}");
    for bad in ["NaN", "inf", "18446744073709551615"] {
        assert!(!stdout.contains(bad), "{bad} in the summary:\n{stdout}");
    }
    assert!(
        stdout.contains("slow on AxiDraw-like pen plotter: 26h00m"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_finite(&report, "report");
    let d = report["duration_s"].as_f64().unwrap();
    assert!((93_600.0..93_700.0).contains(&d), "{d}");
}

#[test]
fn strokes_on_the_sheet_edge_are_drawn_and_small_overshoots_clamped() {
    let tmp = scratch("edges");
    let dir = tmp.path();
    // A millimetre page whose f32 transform put its bottom edge at
    // y = -0.00001 mm; an icon (24 px) whose path starts 0.0117 px (0.0031 mm)
    // left of its box; and one 0.02 px (0.0053 mm) left of it, more than half
    // a step (0.0044 mm) of the plotter's belts.
    let page = r#"<svg xmlns="http://www.w3.org/2000/svg" width="99mm" height="69.3mm" viewBox="0 0 10 7">
  <path d="M0 7 L10 7 L10 0" fill="none" stroke="black"/>
</svg>"#;
    let icon = |x: &str| {
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="24" height="24" viewBox="0 0 24 24">
  <path d="M{x} 12 L12 12 L12 2" fill="none" stroke="black"/>
</svg>"#
        )
    };
    // (file, text, clamped moves and the largest clamp in mm; None: refused)
    let cases = [
        ("page.svg", page.to_string(), Some((0, 0.0))),
        ("icon.svg", icon("-0.0117"), Some((1, 0.0117 * 25.4 / 96.0))),
        ("far.svg", icon("-0.02"), None),
    ];
    for (name, text, want) in cases {
        let job = write(dir, name, &text);
        let out = dir.join(format!("out-{name}"));
        let (ok, stdout, stderr) = motet(&["run", PLOTTER, &job, "--out", out.to_str().unwrap()]);
        match want {
            Some((moves, max)) => {
                assert!(ok, "{name}: {stderr}");
                let report: serde_json::Value = serde_json::from_str(
                    &std::fs::read_to_string(out.join("report.json")).unwrap(),
                )
                .unwrap();
                assert_eq!(report["clamped_moves"].as_u64(), Some(moves), "{name}");
                let got = report["max_clamp_mm"].as_f64().unwrap();
                assert!((got - max).abs() < 1e-6, "{name}: {got} vs {max}");
                assert_eq!(
                    stdout.contains("clamped onto the travel"),
                    moves > 0,
                    "{stdout}"
                );
            }
            None => {
                assert!(!ok, "{name} should fail");
                let want = format!(
                    "{job}:2:3: move to x=-0.00529167 is 0.00529167 beyond the axis's travel [0, 300] (half a step is 0.00441786)"
                );
                assert!(stderr.contains(&want), "{name}: {stderr}");
            }
        }
    }
}

#[test]
fn deep_nesting_is_refused_with_its_depth() {
    let tmp = scratch("nest");
    let dir = tmp.path();
    let n = 200_000;
    let svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">\n{}<path d=\"M1 1 L2 2\" stroke=\"black\"/>{}</svg>\n",
        "<g>".repeat(n),
        "</g>".repeat(n)
    );
    let job = write(dir, "nest.svg", &svg);
    let (ok, _, stderr) = motet(&["check", PLOTTER, &job]);
    assert!(!ok);
    assert!(
        stderr.contains(&format!(
            "{job}:2:766: invalid SVG: elements nest more than 256 deep here"
        )),
        "{stderr}"
    );
}
