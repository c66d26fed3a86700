//! `motet serve` from the command line: on node processes it starts (UDP),
//! with a token when it listens beyond loopback, and its refusals at start.
//! (The page in a real browser is web.rs; every API route is tested in
//! crates/motet-serve/tests/api.rs.)

mod common;

use serde_json::Value;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

struct Serve {
    /// The server: it stops when this drops.
    _served: common::Served,
    addr: String,
    banner: Vec<String>,
    _dir: tempfile::TempDir,
    dir: std::path::PathBuf,
}

/// Starts `motet serve ARGS` in a scratch folder of its own.
fn serve(args: &[&str]) -> Serve {
    let dir = common::scratch("serve", "cli");
    let served = common::serve(args, dir.path());
    Serve {
        addr: served.addr.clone(),
        banner: served.banner.clone(),
        _served: served,
        dir: dir.path().to_path_buf(),
        _dir: dir,
    }
}

/// One HTTP request on a fresh connection: (status, JSON body).
fn http(addr: &str, method: &str, path: &str, body: &[u8], token: Option<&str>) -> (u16, Value) {
    http_as("cli", addr, method, path, body, token)
}

/// [`http`] from the client named `client`.
fn http_as(
    client: &str,
    addr: &str,
    method: &str,
    path: &str,
    body: &[u8],
    token: Option<&str>,
) -> (u16, Value) {
    let addr = addr.replace("0.0.0.0", "127.0.0.1");
    let mut s = TcpStream::connect(&addr).unwrap();
    let auth = token.map_or(String::new(), |t| format!("Authorization: Bearer {t}\r\n"));
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nX-Motet-Client: {client}\r\n{auth}Content-Type: application/json\r\nContent-Length: {}\r\n\r\n",
        body.len()
    )
    .unwrap();
    s.write_all(body).unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let code = text[9..12].parse().unwrap();
    let body = text.split_once("\r\n\r\n").map_or("", |b| b.1);
    (code, serde_json::from_str(body).unwrap_or(Value::Null))
}

