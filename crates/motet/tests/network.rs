//! Networked runs end to end: node processes on UDP and pseudo-terminals,
//! scanning, pairing, firmware upload, a host killed mid-move and `motet
//! resume`. Run times are scaled (`--time-scale`) so jobs take seconds.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

mod common;
use common::{journal_seals, motet, resume_to_done, root, wait_for_seals};

fn scratch(name: &str) -> TempDir {
    common::scratch("net", name)
}

/// A simulated node process; killed when dropped.
struct NodeProc {
    child: Child,
    link: String,
}

impl Drop for NodeProc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start_node(extra: &[&str]) -> NodeProc {
    let mut child = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "node",
            "--sim",
            "--announce",
            "--quiet",
            "--idle-exit",
            "120",
        ])
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let (link, _uid) =
        motet_net::spawn::parse_announce(&line).unwrap_or_else(|| panic!("announce: {line:?}"));
    NodeProc { child, link }
}

/// A copy of an example machine in `dir` (pairing writes beside it).
fn machine_copy(dir: &Path, name: &str) -> PathBuf {
    let to = dir.join(name);
    std::fs::copy(root().join("examples").join(name), &to).unwrap();
    to
}

/// Node clocks five times fast, so a job takes a fifth of its time. The lead
/// (host time, so 0.5 s of wall time here) is what a host stalled by a loaded
/// machine may lose before a node misses its next window and brakes: the
/// tests run in parallel on two cores, beside other test binaries.
const FAST: [&str; 4] = ["--time-scale", "5", "--lead-ms", "2500"];

/// Networked runs keep real time: one at a time, so that the processes of
/// one test do not starve those of another on a small machine.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

#[test]
fn spawned_nodes_run_a_job_to_the_end() {
    let _serial = serial();
    let tmp = scratch("spawn");
    // Short, with every axis (so every node) moving, alone and together.
    let report = spawned_run(
        tmp.path(),
        "examples/gestalt-3axis.toml",
        "G0 Z5\nG0 X40 Y40\nM3 S800\nG1 Z-2 F600\nG2 X40 Y40 Z-4 I-10 J0 F900\nG1 X80 Y70 Z0 F900\nG0 Z10\nM5\n",
        &[],
    );
    assert_eq!(report["nodes"].as_array().unwrap().len(), 3);
    for n in report["nodes"].as_array().unwrap() {
        assert_eq!(n["underruns"], 0, "{n}");
        assert!(n["bytes_out"].as_u64().unwrap() > 0);
    }
}

