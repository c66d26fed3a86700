//! The HTTP API against a real server on a loopback port (in this process,
//! on simulated nodes): every route, a job from upload to emergency stop
//! with the WebSocket watching, and every refusal. Each answer is checked
//! against the schema (openapi.json).

use motet_serve::{serve_config, Server, ServerConfig, SimNodes, ROUTES};
use serde_json::{json, Value};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

struct Running {
    base: String,
    token: Option<String>,
    dir: Option<tempfile::TempDir>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Running {
    fn start(token: Option<&str>) -> Running {
        Running::start_in(token, tempfile::tempdir().unwrap())
    }

    /// A server on `dir`, as one restarted on the same folder.
    fn start_in(token: Option<&str>, dir: tempfile::TempDir) -> Running {
        Running::start_with(token, dir, "examples/plotter.toml", None)
    }

    /// A server for the machine file `machine`, driven by hand through
    /// `graph` if given.
    fn start_with(
        token: Option<&str>,
        dir: tempfile::TempDir,
        machine: &str,
        graph: Option<&str>,
    ) -> Running {
        let m = motet_host::Machine::load(&root().join(machine)).unwrap();
        let graph = graph.map(|g| motet_graph::GraphFile::load(&root().join(g)).unwrap());
        let cfg = ServerConfig {
            listen: "127.0.0.1:0".parse().unwrap(),
            dir: dir.path().to_path_buf(),
            token: token.map(String::from),
        };
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let (addr_tx, addr_rx) = std::sync::mpsc::channel();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Runtime::new().unwrap();
            rt.block_on(async move {
                let listener = tokio::net::TcpListener::bind(cfg.listen).await.unwrap();
                addr_tx.send(listener.local_addr().unwrap()).unwrap();
                let nodes = Box::new(SimNodes::new(&m, m.start, serve_config()));
                let server = Server::start(m, nodes, &cfg).unwrap();
                if let Some(g) = graph {
                    server.drive_by_graph(g).unwrap();
                }
                server
                    .serve(listener, async {
                        let _ = rx.await;
                    })
                    .await
                    .unwrap();
            });
        });
        let addr = addr_rx.recv().unwrap();
        Running {
            base: format!("http://{addr}"),
            token: token.map(String::from),
            dir: Some(dir),
            stop: Some(tx),
            thread: Some(thread),
        }
    }

    /// Sends a request; returns the status and the JSON body.
    fn call(&self, method: &str, path: &str, body: Option<Value>, client: &str) -> (u16, Value) {
        let bytes = body.map(|b| b.to_string().into_bytes());
        self.raw(
            method,
            path,
            bytes.as_deref(),
            client,
            self.token.as_deref(),
            "application/json",
        )
    }

    fn raw(
        &self,
        method: &str,
        path: &str,
        body: Option<&[u8]>,
        client: &str,
        token: Option<&str>,
        content_type: &str,
    ) -> (u16, Value) {
        let mut req = ureq::request(method, &format!("{}{path}", self.base))
            .set("X-Motet-Client", client)
            .set("Content-Type", content_type);
        if let Some(t) = token {
            req = req.set("Authorization", &format!("Bearer {t}"));
        }
        let got = match body {
            Some(b) => req.send_bytes(b),
            None => req.call(),
        };
        let resp = match got {
            Ok(r) => r,
            Err(ureq::Error::Status(_, r)) => r,
            Err(e) => panic!("{method} {path}: {e}"),
        };
        let code = resp.status();
        let text = resp.into_string().unwrap();
        let v = serde_json::from_str(&text).unwrap_or(Value::String(text));
        (code, v)
    }

    fn upload(&self, name: &str, bytes: &[u8]) -> (u16, Value) {
        self.upload_with(name, bytes, "")
    }

    fn upload_with(&self, name: &str, bytes: &[u8], query: &str) -> (u16, Value) {
        let path = format!("/api/jobs?name={}{query}", urlencode(name));
        self.raw(
            "POST",
            &path,
            Some(bytes),
            "a",
            self.token.as_deref(),
            "application/octet-stream",
        )
    }

    fn status(&self) -> Value {
        self.call("GET", "/api/status", None, "a").1
    }

    /// Polls the status until its state is `want`.
    fn until(&self, want: &str, max: Duration) -> Value {
        let end = Instant::now() + max;
        loop {
            let s = self.status();
            if s["state"] == want {
                return s;
            }
            assert!(
                Instant::now() < end,
                "state {} after {max:?}, want {want}",
                s["state"]
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Running {
    fn dir(&self) -> &Path {
        self.dir.as_ref().unwrap().path()
    }

    /// Stops this server and starts another on the same folder.
    fn restart(mut self) -> Running {
        let dir = self.dir.take().unwrap();
        let token = self.token.clone();
        drop(self);
        Running::start_in(token.as_deref(), dir)
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn urlencode(s: &str) -> String {
    s.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'.' | b'-' | b'_' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// Checks `v` against the schema's component `name`.
fn check_schema(name: &str, v: &Value) {
    let spec: Value =
        serde_json::from_str(include_str!("../openapi.json")).expect("openapi.json is JSON");
    let schema = json!({
        "$ref": format!("#/components/schemas/{name}"),
        "components": spec["components"],
    });
    let validator = jsonschema::validator_for(&schema).expect("the schema compiles");
    let errors: Vec<String> = validator.iter_errors(v).map(|e| e.to_string()).collect();
    assert!(errors.is_empty(), "{name}: {errors:?}\n{v}");
}

#[test]
fn every_route_is_served_and_a_job_runs_from_upload_to_stop() {
    let s = Running::start(None);
    // Every route the schema lists answers (not the fallback's 404).
    for (method, path) in ROUTES {
        let path = path.replace("{id}", "999");
        let (code, body) = s.call(&method.to_uppercase(), &path, None, "a");
        let missing = body["error"]
            .as_str()
            .is_some_and(|e| e.starts_with("no such route"));
        assert!(!missing, "{method} {path}: {code} {body}");
    }
    let (code, machine) = s.call("GET", "/api/machine", None, "a");
    assert_eq!(code, 200);
    check_schema("Machine", &machine);
    let (_, nodes) = s.call("GET", "/api/nodes", None, "a");
    for n in nodes.as_array().unwrap() {
        check_schema("Node", n);
        assert_eq!(n["identifying"], false, "{n}");
    }
    // Identify lights the node's LED, in any state, for any client.
    let (code, body) = s.call(
        "POST",
        "/api/nodes/ebb/identify",
        Some(json!({"seconds": 2})),
        "z",
    );
    assert_eq!(code, 200, "{body}");
    let end = Instant::now() + Duration::from_secs(2);
    while s.call("GET", "/api/nodes", None, "a").1[0]["identifying"] != true {
        assert!(Instant::now() < end, "the node's LED never came on");
        std::thread::sleep(Duration::from_millis(10));
    }
    let svg = std::fs::read(root().join("examples/jobs/drawing.svg")).unwrap();
    let (code, job) = s.upload("drawing.svg", &svg);
    assert_eq!(code, 201, "{job}");
    check_schema("Job", &job);
    let id = job["id"].as_u64().unwrap();
    let (code, preview) = s.call("GET", &format!("/api/jobs/{id}/preview"), None, "a");
    assert_eq!(code, 200);
    check_schema("Preview", &preview);
    assert!(preview["strokes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s["on"] == true));

    // Watch over the WebSocket while the job runs.
    let (mut ws, _) =
        tungstenite::connect(format!("{}/api/ws", s.base.replace("http", "ws"))).unwrap();
    let (code, body) = s.call("POST", &format!("/api/jobs/{id}/start"), None, "a");
    assert_eq!(code, 200, "{body}");
    let (code, body) = s.call("POST", &format!("/api/jobs/{id}/start"), None, "a");
    assert_eq!(code, 409, "a second start while running: {body}");
    let mut positions = std::collections::BTreeSet::new();
    let end = Instant::now() + Duration::from_secs(20);
    while positions.len() < 10 {
        assert!(
            Instant::now() < end,
            "the position did not move: {positions:?}"
        );
        let msg = ws.read().unwrap();
        let Ok(text) = msg.to_text() else { continue };
        let v: Value = serde_json::from_str(text).unwrap();
        check_schema("PushMessage", &v);
        positions.insert(v["status"]["position"].to_string());
    }
    // Another client cannot hold the job; the one in control can.
    let (code, _) = s.call("POST", "/api/pause", None, "b");
    assert_eq!(code, 409);
    let (code, body) = s.call("POST", "/api/pause", None, "a");
    assert_eq!(code, 200, "{body}");
    let held = s.until("paused", Duration::from_secs(10));
    check_schema("Status", &held);
    let (code, _) = s.call("POST", "/api/resume", None, "a");
    assert_eq!(code, 200);
    s.until("running", Duration::from_secs(2));
    std::thread::sleep(Duration::from_millis(300));
    // The emergency stop is honoured from any client.
    let (code, _) = s.call("POST", "/api/estop", None, "b");
    assert_eq!(code, 200);
    let stopped = s.until("stopped", Duration::from_secs(10));
    assert_eq!(stopped["reason"], "emergency stop");
    let (_, events) = s.call("GET", "/api/events?since=0", None, "a");
    for e in events.as_array().unwrap() {
        check_schema("Event", e);
    }
    let said: Vec<&str> = events
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["message"].as_str().unwrap())
        .collect();
    for want in [
        "started",
        "held at rest",
        "resumed",
        "emergency stop: every node at rest",
    ] {
        assert!(
            said.iter().any(|m| m.contains(want)),
            "no event {want:?} in {said:?}"
        );
    }
    let (_, history) = s.call("GET", "/api/history", None, "a");
    assert_eq!(history.as_array().unwrap().len(), 1, "{history}");
    check_schema("JobOutcome", &history[0]);
    assert_eq!(history[0]["outcome"], "emergency stop");
    assert_eq!(history[0]["id"], id);
    let (code, _) = s.call("POST", "/api/unlock", None, "a");
    assert_eq!(code, 200);
    let (code, body) = s.call(
        "POST",
        "/api/jog",
        Some(json!({"axes": {"x": 5}, "feed": 100})),
        "a",
    );
    assert_eq!(code, 200, "{body}");
    s.until("idle", Duration::from_secs(10));
}

/// A refused request: method, path, body, content type, status, words in
/// the error.
type Refused<'a> = (&'a str, &'a str, Option<&'a [u8]>, &'a str, u16, &'a str);

#[test]
fn bad_requests_are_refused_with_their_reason_and_nothing_changes() {
    let s = Running::start(None);
    let outside = b"G0 X10 Y10\nG1 X9000 Y10 F600\n";
    let cases: &[Refused] = &[
        (
            "POST",
            "/api/jobs?name=part.docx",
            Some(b"x"),
            "application/octet-stream",
            400,
            ".docx",
        ),
        (
            "POST",
            "/api/jobs?name=empty.svg",
            Some(b""),
            "application/octet-stream",
            400,
            "empty",
        ),
        (
            "POST",
            "/api/jobs?name=far.gcode",
            Some(outside),
            "application/octet-stream",
            422,
            "far.gcode:2",
        ),
        (
            "POST",
            "/api/jobs?name=bad.svg",
            Some(b"<svg"),
            "application/octet-stream",
            422,
            "bad.svg",
        ),
        (
            "POST",
            "/api/jobs",
            Some(b"G0 X1"),
            "application/octet-stream",
            400,
            "name",
        ),
        (
            "POST",
            "/api/jobs?name=a.svg&colour=red",
            Some(b"x"),
            "application/octet-stream",
            400,
            "colour",
        ),
        (
            "POST",
            "/api/jog",
            Some(b"{\"axes\": {\"x\": 1}"),
            "application/json",
            400,
            "EOF",
        ),
        (
            "POST",
            "/api/jog",
            Some(b"{\"axes\": {}, \"speed\": 3}"),
            "application/json",
            400,
            "speed",
        ),
        (
            "POST",
            "/api/jog",
            Some(b"{\"axes\": {\"x\": 1e6}}"),
            "application/json",
            422,
            "travel",
        ),
        (
            "POST",
            "/api/jog",
            Some(b"{\"axes\": {\"w\": 1}}"),
            "application/json",
            422,
            "no axis",
        ),
        (
            "POST",
            "/api/jog",
            Some(b"{\"axes\": {\"x\": 1}, \"feed\": -2}"),
            "application/json",
            422,
            "feed",
        ),
        (
            "POST",
            "/api/tool",
            Some(b"{\"tool\": \"pen\", \"value\": 7}"),
            "application/json",
            422,
            "tool value",
        ),
        (
            "POST",
            "/api/tool",
            Some(b"{\"tool\": \"drill\", \"value\": 1}"),
            "application/json",
            422,
            "no tool",
        ),
        (
            "POST",
            "/api/position",
            Some(b"[1, 2]"),
            "application/json",
            400,
            "line 1 column",
        ),
        ("POST", "/api/pause", None, "application/json", 409, "idle"),
        (
            "POST",
            "/api/nodes/zz/identify",
            Some(b"{}"),
            "application/json",
            404,
            "no node `zz`",
        ),
        (
            "POST",
            "/api/nodes/ebb/identify",
            Some(b"{\"seconds\": 99}"),
            "application/json",
            422,
            "seconds",
        ),
        ("POST", "/api/resume", None, "application/json", 409, "idle"),
        // Nodes simulated in the server have no link to pair on.
        (
            "POST",
            "/api/nodes/pair",
            None,
            "application/json",
            409,
            "nothing to pair",
        ),
        (
            "POST",
            "/api/jobs/77/start",
            None,
            "application/json",
            404,
            "no job 77",
        ),
        (
            "GET",
            "/api/jobs/x",
            None,
            "application/json",
            404,
            "no job",
        ),
        (
            "GET",
            "/api/events?since=-1",
            None,
            "application/json",
            400,
            "since",
        ),
        (
            "GET",
            "/api/nothing",
            None,
            "application/json",
            404,
            "no such route",
        ),
    ];
    for &(method, path, body, ct, want, words) in cases {
        let (code, v) = s.raw(method, path, body, "a", None, ct);
        assert_eq!(code, want, "{method} {path}: {v}");
        let text = v["error"]
            .as_str()
            .unwrap_or_else(|| panic!("{method} {path}: no error in {v}"));
        assert!(
            text.contains(words),
            "{method} {path}: {text:?} does not say {words:?}"
        );
        check_schema("Error", &v);
    }
    // Too large: refused before it is stored.
    let big = vec![b'G'; motet_serve::jobs::MAX_UPLOAD + 1];
    let (code, _) = s.upload("big.gcode", &big);
    assert_eq!(code, 413);
    // A path in the name reaches no file system: the job is stored under
    // the server's folder with a name the server made.
    let svg = std::fs::read(root().join("examples/jobs/drawing.svg")).unwrap();
    let (code, job) = s.upload("../../escape.svg", &svg);
    assert_eq!(code, 201, "{job}");
    assert_eq!(job["name"], "escape.svg");
    assert!(!s.dir().join("../escape.svg").exists());
    assert!(!s.dir().join("../../escape.svg").exists());
    let stored: Vec<String> = std::fs::read_dir(s.dir().join("jobs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(stored, vec![format!("{}.svg", job["id"])]);
    // Placement: fitted with a 10 mm margin, centred in the travel.
    let (code, job) = s.upload_with("drawing.svg", &svg, "&fit=10");
    assert_eq!(code, 201, "{job}");
    check_schema("Job", &job);
    let m = s.call("GET", "/api/machine", None, "a").1;
    for (i, axis) in m["axes"].as_array().unwrap().iter().take(2).enumerate() {
        let lo = axis["travel"][0].as_f64().unwrap();
        let hi = axis["travel"][1].as_f64().unwrap();
        let min = job["placed"]["min"][i].as_f64().unwrap();
        let max = job["placed"]["max"][i].as_f64().unwrap();
        assert!(
            min >= lo + 10.0 - 1e-6 && max <= hi - 10.0 + 1e-6,
            "axis {i}: {min}..{max} in {lo}..{hi}"
        );
        assert!(
            ((min + max) / 2.0 - (lo + hi) / 2.0).abs() < 1e-6,
            "axis {i} not centred: {min}..{max}"
        );
    }
    let b = &job["bounds"];
    assert!(
        b[2].as_f64().unwrap() <= job["placed"]["max"][0].as_f64().unwrap() + 1e-6,
        "{b}"
    );
    // Nothing moved and nothing is queued.
    let st = s.status();
    assert_eq!(st["state"], "idle");
    assert!(st["job"].is_null());
    assert_eq!(st["position"], json!([0.0, 0.0]));
}

#[test]
fn a_server_with_a_token_refuses_requests_without_it() {
    let token = "0123456789abcdef0123456789abcdef";
    let s = Running::start(Some(token));
    for (given, want) in [(None, 401), (Some("wrong"), 401), (Some(token), 200)] {
        let (code, v) = s.raw("GET", "/api/status", None, "a", given, "application/json");
        assert_eq!(code, want, "{given:?}: {v}");
    }
    let (code, _) = s.raw("POST", "/api/estop", None, "a", None, "application/json");
    assert_eq!(code, 401);
    // The query form, for the page and its WebSocket.
    let (code, _) = s.raw(
        "GET",
        &format!("/api/status?token={token}"),
        None,
        "a",
        None,
        "x",
    );
    assert_eq!(code, 200);
    let ws = format!("{}/api/ws", s.base.replace("http", "ws"));
    assert!(tungstenite::connect(&ws).is_err());
    assert!(tungstenite::connect(format!("{ws}?token={token}")).is_ok());
    // The page's own files load without it; they hold nothing of the machine.
    let (code, _) = s.raw("GET", "/", None, "a", None, "x");
    assert_eq!(code, 200);
    let _ = TcpStream::connect(s.base.trim_start_matches("http://")).unwrap();
}

#[test]
fn hundreds_of_watchers_and_a_client_gone_mid_upload_leave_the_machine_safe() {
    use std::io::Write;
    let s = Running::start(None);
    let ws = format!("{}/api/ws", s.base.replace("http", "ws"));
    let mut watchers: Vec<_> = (0..200)
        .map(|_| tungstenite::connect(&ws).unwrap().0)
        .collect();
    // A client that promises a large upload, sends a little and goes.
    let addr = s.base.trim_start_matches("http://").to_string();
    let mut c = TcpStream::connect(&addr).unwrap();
    write!(
        c,
        "POST /api/jobs?name=half.gcode HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 100000\r\n\r\nG0 X10\nG1 X"
    )
    .unwrap();
    drop(c);
    // Every watcher hears the machine; the API still answers quickly, and
    // an emergency stop is taken.
    for w in watchers.iter_mut() {
        let msg = w.read().unwrap();
        let v: Value = serde_json::from_str(msg.to_text().unwrap()).unwrap();
        assert_eq!(v["type"], "status");
    }
    let t = Instant::now();
    let (code, _) = s.call("POST", "/api/estop", None, "x");
    assert_eq!(code, 200);
    eprintln!(
        "estop answered in {:?} with {} watchers",
        t.elapsed(),
        watchers.len()
    );
    s.until("stopped", Duration::from_secs(5));
    drop(watchers);
    // The half upload left nothing behind.
    let (_, jobs) = s.call("GET", "/api/jobs", None, "a");
    assert_eq!(jobs, json!([]));
    assert_eq!(std::fs::read_dir(s.dir().join("jobs")).unwrap().count(), 0);
}

/// Polls the history until it holds `n` entries.
fn history_of(s: &Running, n: usize, max: Duration) -> Vec<Value> {
    let end = Instant::now() + max;
    loop {
        let (_, h) = s.call("GET", "/api/history", None, "a");
        let h = h.as_array().unwrap().clone();
        if h.len() >= n {
            return h;
        }
        assert!(Instant::now() < end, "history {h:?} after {max:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn the_queue_runs_jobs_in_turn_and_a_restarted_server_keeps_jobs_queue_and_history() {
    let s = Running::start(None);
    let mut ids = Vec::new();
    for (name, gcode) in [
        ("one.gcode", "G0 X10 Y10\nG1 X20 F6000\n"),
        ("two.gcode", "G0 X30 Y10\nG1 Y20 F6000\n"),
    ] {
        let (code, job) = s.upload(name, gcode.as_bytes());
        assert_eq!(code, 201, "{job}");
        ids.push(job["id"].as_u64().unwrap());
    }
    for &id in &ids {
        let (code, q) = s.call("POST", "/api/queue", Some(json!({ "job": id })), "a");
        assert_eq!(code, 200, "{q}");
        check_schema("Queue", &q);
    }
    // Refusals change nothing.
    for (method, path, body, want) in [
        ("POST", "/api/queue", Some(json!({ "job": 999 })), 404),
        ("POST", "/api/queue", Some(json!({ "id": ids[0] })), 400),
        ("DELETE", "/api/queue/2", None, 404),
        ("DELETE", "/api/queue/x", None, 404),
    ] {
        let (code, body) = s.call(method, path, body, "a");
        assert_eq!(code, want, "{method} {path}: {body}");
    }
    assert_eq!(s.status()["queued"], 2);

    let (code, q) = s.call("POST", "/api/queue/start", None, "a");
    assert_eq!(code, 200, "{q}");
    assert_eq!(q["running"], true);
    let h = history_of(&s, 2, Duration::from_secs(30));
    let ran: Vec<_> = h
        .iter()
        .map(|e| (e["id"].as_u64().unwrap(), e["outcome"].as_str().unwrap()))
        .collect();
    assert_eq!(ran, [(ids[0], "finished"), (ids[1], "finished")]);
    for e in &h {
        check_schema("JobOutcome", e);
    }
    let (_, q) = s.call("GET", "/api/queue", None, "a");
    assert_eq!(q, json!({ "running": false, "jobs": [] }));
    let end = s.status();
    assert_eq!(end["position"][0], 30.0, "the second job's end: {end}");
    assert_eq!(end["position"][1], 20.0, "the second job's end: {end}");
    let (code, body) = s.call("POST", "/api/queue/start", None, "a");
    assert_eq!(code, 409, "an empty queue: {body}");

    // Queue both again; a restarted server has the jobs (same ids), the
    // queue (halted) and the history, and gives new uploads new ids.
    for &id in ids.iter().rev() {
        s.call("POST", "/api/queue", Some(json!({ "job": id })), "a");
    }
    let s = s.restart();
    let (_, jobs) = s.call("GET", "/api/jobs", None, "a");
    let kept: Vec<_> = jobs
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_u64().unwrap())
        .collect();
    assert_eq!(kept, ids);
    let (_, q) = s.call("GET", "/api/queue", None, "a");
    let queued: Vec<_> = q["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_u64().unwrap())
        .collect();
    assert_eq!(queued, [ids[1], ids[0]]);
    assert_eq!(q["running"], false);
    assert_eq!(history_of(&s, 2, Duration::ZERO), h);
    let (code, job) = s.upload("three.gcode", b"G0 X5 Y5\n");
    assert_eq!(code, 201, "{job}");
    assert_eq!(job["id"].as_u64().unwrap(), ids[1] + 1);

    // A kept state that does not read is set aside, not lost, and said.
    std::fs::write(s.dir().join("state.json"), "{ not json").unwrap();
    let s = s.restart();
    let (_, ev) = s.call("GET", "/api/events?since=0", None, "a");
    assert!(s.dir().join("state.json.bad").exists(), "{ev}");
    let (_, events) = s.call("GET", "/api/events?since=0", None, "a");
    let said = events.as_array().unwrap().iter().any(|e| {
        e["message"]
            .as_str()
            .unwrap()
            .contains("kept state not read")
    });
    assert!(said, "{events}");
    let (_, jobs) = s.call("GET", "/api/jobs", None, "a");
    assert_eq!(jobs, json!([]));

    // A job that does not finish halts the queue; the rest wait.
    for name in ["long.gcode", "next.gcode"] {
        let (_, job) = s.upload(name, b"G0 X10 Y10\nG1 X200 F600\n");
        let id = job["id"].as_u64().unwrap();
        s.call("POST", "/api/queue", Some(json!({ "job": id })), "a");
    }
    let (code, _) = s.call("POST", "/api/queue/start", None, "a");
    assert_eq!(code, 200);
    s.call("POST", "/api/estop", None, "b");
    s.until("stopped", Duration::from_secs(10));
    let (_, q) = s.call("GET", "/api/queue", None, "a");
    assert_eq!(q["running"], false, "{q}");
    assert_eq!(q["jobs"][0]["name"], "next.gcode", "{q}");
    let h = history_of(&s, 1, Duration::ZERO);
    assert_eq!(h[0]["outcome"], "emergency stop", "{h:?}");
}

/// The game controller's machine and graph.
const GAME: (&str, &str) = (
    "examples/dance/game-controller/machine.toml",
    "examples/dance/game-controller/graph.toml",
);

/// A server driven by hand through the game controller's graph, and its
/// graph as first read (checked against the schema).
fn hand_driven() -> (Running, Value) {
    let s = Running::start_with(None, tempfile::tempdir().unwrap(), GAME.0, Some(GAME.1));
    let (code, g) = s.call("GET", "/api/graph", None, "a");
    assert_eq!(code, 200, "{g}");
    check_schema("Graph", &g);
    (s, g)
}

/// Where the game controller's graph, fed by `inputs` offline for 3 s,
/// leaves the pen.
fn offline_end(inputs: &mut dyn motet_sim::dance::InputSource) -> [f64; 2] {
    let m = motet_host::Machine::load(&root().join(GAME.0)).unwrap();
    let g = motet_graph::GraphFile::load(&root().join(GAME.1)).unwrap();
    motet_sim::dance::run_dance(&m, &g, inputs, 3.0, &mut |_| {})
        .unwrap()
        .report
        .final_xy
}

/// Turns the knobs to 300 and −200 counts over the API.
fn turn_knobs(s: &Running) {
    let body = json!({"knob_x": 300, "knob_y": -200});
    let (code, g) = s.call("POST", "/api/graph/inputs", Some(body), "b");
    assert_eq!(code, 200, "{g}");
}

/// Waits until the server's pen is at `want`.
fn pen_reaches(s: &Running, want: [f64; 2]) {
    let end = Instant::now() + Duration::from_secs(30);
    loop {
        let (_, g) = s.call("GET", "/api/graph", None, "a");
        let p = [
            g["position"][0].as_f64().unwrap(),
            g["position"][1].as_f64().unwrap(),
        ];
        if (p[0] - want[0]).hypot(p[1] - want[1]) < 1e-9 {
            return;
        }
        assert!(Instant::now() < end, "at {p:?}, want {want:?}: {g}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_hand_driven_machine_follows_its_graph_inputs_set_over_the_api() {
    let (s, g) = hand_driven();
    let inputs: Vec<_> = g["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| {
            (
                i["name"].as_str().unwrap(),
                i["kind"].as_str().unwrap(),
                i["value"].as_f64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        inputs,
        [
            ("joy_x", "analog", 512.0),
            ("joy_y", "analog", 512.0),
            ("knob_x", "encoder", 0.0),
            ("knob_y", "encoder", 0.0)
        ]
    );
    // Turn the knobs; the machine ends where the same graph, fed the same
    // values offline, puts it.
    turn_knobs(&s);
    let mut held = motet_sim::dance::HeldInputs(vec![512.0, 512.0, 300.0, -200.0]);
    let got = offline_end(&mut held);
    pen_reaches(&s, got);
    assert!(
        got[0].hypot(got[1]) > 5.0,
        "the knobs moved nothing: {got:?}"
    );

    // Wrong inputs change nothing; the machine takes no jobs meanwhile.
    for (body, want) in [
        (json!({"knob_x": 5, "nope": 1}), 422),
        (json!({"knob_x": 1e300}), 422),
        (json!({"joy_x": -1}), 422),
        (json!({"joy_y": 5000}), 422),
        (json!({"knob_x": "five"}), 400),
        (json!([1, 2]), 400),
    ] {
        let (code, answer) = s.call("POST", "/api/graph/inputs", Some(body.clone()), "a");
        assert_eq!(code, want, "{body}: {answer}");
    }
    let (_, g) = s.call("GET", "/api/graph", None, "a");
    assert_eq!(g["inputs"][2]["value"], 300.0);
    assert_eq!(g["error"], Value::Null, "the graph still runs: {g}");
    let (code, job) = s.upload("one.gcode", b"G0 X1 Y1\n");
    assert_eq!(code, 201, "{job}");
    let id = job["id"].as_u64().unwrap();
    let (code, answer) = s.call("POST", &format!("/api/jobs/{id}/start"), None, "a");
    assert_eq!(code, 409, "{answer}");
    assert!(
        answer["error"].as_str().unwrap().contains("by hand"),
        "{answer}"
    );
    let (code, _) = s.call("POST", "/api/jog", Some(json!({"axes": {"x": 1}})), "a");
    assert_eq!(code, 409);
}

#[test]
fn a_hand_driven_machines_component_parameters_are_set_live_over_the_api() {
    let (s, g) = hand_driven();
    let param = |g: &Value, comp: &str, name: &str| -> Value {
        let c = g["components"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["name"] == comp)
            .unwrap_or_else(|| panic!("no component {comp}: {g}"));
        c["params"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("no parameter {comp}.{name}: {g}"))
            .clone()
    };
    assert_eq!(param(&g, "knob_x", "invert")["value"], 0.0);
    assert_eq!(param(&g, "joy_x", "floor_value")["value"], -40.0);
    assert_eq!(param(&g, "ch_a", "max_pulse_rate")["min"], 0.0);
    assert_eq!(g["param_changes"], 0);

    // Turn knob x's direction round, then the knobs: the machine ends where
    // the same graph, with the same change and the same inputs, puts it
    // offline.
    let set = |comp: &str, name: &str, value: f64| {
        let body = json!({"component": comp, "param": name, "value": value});
        s.call("POST", "/api/graph/params", Some(body), "b")
    };
    let (code, g) = set("knob_x", "invert", 1.0);
    assert_eq!(code, 200, "{g}");
    check_schema("Graph", &g);
    assert_eq!(param(&g, "knob_x", "invert")["value"], 1.0);
    assert_eq!(g["param_changes"], 1);
    turn_knobs(&s);
    let gf = motet_graph::GraphFile::load(&root().join(GAME.1)).unwrap();
    let (component, id) = gf.param_id("knob_x", "invert").unwrap();
    let mut offline = motet_sim::dance::HeldWithChanges {
        values: vec![512.0, 512.0, 300.0, -200.0],
        changes: [motet_sim::dance::ParamChange {
            component,
            param: id,
            value: 1.0,
        }]
        .into(),
        refused: Vec::new(),
    };
    let want = offline_end(&mut offline);
    assert!(offline.changes.is_empty() && offline.refused.is_empty());
    let mut plain = motet_sim::dance::HeldInputs(vec![512.0, 512.0, 300.0, -200.0]);
    let unchanged = offline_end(&mut plain);
    assert!(
        (want[0] - unchanged[0]).hypot(want[1] - unchanged[1]) > 5.0,
        "the change moves the machine elsewhere: {want:?} {unchanged:?}"
    );
    pen_reaches(&s, want);

    // Unknown names and values outside what a parameter takes are refused
    // and change nothing; so is a body that is not one change.
    for (body, want, words) in [
        (
            json!({"component": "nope", "param": "ratio", "value": 1}),
            422,
            "no component",
        ),
        (
            json!({"component": "knob_x", "param": "ratio", "value": 1}),
            422,
            "no live parameter",
        ),
        (
            json!({"component": "joy_x", "param": "deadband_width", "value": -3}),
            422,
            "outside",
        ),
        (
            json!({"component": "ch_a", "param": "max_pulse_rate", "value": -1}),
            422,
            "outside",
        ),
        (
            json!({"component": "knob_x", "param": "invert", "value": "yes"}),
            400,
            "",
        ),
        (
            json!({"component": "knob_x", "param": "invert", "value": 0, "extra": 1}),
            400,
            "extra",
        ),
        (json!({"component": "knob_x", "value": 0}), 400, "param"),
    ] {
        let (code, answer) = s.call("POST", "/api/graph/params", Some(body.clone()), "a");
        assert_eq!(code, want, "{body}: {answer}");
        check_schema("Error", &answer);
        let e = answer["error"].as_str().unwrap();
        assert!(e.contains(words), "{body}: {e}");
    }
    // The node itself refuses a lower limit above the upper one.
    let (code, _) = set("ch_a", "upper", 1000.0);
    assert_eq!(code, 200);
    let (code, answer) = set("ch_a", "lower", 2000.0);
    assert_eq!(code, 422, "{answer}");
    assert!(
        answer["error"]
            .as_str()
            .unwrap()
            .contains("the node refused"),
        "{answer}"
    );
    let (_, g) = s.call("GET", "/api/graph", None, "a");
    assert_eq!(param(&g, "knob_x", "invert")["value"], 1.0);
    assert_eq!(param(&g, "joy_x", "deadband_width")["value"], 6.0);
    assert_eq!(param(&g, "ch_a", "upper")["value"], 1000.0);
    // Unbounded below, as the file left it.
    assert_eq!(param(&g, "ch_a", "lower")["value"], Value::Null, "{g}");
    assert_eq!(g["param_changes"], 2);
    assert_eq!(g["error"], Value::Null, "the graph still runs: {g}");
}

#[test]
fn a_printers_status_carries_its_heaters_as_the_schema_says() {
    let m = motet_host::Machine::load(&root().join("examples/printer.toml")).unwrap();
    let nodes = SimNodes::new(&m, m.start, serve_config());
    let mut s = motet_serve::Session::new(std::sync::Arc::new(m), Box::new(nodes));
    s.set_heater_target(motet_planner::AuxChannel::Bed, 60.0)
        .unwrap();
    s.tick(5_000_000);
    let status = serde_json::to_value(s.status()).unwrap();
    check_schema("Status", &status);
    let heaters = status["heaters"].as_array().unwrap();
    assert_eq!(heaters.len(), 2, "{status}");
    assert_eq!(heaters[1]["channel"], "bed");
    assert_eq!(heaters[1]["target"], 60.0);
    let t = heaters[1]["temp"].as_f64().unwrap();
    assert!(t > 25.0 && t < 60.0, "warming: {t}");
}