fn wait_state(s: &Serve, want: &str, max: Duration) -> Value {
    let end = Instant::now() + max;
    loop {
        let (_, st) = http(&s.addr, "GET", "/api/status", b"", None);
        if st["state"] == want && st["connecting"] == false {
            return st;
        }
        assert!(
            Instant::now() < end,
            "state {st} after {max:?}, want {want}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_job_runs_held_and_resumed_on_spawned_node_processes() {
    let s = serve(&[
        "examples/plotter.toml",
        "--nodes",
        "spawn",
        "--listen",
        "127.0.0.1:0",
    ]);
    let (code, nodes) = http(&s.addr, "GET", "/api/nodes", b"", None);
    assert_eq!(code, 200);
    let n = &nodes[0];
    assert_eq!(n["kind"], "spawn", "{nodes}");
    assert!(
        n["address"].as_str().unwrap().starts_with("udp:"),
        "{nodes}"
    );
    assert!(!n["firmware"].as_str().unwrap().is_empty());
    let job = b"G21 G90\nG0 X10 Y10\nM3 S1000\nG1 X60 Y10 F1200\nG1 X60 Y40\nG1 X10 Y40\nG1 X10 Y10\nM5\nG0 X5 Y5\n";
    let (code, j) = http(&s.addr, "POST", "/api/jobs?name=square.gcode", job, None);
    assert_eq!(code, 201, "{j}");
    wait_state(&s, "idle", Duration::from_secs(20));
    let (code, r) = http(
        &s.addr,
        "POST",
        &format!("/api/jobs/{}/start", j["id"]),
        b"",
        None,
    );
    assert_eq!(code, 200, "{r}");
    std::thread::sleep(Duration::from_millis(1500));
    let (code, r) = http(&s.addr, "POST", "/api/pause", b"", None);
    assert_eq!(code, 200, "{r}");
    let held = wait_state(&s, "paused", Duration::from_secs(10));
    let p = &held["position"];
    let on_square = |x: f64, y: f64| {
        let on = |a: f64, b: f64| (a - b).abs() < 1e-3;
        ((on(y, 10.0) || on(y, 40.0)) && (9.999..=60.001).contains(&x))
            || ((on(x, 10.0) || on(x, 60.0)) && (9.999..=40.001).contains(&y))
            || (x - y).abs() < 1e-3 // the travel in
    };
    let (x, y) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
    assert!(on_square(x, y), "held at {x}, {y}: off the job's path");
    let (code, _) = http(&s.addr, "POST", "/api/resume", b"", None);
    assert_eq!(code, 200);
    let done = wait_state(&s, "idle", Duration::from_secs(30));
    assert_eq!(done["position"], serde_json::json!([5.0, 5.0]), "{done}");
}

#[test]
fn the_server_pairs_its_node_processes_and_writes_the_pairing_file() {
    let tmp = common::scratch("serve", "pair");
    let machine = tmp.path().join("plotter.toml");
    std::fs::copy(common::root().join("examples/plotter.toml"), &machine).unwrap();
    let s = serve(&[
        machine.to_str().unwrap(),
        "--nodes",
        "spawn",
        "--listen",
        "127.0.0.1:0",
    ]);
    let before = wait_state(&s, "idle", Duration::from_secs(20));
    let (_, nodes) = http(&s.addr, "GET", "/api/nodes", b"", None);
    let link = nodes[0]["address"].as_str().unwrap().to_string();
    // Only the client in control pairs.
    let (code, _) = http(&s.addr, "POST", "/api/control", b"", None);
    assert_eq!(code, 200);
    let (code, r) = http_as("other", &s.addr, "POST", "/api/nodes/pair", b"", None);
    assert_eq!(code, 409, "{r}");
    assert!(
        r["error"].as_str().unwrap().contains("another client"),
        "{r}"
    );
    let pairing = tmp.path().join("plotter.nodes.toml");
    assert!(!pairing.exists(), "a refused pairing wrote the file");

    let (code, r) = http(&s.addr, "POST", "/api/nodes/pair", b"", None);
    assert_eq!(code, 200, "{r}");
    assert!(
        r["paired"][0]
            .as_str()
            .unwrap()
            .contains("is now address 2"),
        "{r}"
    );
    assert_eq!(r["file"], pairing.display().to_string(), "{r}");
    let text = std::fs::read_to_string(&pairing).unwrap();
    assert!(
        text.contains("[nodes.ebb]") && text.contains(&link),
        "{text}"
    );
    let (_, events) = http(&s.addr, "GET", "/api/events", b"", None);
    assert!(
        events.to_string().contains("nodes paired"),
        "no event: {events}"
    );

    // The server goes on with the node at its address: a jog moves it.
    wait_state(&s, "idle", Duration::from_secs(20));
    let jog = |body: &[u8]| http(&s.addr, "POST", "/api/jog", body, None);
    let (code, r) = jog(br#"{"axes": {"x": 5}, "feed": 50}"#);
    assert_eq!(code, 200, "{r}");
    let after = wait_state(&s, "idle", Duration::from_secs(20));
    let moved = after["position"][0].as_f64().unwrap() - before["position"][0].as_f64().unwrap();
    assert!((moved - 5.0).abs() < 1e-6, "{before} {after}");

    // While the machine moves, pairing is refused.
    let (code, _) = jog(br#"{"axes": {"x": 20}, "feed": 5}"#);
    assert_eq!(code, 200);
    let (code, r) = http(&s.addr, "POST", "/api/nodes/pair", b"", None);
    assert_eq!(code, 409, "{r}");
    assert!(r["error"].as_str().unwrap().contains("while"), "{r}");
    let (code, _) = http(&s.addr, "POST", "/api/cancel", b"", None);
    assert_eq!(code, 200);
}

#[test]
fn beyond_loopback_every_request_needs_the_token() {
    let s = serve(&["examples/plotter.toml", "--listen", "0.0.0.0:0"]);
    let line = s
        .banner
        .iter()
        .find(|l| l.starts_with("token"))
        .expect("the token is shown");
    let token = line.rsplit(' ').next().unwrap();
    let kept = std::fs::read_to_string(s.dir.join("token")).unwrap();
    assert_eq!(kept.trim(), token);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(s.dir.join("token"))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o777, 0o600);
    }
    assert_eq!(http(&s.addr, "GET", "/api/status", b"", None).0, 401);
    assert_eq!(
        http(&s.addr, "POST", "/api/estop", b"", Some("nope")).0,
        401
    );
    assert_eq!(http(&s.addr, "GET", "/api/status", b"", Some(token)).0, 200);
}

#[test]
fn a_server_that_cannot_start_says_why() {
    let dir = common::scratch("serve", "bad");
    let d = dir.path().to_str().unwrap();
    for (args, words) in [
        (vec!["examples/nothing.toml"], "nothing.toml"),
        (
            vec!["examples/plotter.toml", "--nodes", "paired"],
            "pair the nodes first",
        ),
        (vec!["examples/plotter.toml", "--nodes", "mars"], "--nodes"),
        (
            vec!["examples/plotter.toml", "--listen", "localhost"],
            "--listen",
        ),
        (
            vec![
                "examples/plotter.toml",
                "--listen",
                "127.0.0.1:0",
                "--grbl",
                "tcp:0.0.0.0:0",
            ],
            "carries no token",
        ),
    ] {
        let mut all = vec!["serve"];
        all.extend(&args);
        all.extend(["--dir", d]);
        let (ok, _, err) = common::motet(&all);
        assert!(!ok, "{args:?} started");
        assert!(
            err.contains(words),
            "{args:?}: {err:?} does not say {words:?}"
        );
    }
}
