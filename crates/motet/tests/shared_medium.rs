//! Three node processes on one shared medium from the command line
//! (`motet run --nodes spawn --bus udp`: a UDP multicast group, as on a CAN
//! bus): the host killed, one node's cable pulled, or one node killed,
//! mid-job; every surviving node rests on one committed point, and `motet
//! resume` finishes the job.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

mod common;
use common::{motet, resume_to_done, root, wait_for_seals};

/// Networked runs keep real time: one at a time.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// Node clocks five times fast; a lead of half a second of wall time.
const FAST: [&str; 4] = ["--time-scale", "5", "--lead-ms", "2500"];

/// The three-node machine's job up to its helical bore (every axis moving
/// at once), as a file in `dir`.
fn job(dir: &Path) -> String {
    let text = std::fs::read_to_string(root().join("examples/jobs/gestalt-3d.gcode")).unwrap();
    let mut part: String = text.lines().take(11).map(|l| format!("{l}\n")).collect();
    part += "G1 Z5 F300\nM5\n";
    let path = dir.join("part.gcode");
    std::fs::write(&path, part).unwrap();
    path.to_str().unwrap().to_string()
}

/// The three-node machine's job from `dir`, on the group.
fn start_run(dir: &Path, stderr: Stdio) -> Child {
    let out = dir.join("out");
    Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "run",
            "examples/gestalt-3axis.toml",
            &job(dir),
            "--nodes",
            "spawn",
            "--bus",
            "udp",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ])
        .args(FAST)
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .unwrap()
}

/// The run record's nodes: (name, link, uid, pid of the process the run
/// started). Every one was on the same multicast group.
fn recorded(out: &Path) -> Vec<(String, String, String, u32)> {
    let text = std::fs::read_to_string(out.join("resume.toml")).unwrap();
    let record: toml::Table = toml::from_str(&text).unwrap();
    let nodes = record["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| {
            let s = |k: &str| n[k].as_str().unwrap().to_string();
            let pid = n["pid"].as_integer().unwrap() as u32;
            (s("name"), s("link"), s("uid"), pid)
        })
        .collect::<Vec<_>>();
    let link = &nodes[0].1;
    assert!(link.starts_with("udp-group:"), "{link}");
    assert!(nodes.iter().all(|n| &n.1 == link), "{nodes:?}");
    nodes
}

fn kill(pid: u32, signal: &str) {
    let ok = Command::new("kill")
        .args([signal, &pid.to_string()])
        .status()
        .unwrap();
    assert!(ok.success(), "kill {signal} {pid}");
}

/// The node processes a test's runs started, killed at its end (a stopped
/// run's nodes would otherwise wait a minute for a resume).
struct Leftovers(Vec<u32>);

impl Drop for Leftovers {
    fn drop(&mut self) {
        for &pid in &self.0 {
            let _ = Command::new("kill")
                .args(["-9", &pid.to_string()])
                .stderr(Stdio::null())
                .status();
        }
    }
}

/// The one line `motet resume` prints about where the nodes rest, which
/// must name every node in `nodes`: they rest on one committed point.
fn one_rest_line(stdout: &str, nodes: &str) {
    let rests: Vec<&str> = stdout
        .lines()
        .filter(|l| l.contains("at rest at the end of committed segment"))
        .collect();
    assert_eq!(rests.len(), 1, "{stdout}");
    assert!(rests[0].contains(nodes), "{stdout}");
}

#[test]
fn host_killed_every_node_on_the_group_rests_on_one_point_and_resume_finishes() {
    let _serial = serial();
    let tmp = common::scratch("bus", "host");
    let out = tmp.path().join("out");
    let mut host = start_run(tmp.path(), Stdio::null());
    wait_for_seals(&out, &mut host, 6);
    let _left = Leftovers(recorded(&out).iter().map(|n| n.3).collect());
    host.kill().unwrap();
    host.wait().unwrap();
    // The nodes run out the committed window (the lead, half a second)
    // and brake on its tail; the resume finds them at rest.
    std::thread::sleep(Duration::from_secs(3));
    let stdout = resume_to_done(&out, &[]);
    one_rest_line(&stdout, "nodes x_node, y_node, z_node are");
}

