//! The `motet` command line end to end: outputs on success, located errors on
//! bad input.

use std::path::Path;
use std::process::Command;
use tempfile::TempDir;

mod common;
use common::{motet, root};

fn scratch(name: &str) -> TempDir {
    common::scratch("cli", name)
}

#[test]
fn run_writes_render_and_report() {
    let tmp = scratch("run");
    let out = tmp.path();
    let (ok, stdout, stderr) = motet(&[
        "run",
        "examples/plotter.toml",
        "examples/jobs/drawing.svg",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("executed vs commanded"),
        "summary missing: {stdout}"
    );
    let png = std::fs::read(out.join("path.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let svg = std::fs::read_to_string(out.join("path.svg")).unwrap();
    assert!(svg.contains("<polyline"));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    for key in [
        "duration_s",
        "tool_on_distance_mm",
        "travel_distance_mm",
        "axes",
        "actuators",
        "max_path_deviation_mm",
        "max_step_time_error_us",
    ] {
        assert!(report.get(key).is_some(), "report lacks {key}");
    }
    assert_eq!(report["actuators"].as_array().unwrap().len(), 2);
    assert!(report["actuators"][0]["steps"].as_u64().unwrap() > 0);
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn bad_input_gets_a_located_error_and_no_output() {
    let tmp = scratch("bad");
    let dir = tmp.path();
    let printer = "examples/printer.toml";
    let plotter = "examples/plotter.toml";
    // (machine, job file name, job text, expected substring of the error)
    let cases: &[(&str, &str, &str, &str)] = &[
        (printer, "nofeed.gcode", "G21\nG90\nG1 X10 Y10\n", "nofeed.gcode:3:1"),
        (printer, "beyond.gcode", "G21\nG1 X10 F600\nG1 X500 F600\n", "beyond.gcode:3"),
        (printer, "unknown.gcode", "G1 X1 F100\nG38.2 X5\n", "unknown.gcode:2:1"),
        (printer, "garbage.gcode", "G1 X1..2 F100\n", "garbage.gcode:1:"),
        (plotter, "broken.svg", "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">\n<path d=\"M0 0 L5 5\"\n", "broken.svg:"),
        (plotter, "z.gcode", "G1 Z1 F100\n", "z.gcode:1:"),
        (printer, "job.docx", "hello", "unknown job type"),
    ];
    for (machine, name, text, want) in cases {
        let job = write(dir, name, text);
        let out = dir.join(format!("out-{name}"));
        let (ok, _, stderr) = motet(&[
            "run",
            machine,
            &job,
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(!ok, "{name} should fail");
        assert!(
            stderr.contains(want),
            "{name}: error should contain `{want}`, got: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(
            !out.exists(),
            "{name}: nothing should be written for a refused job"
        );
    }
}

#[test]
fn bad_machine_file_gets_a_located_error() {
    let tmp = scratch("machine");
    let dir = tmp.path();
    let good = std::fs::read_to_string(root().join("examples/printer.toml")).unwrap();
    let cases: &[(&str, String, &str)] = &[
        (
            "typo.toml",
            good.replace("max_velocity = 300          # mm/s", "max_velocty = 300"),
            "typo.toml:15:1",
        ),
        (
            "chain.toml",
            good.replace(
                "{ stepper = { step_angle = 1.8 } }, { microstep = 16 }]\n\n[actuators.y_motor]",
                "{ microstep = 16 }, { stepper = { step_angle = 1.8 } }]\n\n[actuators.y_motor]",
            ),
            "impossible element chain",
        ),
        (
            "joint.toml",
            good.replace("joint = \"z\"", "joint = \"w\""),
            "unknown joint `w`",
        ),
    ];
    for (name, text, want) in cases {
        let m = write(dir, name, text);
        let (ok, _, stderr) = motet(&["check", &m]);
        assert!(!ok, "{name} should fail");
        assert!(
            stderr.contains(want),
            "{name}: error should contain `{want}`, got: {stderr}"
        );
    }
    let (ok, _, stderr) = motet(&["check", "no/such/machine.toml"]);
    assert!(
        !ok && stderr.contains("cannot read machine file"),
        "{stderr}"
    );
}

#[test]
fn dance_takes_live_inputs_from_stdin() {
    use std::io::Write;
    let tmp = scratch("live");
    let out = tmp.path();
    let mut child = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "dance",
            "examples/dance/step-a-sketch/machine.toml",
            "examples/dance/step-a-sketch/graph.toml",
            "--live",
            "-",
            "--stamped",
            "--seconds",
            "2",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ])
        .current_dir(root())
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"t=0 knob_x=0 knob_y=0\nt=0.5 knob_x=200\nnot a line\nt=1.0 knob_y=300\n")
        .unwrap();
    let result = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(result.status.success(), "{stderr}");
    assert!(
        stderr.contains(":3:"),
        "the malformed line 3 is reported: {stderr}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    // The knobs turned (x to 200, then y to 300 counts): both belts moved and
    // ended within half a step of the exact sum of their inputs.
    for ch in report["channels"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["name"] != "ch_pen")
    {
        assert!(ch["steps_forward"].as_u64().unwrap() > 0, "{ch}");
        assert!(ch["error_steps"].as_f64().unwrap().abs() <= 0.5, "{ch}");
    }
}

/// Output into a pipe nobody reads (`motet … | head -0`) ends motet quietly,
/// never with a panic.
#[test]
fn a_closed_pipe_is_no_panic() {
    use std::process::{Command, Stdio};
    let tmp = scratch("pipe");
    let mut child = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "run",
            "examples/plotter.toml",
            "examples/jobs/drawing.svg",
            "--out",
        ])
        .arg(tmp.path().join("out"))
        .current_dir(root())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// `bench --microsteps` simulates the machine as if its file said so: the
/// same steps as a run of the edited file.
#[test]
fn bench_microsteps_is_the_edited_machine() {
    let tmp = scratch("microsteps");
    let dir = tmp.path();
    let job = root().join("examples/jobs/printer-vase-layers.gcode");
    let job = job.to_str().unwrap();
    let printer = root().join("examples/printer.toml");
    let text = std::fs::read_to_string(&printer).unwrap();
    assert!(text.contains("microstep = 16"));
    let edited = write(
        dir,
        "printer.toml",
        &text.replace("microstep = 16", "microstep = 32"),
    );
    let out = dir.join("out");
    let (ok, _, stderr) = motet(&["run", &edited, job, "-q", "--out", out.to_str().unwrap()]);
    assert!(ok, "{stderr}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let want: u64 = report["actuators"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["steps"].as_u64().unwrap())
        .sum();

    let (ok, stdout, stderr) = motet(&[
        "bench",
        "--machine",
        printer.to_str().unwrap(),
        "--job",
        job,
        "--repeat",
        "1",
        "--microsteps",
        "32",
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(&format!(" {want} steps ")),
        "want {want} steps: {stdout}"
    );

    let (ok, _, stderr) = motet(&["bench", "--microsteps", "0", "--no-sim"]);
    assert!(!ok && stderr.contains("--microsteps"), "{stderr}");
}

/// Placement flags: a fitted run reports where the drawing went (and a run
/// without them writes no such entry); refused values and combinations
/// name their flags before anything runs.
#[test]
fn placement_flags_place_drawings_or_name_what_is_wrong() {
    let tmp = scratch("place");
    let out = |name: &str| tmp.path().join(name).to_str().unwrap().to_string();
    let svg = "examples/jobs/drawing.svg";
    let plotter = "examples/plotter.toml";
    for (name, placed) in [("fit", true), ("plain", false)] {
        let o = out(name);
        let mut args = vec!["run", plotter, svg, "--out", &o, "--quiet"];
        if placed {
            args.push("--fit");
        }
        let (ok, _, stderr) = motet(&args);
        assert!(ok, "{name}: {stderr}");
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(tmp.path().join(name).join("report.json")).unwrap(),
        )
        .unwrap();
        match placed {
            // The default 10 mm margin: the drawing is wider than tall, so
            // it spans x 10..290.
            true => {
                let p = &report["placement"];
                assert_eq!(p["min_mm"][0].as_f64(), Some(10.0), "{p}");
                assert_eq!(p["max_mm"][0].as_f64(), Some(290.0), "{p}");
                assert_eq!(p["clamped_moves"].as_u64(), Some(0), "{p}");
            }
            false => assert!(report.get("placement").is_none(), "{report}"),
        }
    }
    let cases: &[(&[&str], bool, &str)] = &[
        (&["check", plotter, svg, "--rotate", "-90", "--scale", "0.5", "--origin", "-0,10"], true, "placed at x 0.."),
        (&["check", plotter, svg, "--fit", "5"], true, "placed at x 5..295"),
        (&["check", plotter, svg, "--fit", "--scale", "2"], false, "placement fit_margin_mm (`--fit`) and scale (`--scale`) cannot be combined"),
        (&["check", plotter, svg, "--fit", "--origin", "1,1"], false, "(`--fit`) and origin (`--origin`) cannot be combined"),
        (&["check", plotter, svg, "--scale", "0"], false, "scale (`--scale`) must be a finite number > 0, not 0"),
        (&["check", plotter, svg, "--scale", "nan"], false, "not NaN"),
        (&["check", plotter, svg, "--fit", "-3"], false, "fit_margin_mm (`--fit`) must be a finite number of mm ≥ 0, not -3"),
        (&["check", plotter, svg, "--fit", "wide"], false, "invalid value 'wide' for '--fit [<MARGIN_MM>]'"),
        (&["check", plotter, svg, "--fit", "150"], false, "drawing.svg: placement fit_margin_mm (`--fit`) 150 mm leaves nothing"),
        (&["check", plotter, svg, "--origin", "1;2"], false, "invalid value '1;2' for '--origin <X,Y>'"),
        (&["check", plotter, svg, "--scale", "3"], false, "beyond the x travel 0..300 mm"),
        (&["check", "examples/laser.toml", "examples/jobs/laser-badge.gcode", "--rotate", "90"], false, "laser-badge.gcode: placement (`--fit`, `--scale`, `--rotate`, `--origin`) applies to SVG and photo jobs"),
        (&["run", plotter, svg, "--nodes", "spawn", "--fit"], false, "--fit, --scale, --rotate and --origin work with --nodes sim only"),
    ];
    for (args, want_ok, want) in cases {
        let (ok, stdout, stderr) = motet(args);
        assert_eq!(ok, *want_ok, "{args:?}: {stdout}{stderr}");
        let text = if ok { stdout } else { stderr };
        assert!(text.contains(want), "{args:?}: `{text}` lacks `{want}`");
    }
}