#[test]
fn scan_pair_and_run_on_paired_nodes_over_udp_and_a_pty() {
    let _serial = serial();
    let tmp = scratch("pair");
    let dir = tmp.path();
    let machine = machine_copy(dir, "plotter.toml");
    for listen in ["udp:127.0.0.1:0", "pty"] {
        let state = dir.join(format!("node-{}.state", listen.len()));
        let node = start_node(&[
            "--listen",
            listen,
            "--state",
            state.to_str().unwrap(),
            "--time-scale",
            "5",
        ]);
        let (ok, stdout, stderr) = motet(&["nodes", "scan", "--link", &node.link]);
        assert!(ok, "{stderr}");
        assert!(
            stdout.contains("stepper") && stdout.contains("unpaired"),
            "{stdout}"
        );

        let ebb = format!("ebb={}", node.link);
        let (ok, stdout, stderr) =
            motet(&["nodes", "pair", machine.to_str().unwrap(), "--link", &ebb]);
        assert!(ok, "{stderr}");
        assert!(stdout.contains("is now address 2"), "{stdout}");
        let pairing = dir.join("plotter.nodes.toml");
        let text = std::fs::read_to_string(&pairing).unwrap();
        assert!(
            text.contains("[nodes.ebb]") && text.contains(&node.link),
            "{text}"
        );

        let (ok, stdout, stderr) = motet(&["nodes", "status", machine.to_str().unwrap()]);
        assert!(ok, "{stderr}");
        assert!(
            stdout.contains("ebb: stepper") && stdout.contains("Idle"),
            "{stdout}"
        );

        // A short job: what is tested is that paired nodes run one.
        let job = dir.join("square.gcode");
        std::fs::write(
            &job,
            "G0 X20 Y20\nM3\nG1 X60 F3000\nG1 Y60\nG1 X20\nG1 Y20\nM5\n",
        )
        .unwrap();
        let out = dir.join(format!("out-{}", listen.len()));
        let mut args = vec![
            "run",
            machine.to_str().unwrap(),
            job.to_str().unwrap(),
            "--nodes",
            "paired",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(FAST);
        let (ok, _, stderr) = motet(&args);
        assert!(ok, "{listen}: {stderr}");
        let report = std::fs::read_to_string(out.join("net.json")).unwrap();
        assert!(report.contains("\"outcome\": \"done\""), "{report}");

        // The node remembers its address: a new process from the same state
        // file needs no pairing.
        drop(node);
        if listen == "pty" {
            break;
        }
        let again = start_node(&["--listen", listen, "--state", state.to_str().unwrap()]);
        let (ok, stdout, _) = motet(&["nodes", "scan", "--link", &again.link]);
        assert!(ok && stdout.contains("address 2"), "{stdout}");
    }
}

#[test]
fn button_pairing_takes_the_pressed_node() {
    let _serial = serial();
    let tmp = scratch("button");
    let dir = tmp.path();
    let machine = machine_copy(dir, "plotter.toml");
    let node = start_node(&["--auto-press"]);
    let ebb = format!("ebb={}", node.link);
    let (ok, stdout, stderr) = motet(&[
        "nodes",
        "pair",
        machine.to_str().unwrap(),
        "--link",
        &ebb,
        "--button",
        "--wait",
        "10",
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("press the button") && stdout.contains("is now address 2"),
        "{stdout}"
    );
}

#[test]
fn firmware_upload_verifies_and_refuses_bad_images() {
    let _serial = serial();
    let tmp = scratch("flash");
    let dir = tmp.path();
    let machine = machine_copy(dir, "plotter.toml");
    let node = start_node(&[]);
    let (ok, _, stderr) = motet(&[
        "nodes",
        "pair",
        machine.to_str().unwrap(),
        "--link",
        &format!("ebb={}", node.link),
    ]);
    assert!(ok, "{stderr}");
    let payload = dir.join("payload.bin");
    std::fs::write(
        &payload,
        (0..5000u32)
            .map(|i| (i * 7 % 251) as u8)
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let img = dir.join("fw.img");
    let (ok, _, stderr) = motet(&[
        "nodes",
        "image",
        "--kind",
        "stepper",
        "--version",
        "2.3.4",
        payload.to_str().unwrap(),
        "-o",
        img.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");

    // (image bytes changed how, expected error)
    let good = std::fs::read(&img).unwrap();
    let mut flipped = good.clone();
    flipped[100] ^= 0x40;
    let bad = dir.join("bad.img");
    std::fs::write(&bad, &flipped).unwrap();
    let (ok, _, stderr) = motet(&[
        "nodes",
        "flash",
        machine.to_str().unwrap(),
        "ebb",
        bad.to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("CRC"), "{stderr}");
    let other = dir.join("other.img");
    let (ok, _, _) = motet(&[
        "nodes",
        "image",
        "--kind",
        "servo",
        "--version",
        "9.9.9",
        payload.to_str().unwrap(),
        "-o",
        other.to_str().unwrap(),
    ]);
    assert!(ok);
    let (ok, _, stderr) = motet(&[
        "nodes",
        "flash",
        machine.to_str().unwrap(),
        "ebb",
        other.to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("another kind"), "{stderr}");
    let (_, stdout, _) = motet(&["nodes", "status", machine.to_str().unwrap()]);
    assert!(
        !stdout.contains("2.3.4") && !stdout.contains("9.9.9"),
        "{stdout}"
    );

    let (ok, stdout, stderr) = motet(&[
        "nodes",
        "flash",
        machine.to_str().unwrap(),
        "ebb",
        img.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("firmware 2.3.4 verified and started"),
        "{stdout}"
    );
    let (_, stdout, _) = motet(&["nodes", "status", machine.to_str().unwrap()]);
    assert!(stdout.contains("firmware 2.3.4"), "{stdout}");
}

#[test]
fn host_killed_mid_move_stops_the_nodes_and_resume_finishes_the_job() {
    let _serial = serial();
    let tmp = scratch("kill");
    let dir = tmp.path();
    let machine = machine_copy(dir, "plotter.toml");
    let node = start_node(&["--time-scale", "5"]);
    let (ok, _, stderr) = motet(&[
        "nodes",
        "pair",
        machine.to_str().unwrap(),
        "--link",
        &format!("ebb={}", node.link),
    ]);
    assert!(ok, "{stderr}");
    let out = dir.join("out");
    let mut host = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "run",
            machine.to_str().unwrap(),
            "examples/jobs/drawing.svg",
            "--nodes",
            "paired",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ])
        .args(FAST)
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Kill it once the job is well under way (the journal has windows).
    wait_for_seals(&out, &mut host, 16);
    host.kill().unwrap();
    host.wait().unwrap();
    // The node runs out its committed window (up to the lead) and brakes.
    let killed = Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(300));
        let (ok, stdout, stderr) = motet(&["nodes", "status", machine.to_str().unwrap()]);
        assert!(ok, "{stderr}");
        if stdout.contains("Stopped") {
            break;
        }
        assert!(
            killed.elapsed() < Duration::from_secs(20),
            "the node must have stopped on its tail: {stdout}"
        );
    }

    resume_to_done(&out, &[]);
}

/// A UDP port free on this machine now.
fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The defects of a trusting resume, end to end: firmware upload mid-job is
/// refused; a node killed mid-job is reported lost, not at rest; restarted,
/// it knows nothing, and resume asks where the machine is instead of
/// starting over; an edited journal or job is refused; given a position,
/// the job finishes, resumed from another folder than the run's.
#[test]
fn a_crashed_node_is_lost_and_resume_trusts_nothing() {
    let _serial = serial();
    let tmp = scratch("crash");
    let dir = tmp.path();
    let machine = machine_copy(dir, "plotter.toml");
    std::fs::copy(
        root().join("examples/jobs/drawing.svg"),
        dir.join("drawing.svg"),
    )
    .unwrap();
    let state = dir.join("node.state");
    let listen = format!("udp:127.0.0.1:{}", free_udp_port());
    let node_args = [
        "--listen",
        listen.as_str(),
        "--state",
        state.to_str().unwrap(),
        "--time-scale",
        "5",
    ];
    let node = start_node(&node_args);
    let (ok, _, stderr) = motet(&[
        "nodes",
        "pair",
        machine.to_str().unwrap(),
        "--link",
        &format!("ebb={}", node.link),
    ]);
    assert!(ok, "{stderr}");
    // A firmware image to try mid-job.
    std::fs::write(dir.join("payload.bin"), vec![7u8; 2000]).unwrap();
    let img = dir.join("fw.img");
    let (ok, _, stderr) = motet(&[
        "nodes",
        "image",
        "--kind",
        "stepper",
        "--version",
        "2.0.0",
        dir.join("payload.bin").to_str().unwrap(),
        "-o",
        img.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");

    // The run, from the scratch folder with relative paths.
    let out = dir.join("out");
    let host = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "run",
            "plotter.toml",
            "drawing.svg",
            "--nodes",
            "paired",
            "-q",
            "--out",
            "out",
        ])
        .args(FAST)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while journal_seals(&out) < 10 {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the run never got going"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let (ok, stdout, stderr) = motet(&[
        "nodes",
        "flash",
        machine.to_str().unwrap(),
        "ebb",
        img.to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("is moving"), "{stdout}{stderr}");
    let (_, stdout, _) = motet(&["nodes", "status", machine.to_str().unwrap()]);
    assert!(
        stdout.contains("Running") && stdout.contains("firmware 0.1.0"),
        "{stdout}"
    );

    // The node's process dies.
    drop(node);
    let result = host.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success());
    assert!(
        stderr.contains("node ebb")
            && stderr.contains("where it is is not known")
            && !stderr.contains("came to rest"),
        "{stderr}"
    );
    let stop = std::fs::read_to_string(out.join("stop.toml")).unwrap();
    assert!(stop.contains("lost = [\"ebb\"]"), "{stop}");

    // Started again from its state file: same address, no position.
    let _node = start_node(&node_args);
    let o = out.to_str().unwrap();
    let (ok, _, stderr) = motet(&["resume", o]);
    assert!(
        !ok && stderr.contains("restarted") && stderr.contains("--assume-position x=…,y=…"),
        "{stderr}"
    );
    // An edited journal, then an edited job: refused, saying where.
    let journal = std::fs::read_to_string(out.join("journal")).unwrap();
    let seg = journal
        .lines()
        .position(|l| l.starts_with("seg 5 "))
        .unwrap();
    let edited: Vec<String> = journal
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == seg {
                l.replacen(" | ", " | 921", 1)
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(out.join("journal"), edited.join("\n") + "\n").unwrap();
    let (ok, _, stderr) = motet(&["resume", o, "--assume-position", "x=100,y=100"]);
    assert!(
        !ok && stderr.contains(&format!("journal:{}: checksum", seg + 1)),
        "{stderr}"
    );
    std::fs::write(out.join("journal"), &journal).unwrap();
    let job = std::fs::read_to_string(dir.join("drawing.svg")).unwrap();
    std::fs::write(
        dir.join("drawing.svg"),
        job.replacen("<svg", "<svg data-x=\"1\"", 1),
    )
    .unwrap();
    let (ok, _, stderr) = motet(&["resume", o, "--assume-position", "x=100,y=100"]);
    assert!(
        !ok && stderr.contains("drawing.svg changed since the run"),
        "{stderr}"
    );
    std::fs::write(dir.join("drawing.svg"), &job).unwrap();
    // Beyond travel: refused before anything moves.
    let (ok, _, stderr) = motet(&["resume", o, "--assume-position", "x=921,y=100"]);
    assert!(
        !ok && stderr.contains("beyond the axis's travel"),
        "{stderr}"
    );

    // Told where the machine is, it finishes the job.
    let (ok, stdout, stderr) = motet(&["resume", o, "--assume-position", "x=100,y=100"]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("was given with --assume-position")
            && stdout.contains("may run twice")
            && stdout.contains("done"),
        "{stdout}"
    );
    let report = std::fs::read_to_string(out.join("net.json")).unwrap();
    assert!(report.contains("\"outcome\": \"done\""), "{report}");
}

#[test]
fn bad_network_input_is_a_clear_error() {
    let _serial = serial();
    let tmp = scratch("bad");
    let dir = tmp.path();
    let machine = machine_copy(dir, "plotter.toml");
    let m = machine.to_str().unwrap();
    // (arguments, expected part of the error)
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["run", m, "examples/jobs/drawing.svg", "--nodes", "paired"],
            "plotter.nodes.toml does not exist",
        ),
        (
            vec!["nodes", "pair", m, "--link", "pen=udp:127.0.0.1:9"],
            "the machine has no node `pen`",
        ),
        (
            vec!["nodes", "pair", m, "--link", "ebb"],
            "expected NODE=SPEC",
        ),
        (
            vec!["nodes", "scan", "--link", "carrier-pigeon:1"],
            "carrier-pigeon",
        ),
        (vec!["nodes", "status", m], "does not exist"),
        (
            vec!["node", "--sim", "--listen", "tcp:1"],
            "expected `udp:HOST:PORT`, `udp-group:GROUP:PORT[@IFACE]` or `pty`",
        ),
        (
            vec!["node", "--sim", "--listen", "udp-group:10.0.0.1:47100"],
            "10.0.0.1",
        ),
        (
            vec![
                "run",
                m,
                "examples/jobs/drawing.svg",
                "--nodes",
                "spawn",
                "--bus",
                "can",
            ],
            "--bus \"can\": expected `udp` or `udp-group:GROUP:PORT[@IFACE]`",
        ),
        (
            vec![
                "run",
                m,
                "examples/jobs/drawing.svg",
                "--nodes",
                "paired",
                "--bus",
                "udp",
            ],
            "--bus is for --nodes spawn",
        ),
        (vec!["resume", dir.to_str().unwrap()], "resume.toml"),
    ];
    for (args, want) in cases {
        let (ok, _, stderr) = motet(&args);
        assert!(!ok && stderr.contains(want), "{args:?}: {stderr}");
    }
    // A pairing file naming a device that is not there.
    std::fs::write(
        dir.join("plotter.nodes.toml"),
        "[nodes.ebb]\nlink = \"udp:127.0.0.1:9\"\naddress = 2\nuid = \"1\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n",
    )
    .unwrap();
    let (ok, _, stderr) = motet(&["run", m, "examples/jobs/drawing.svg", "--nodes", "paired"]);
    assert!(
        !ok && stderr.contains("node ebb") && stderr.contains("no answer"),
        "{stderr}"
    );
    // A node that is not the one paired.
    let node = start_node(&[]);
    let (ok, _, _) = motet(&["nodes", "pair", m, "--link", &format!("ebb={}", node.link)]);
    assert!(ok);
    let text = std::fs::read_to_string(dir.join("plotter.nodes.toml")).unwrap();
    let uid_line = text
        .lines()
        .find(|l| l.starts_with("uid"))
        .unwrap()
        .to_string();
    std::fs::write(
        dir.join("plotter.nodes.toml"),
        text.replace(&uid_line, "uid = \"0000000000000001\""),
    )
    .unwrap();
    let (ok, _, stderr) = motet(&["run", m, "examples/jobs/drawing.svg", "--nodes", "paired"]);
    assert!(
        !ok && stderr.contains("but uid 0000000000000001 was paired"),
        "{stderr}"
    );
    // A node started with another --time-scale than the host's: its clock
    // runs 5 times as fast; refused before anything moves.
    drop(node);
    let node = start_node(&["--time-scale", "5"]);
    let (ok, _, _) = motet(&["nodes", "pair", m, "--link", &format!("ebb={}", node.link)]);
    assert!(ok);
    let (ok, _, stderr) = motet(&["run", m, "examples/jobs/drawing.svg", "--nodes", "paired"]);
    assert!(
        !ok && stderr.contains("× as fast as the host") && stderr.contains("--time-scale"),
        "{stderr}"
    );
}

#[test]
fn one_device_for_two_nodes_is_refused_and_status_names_silent_nodes() {
    let _serial = serial();
    let tmp = scratch("twice");
    let dir = tmp.path();
    let machine = machine_copy(dir, "clay-printer.toml");
    let m = machine.to_str().unwrap();
    let pairing = dir.join("clay-printer.nodes.toml");
    let a = start_node(&[]);
    let b = start_node(&[]);

    let (ok, _, stderr) = motet(&[
        "nodes",
        "pair",
        m,
        "--link",
        &format!("table={}", a.link),
        "--link",
        &format!("tower={}", a.link),
    ]);
    assert!(
        !ok && stderr.contains("machine nodes `table` and `tower` would both be the device uid")
            && stderr.contains(&a.link),
        "{stderr}"
    );
    assert!(!pairing.exists(), "nothing is written");

    let (ok, _, stderr) = motet(&[
        "nodes",
        "pair",
        m,
        "--link",
        &format!("table={}", a.link),
        "--link",
        &format!("tower={}", b.link),
    ]);
    assert!(ok, "{stderr}");
    let (ok, stdout, stderr) = motet(&["nodes", "status", m]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("table: stepper") && stdout.contains("tower: stepper"),
        "{stdout}"
    );

    // A node that does not answer fails the command, by name; the other is
    // still shown.
    drop(b);
    let (ok, stdout, stderr) = motet(&["nodes", "status", m]);
    assert!(!ok, "a silent node must fail: {stdout}");
    assert!(stdout.contains("table: stepper"), "{stdout}");
    assert!(
        stderr.contains("1 of 2 paired nodes gave no status: tower") && stderr.contains("tower: "),
        "{stderr}"
    );

    // A pairing file that puts both nodes on one device is refused when read.
    let text = std::fs::read_to_string(&pairing).unwrap();
    let uid = |node: &str| {
        let at = text.find(&format!("[nodes.{node}]")).unwrap();
        text[at..]
            .lines()
            .find(|l| l.starts_with("uid"))
            .unwrap()
            .to_string()
    };
    std::fs::write(&pairing, text.replace(&uid("tower"), &uid("table"))).unwrap();
    for args in [
        vec!["nodes", "status", m],
        vec![
            "run",
            m,
            "examples/jobs/clay-vase.gcode",
            "--nodes",
            "paired",
        ],
    ] {
        let (ok, _, stderr) = motet(&args);
        assert!(
            !ok && stderr.contains("clay-printer.nodes.toml: nodes table and tower are both uid"),
            "{args:?}: {stderr}"
        );
    }
}

/// Servo nodes in their own processes close their loops on their plants,
/// and the run plots what they sent: each servo followed its moves (its
/// encoder went from the start to where the job ends), its following
/// error within the limit, the sensor heard.
#[test]
fn spawned_servo_nodes_send_samples_the_run_plots() {
    let _serial = serial();
    let tmp = scratch("servo");
    let report = spawned_run(
        tmp.path(),
        "examples/servo-mill.toml",
        "G21 G90\nG1 X20 Y10 F3000\nG1 X0 Y0\n",
        &[
            "servo-x_servo.png",
            "servo-y_servo.png",
            "sensor-x_accel.png",
        ],
    );
    let loops = report["loops"].as_array().unwrap();
    let x = loops
        .iter()
        .find(|l| l["name"] == "actuator x_servo")
        .expect("x_servo's samples");
    // 800 counts/mm: 20 mm out and back (16,000 counts; samples a
    // window apart, so the turn may fall between two), within the limit
    // (40 counts).
    assert!(x["points"].as_u64().unwrap() > 10, "{x}");
    let span = x["high"].as_f64().unwrap() - x["low"].as_f64().unwrap();
    assert!(span > 15_000.0 && span < 16_040.0, "{x}");
    assert!(
        (x["last"].as_f64().unwrap() - x["low"].as_f64().unwrap()).abs() < 40.0,
        "{x}"
    );
    let most = x["least"]
        .as_f64()
        .unwrap()
        .abs()
        .max(x["most"].as_f64().unwrap().abs());
    assert!(most > 0.0 && most < 40.0, "{x}");
}

/// A heater on a node in its own process: its samples come back and the
/// run plots its temperature against its target, as an in-process run
/// does.
#[test]
fn spawned_heater_nodes_plot_their_heaters() {
    let _serial = serial();
    let tmp = scratch("heat");
    let report = spawned_run(
        tmp.path(),
        "examples/printer-heated.toml",
        "M104 S60\nG28\nG1 X20 Y20 F3000\nG1 X0 Y0\nG4 S4\nM104 S0\n",
        &["heater-hotend.png", "heater-bed.png"],
    );
    // Only servos and sensors are the loops' sources: none here.
    assert!(report["loops"].as_array().unwrap().is_empty(), "{report}");
    // The hot end was driven toward 60 °C and warmed (several degrees in
    // the dwell past its sensor's lag); the bed was left off.
    let heaters = report["heaters"].as_array().unwrap();
    let h = |name: &str| heaters.iter().find(|h| h["name"] == name).unwrap();
    let (hot, bed) = (h("hotend"), h("bed"));
    assert_eq!(hot["highest_target_c"], 60.0, "{hot}");
    assert!(hot["highest_power"].as_f64().unwrap() > 0.5, "{hot}");
    let warmed = hot["highest_c"].as_f64().unwrap() - hot["first_c"].as_f64().unwrap();
    assert!(warmed > 2.0, "{hot}");
    assert_eq!(bed["highest_target_c"], 0.0, "{bed}");
    assert_eq!(bed["highest_power"], 0.0, "{bed}");
}

/// `motet run MACHINE JOB --nodes spawn` (fast) in `out` to the end; its
/// `net.json`, once each of `plots` is listed there and written.
fn spawned_run(out: &Path, machine: &str, job: &str, plots: &[&str]) -> serde_json::Value {
    let path = out.join("job.gcode");
    std::fs::write(&path, job).unwrap();
    let mut args = vec![
        "run",
        machine,
        path.to_str().unwrap(),
        "--nodes",
        "spawn",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(FAST);
    let (ok, _, stderr) = motet(&args);
    assert!(ok, "{stderr}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("net.json")).unwrap()).unwrap();
    assert_eq!(report["outcome"], "done");
    let listed = report["plots"].as_array().unwrap();
    for file in plots {
        assert!(listed.iter().any(|p| p == file), "{listed:?}");
        assert!(std::fs::metadata(out.join(file)).unwrap().len() > 1000);
    }
    report
}