#[test]
fn one_cable_pulled_every_node_rests_on_one_point_and_resume_finishes() {
    let _serial = serial();
    let tmp = common::scratch("bus", "cable");
    let out = tmp.path().join("out");
    let log = tmp.path().join("host.log");
    let mut host = start_run(
        tmp.path(),
        Stdio::from(std::fs::File::create(&log).unwrap()),
    );
    wait_for_seals(&out, &mut host, 6);
    let nodes = recorded(&out);
    let _left = Leftovers(nodes.iter().map(|n| n.3).collect());
    // y_node's cable out: it neither hears nor is heard, and runs on.
    let y_pid = nodes[1].3;
    kill(y_pid, "-USR1");
    let status = host.wait().unwrap();
    let stderr = std::fs::read_to_string(&log).unwrap();
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains("nodes x_node, z_node came to rest at")
            && stderr.contains("node y_node was lost")
            && !stderr.contains("missed the last window"),
        "{stderr}"
    );
    // It brakes on the tail it was sent, and is plugged back in.
    std::thread::sleep(Duration::from_secs(2));
    kill(y_pid, "-USR1");
    let y_log = std::fs::read_to_string(out.join("node-y_node.log")).unwrap();
    assert!(y_log.contains("cable pulled"), "{y_log}");
    // All three on one point: the resume finds y_node where the others
    // are, with nothing assumed, and finishes the job.
    let stdout = resume_to_done(&out, &[]);
    one_rest_line(&stdout, "nodes x_node, y_node, z_node are");
}

#[test]
fn one_node_killed_the_others_rest_on_one_point_and_resume_finishes() {
    let _serial = serial();
    let tmp = common::scratch("bus", "node");
    let out = tmp.path().join("out");
    // Not piped: the stopped run leaves its nodes up, holding its stderr.
    let log = tmp.path().join("host.log");
    let mut host = start_run(
        tmp.path(),
        Stdio::from(std::fs::File::create(&log).unwrap()),
    );
    wait_for_seals(&out, &mut host, 6);
    let nodes = recorded(&out);
    let _left = Leftovers(nodes.iter().map(|n| n.3).collect());
    let (_, link, y_uid, y_pid) = nodes[1].clone();
    kill(y_pid, "-9");
    let status = host.wait().unwrap();
    let stderr = std::fs::read_to_string(&log).unwrap();
    assert!(!status.success(), "{stderr}");
    // The host names the node that died and where each other one stopped:
    // both on the end of the same window.
    assert!(
        stderr.contains("nodes x_node, z_node came to rest at")
            && stderr.contains("node y_node was lost")
            && !stderr.contains("missed the last window"),
        "{stderr}"
    );
    let stop: toml::Table =
        toml::from_str(&std::fs::read_to_string(out.join("stop.toml")).unwrap()).unwrap();
    assert_eq!(
        stop["at_rest"].as_array().unwrap(),
        &vec![toml::Value::from("x_node"), toml::Value::from("z_node")]
    );
    assert_eq!(
        stop["lost"].as_array().unwrap(),
        &vec![toml::Value::from("y_node")]
    );
    let y_at = stop["point"].as_array().unwrap()[1].as_float().unwrap();

    // The node comes back as a new process (its position lost) under its
    // uid; the resume gives it its address again.
    let mut back = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args(["node", "--sim", "--listen", &link, "--uid", &y_uid])
        .args(["--time-scale", "5", "--quiet", "--idle-exit", "60"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let (ok, _, stderr) = motet(&["resume", out.to_str().unwrap()]);
    assert!(
        !ok && stderr.contains("node y_node restarted") && stderr.contains("--assume-position"),
        "{stderr}"
    );
    let stdout = resume_to_done(&out, &["--assume-position", &format!("y={y_at}")]);
    one_rest_line(&stdout, "nodes x_node, z_node are");
    let _ = back.kill();
    let _ = back.wait();
}
