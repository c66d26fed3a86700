//! Klipper's API server on a running server: requests over its Unix
//! socket as a printer host sends them, each endpoint's answer, the
//! subscriptions' pushes, prints from the G-code folder, and bad input.

use motet_serve::klipper::frame::{self, Frame, Frames, Request, ETX};
use motet_serve::{serve_config, Server, ServerConfig, SimNodes};
use proptest::prelude::*;
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

struct Rig {
    _server: Server,
    _dir: tempfile::TempDir,
    sock: PathBuf,
    gcodes: PathBuf,
}

fn rig() -> Rig {
    let dir = tempfile::tempdir().unwrap();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/printer.toml");
    let m = motet_host::Machine::load(&path).unwrap();
    let nodes = Box::new(SimNodes::new(&m, m.start, serve_config()));
    let cfg = ServerConfig {
        listen: "127.0.0.1:0".parse().unwrap(),
        dir: dir.path().join("serve"),
        token: None,
    };
    let server = Server::start(m, nodes, &cfg).unwrap();
    let sock = dir.path().join("klippy.sock");
    let gcodes = dir.path().join("gcodes");
    std::fs::create_dir_all(&gcodes).unwrap();
    let at = server.klipper(&sock, &gcodes).unwrap();
    assert_eq!(at, format!("unix:{}", sock.display()));
    Rig {
        _server: server,
        _dir: dir,
        sock,
        gcodes,
    }
}

/// A printer host's end of the socket.
struct Client {
    s: UnixStream,
    buf: Vec<u8>,
    /// Messages that were not answers (subscription pushes), in order.
    pushes: Vec<Value>,
    next_id: u64,
}

impl Client {
    fn new(path: &Path) -> Client {
        let s = UnixStream::connect(path).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
        Client {
            s,
            buf: Vec::new(),
            pushes: Vec::new(),
            next_id: 1,
        }
    }

    fn send_raw(&mut self, bytes: &[u8]) {
        self.s.write_all(bytes).unwrap();
    }

    /// The next message, 20 s at most.
    fn next(&mut self) -> Value {
        let end = Instant::now() + Duration::from_secs(20);
        loop {
            if let Some(i) = self.buf.iter().position(|b| *b == ETX) {
                let msg: Vec<u8> = self.buf.drain(..=i).collect();
                return serde_json::from_slice(&msg[..i]).unwrap();
            }
            assert!(Instant::now() < end, "no message");
            let mut b = [0u8; 4096];
            match self.s.read(&mut b) {
                Ok(0) => panic!("the server closed the connection"),
                Ok(n) => self.buf.extend_from_slice(&b[..n]),
                Err(_) => {}
            }
        }
    }

    /// The answer to message `id`, keeping pushes that come first.
    fn answer(&mut self, id: &Value) -> Value {
        loop {
            let m = self.next();
            if m.get("id") == Some(id) && m.get("method").is_none() {
                return m;
            }
            self.pushes.push(m);
        }
    }

    fn call(&mut self, method: &str, params: Value) -> Value {
        let id = json!(self.next_id);
        self.next_id += 1;
        let req = json!({"id": id, "method": method, "params": params});
        self.send_raw(&frame::encode(&req));
        self.answer(&id)
    }

    fn ok(&mut self, method: &str, params: Value) -> Value {
        let a = self.call(method, params);
        assert!(a.get("error").is_none(), "{method}: {a}");
        a["result"].clone()
    }

    fn query(&mut self, objects: Value) -> Value {
        self.ok("objects/query", json!({ "objects": objects }))["status"].clone()
    }

    fn wait_for(&mut self, what: &str, mut f: impl FnMut(&mut Client) -> bool) {
        let end = Instant::now() + Duration::from_secs(30);
        while !f(self) {
            assert!(Instant::now() < end, "waited too long for {what}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

fn error_message(a: &Value) -> &str {
    assert_eq!(a["error"]["error"], "WebRequestError", "{a}");
    a["error"]["message"].as_str().unwrap()
}

#[test]
fn info_endpoints_and_objects_answer_in_klippers_shapes() {
    let r = rig();
    let mut c = Client::new(&r.sock);
    let info = c.ok(
        "info",
        json!({"client_info": {"program": "Moonraker", "version": "x"}}),
    );
    assert_eq!(info["state"], "ready");
    for k in [
        "state_message",
        "klipper_path",
        "python_path",
        "config_file",
        "software_version",
        "hostname",
    ] {
        assert!(info[k].is_string(), "info.{k}: {info}");
    }
    let eps = c.ok("list_endpoints", json!({}));
    for e in [
        "objects/subscribe",
        "gcode/script",
        "gcode/subscribe_output",
        "emergency_stop",
    ] {
        assert!(
            eps["endpoints"].as_array().unwrap().contains(&json!(e)),
            "{e}"
        );
    }
    let list = c.ok("objects/list", json!({}));
    let names = list["objects"].as_array().unwrap();
    for o in [
        "webhooks",
        "toolhead",
        "gcode_move",
        "print_stats",
        "virtual_sdcard",
        "configfile",
        "heaters",
        "pause_resume",
        "display_status",
        "extruder",
        "heater_bed",
    ] {
        assert!(names.contains(&json!(o)), "{o}");
    }
    let st = c.query(
        json!({"toolhead": ["position", "homed_axes"], "print_stats": null,
        "configfile": ["settings"], "heaters": null, "no_such_object": null}),
    );
    assert_eq!(
        st["toolhead"],
        json!({"position": [0.0, 0.0, 0.0, 0.0], "homed_axes": "xyz"})
    );
    assert_eq!(st["print_stats"]["state"], "standby");
    // The printer's heaters (examples/printer.toml has an extruder axis).
    assert_eq!(
        st["heaters"]["available_heaters"],
        json!(["extruder", "heater_bed"])
    );
    // A temperature set over the console reaches the heater's object.
    c.ok(
        "gcode/script",
        json!({"script": "M104 S200\nM140 S60\nM400"}),
    );
    c.wait_for("the targets set", |c| {
        let st = c.query(json!({"extruder": ["target", "temperature"], "heater_bed": ["target"]}));
        st["extruder"]["target"] == 200.0 && st["heater_bed"]["target"] == 60.0
    });
    let st = c.query(json!({"extruder": null, "toolhead": ["extruder"]}));
    assert_eq!(st["toolhead"]["extruder"], "extruder");
    assert!(
        st["extruder"]["temperature"].as_f64().unwrap() >= 25.0,
        "{st}"
    );
    let st = c.query(json!({"configfile": ["settings"], "no_such_object": null}));
    assert_eq!(
        st["configfile"]["settings"]["virtual_sdcard"]["path"],
        json!(r.gcodes.display().to_string())
    );
    assert!(
        st.get("no_such_object").is_none(),
        "unknown objects are left out"
    );
    // Requests without an id get no answer: the next answer is the next call's.
    c.send_raw(&frame::encode(&json!({"method": "info", "params": {}})));
    let id = c.next_id;
    let a = c.call("objects/list", json!({}));
    assert_eq!(a["id"], json!(id));
}

#[test]
fn gcode_moves_the_machine_and_subscriptions_push_what_changed() {
    let r = rig();
    let mut c = Client::new(&r.sock);
    c.ok(
        "gcode/subscribe_output",
        json!({"response_template": {"method": "out"}}),
    );
    let first = c.ok(
        "objects/subscribe",
        json!({"objects": {"toolhead": ["position"], "webhooks": null},
               "response_template": {"method": "process_status_update"}}),
    );
    assert_eq!(first["status"]["webhooks"]["state"], "ready");
    let a = c.ok(
        "gcode/script",
        json!({"script": "G21 G90\nG1 X12 Y7 F6000\nM400\nM114"}),
    );
    assert_eq!(a, json!({}));
    // M400 waited for the machine: it is there now.
    let st = c.query(
        json!({"gcode_move": ["position", "gcode_position"], "motion_report": ["live_position"]}),
    );
    assert_eq!(
        st["motion_report"]["live_position"],
        json!([12.0, 7.0, 0.0, 0.0])
    );
    assert_eq!(
        st["gcode_move"]["gcode_position"],
        json!([12.0, 7.0, 0.0, 0.0])
    );
    c.wait_for("the position pushed", |c| {
        let _ = c.call("objects/list", json!({}));
        c.pushes.iter().any(|p| {
            p["method"] == "process_status_update"
                && p["params"]["status"]["toolhead"]["position"] == json!([12.0, 7.0, 0.0, 0.0])
        })
    });
    // Pushes carry only what changed: the webhooks never did.
    assert!(c
        .pushes
        .iter()
        .all(|p| p["params"]["status"].get("webhooks").is_none()));
    assert!(c.pushes.iter().any(|p| p["method"] == "out"
        && p["params"]["response"]
            .as_str()
            .unwrap()
            .starts_with("X:12.000 Y:7.000")));
    // Errors: an unknown command, a move off the travel; nothing moved.
    let a = c.call("gcode/script", json!({"script": "FROB X=1"}));
    assert_eq!(error_message(&a), "Unknown command:\"FROB\"");
    let a = c.call("gcode/script", json!({"script": "G1 X500"}));
    assert!(!error_message(&a).is_empty());
    let st = c.query(json!({"motion_report": ["live_position"]}));
    assert_eq!(
        st["motion_report"]["live_position"],
        json!([12.0, 7.0, 0.0, 0.0])
    );
}

#[test]
fn bad_json_gets_an_error_and_loses_nothing_queued() {
    let r = rig();
    let mut c = Client::new(&r.sock);
    // A script in flight, then garbage on the same connection, in one write.
    let mut bytes = frame::encode(&json!({"id": 1, "method": "gcode/script",
        "params": {"script": "G1 X30 Y20 F3000\nG1 X40 Y10\nM400"}}));
    bytes.extend_from_slice(b"{\"id\": 2, \"method\": \x03");
    bytes.extend_from_slice(b"[1,2]\x03");
    bytes.extend(frame::encode(
        &json!({"id": 3, "method": "gcode/script", "params": "G1"}),
    ));
    bytes.extend(frame::encode(&json!({"id": 4, "params": {}})));
    c.send_raw(&bytes);
    let mut answers: Vec<Value> = (0..5).map(|_| c.next()).collect();
    answers.sort_by_key(|a| a["id"].as_u64().unwrap_or(0));
    assert!(
        error_message(&answers[0]).starts_with("malformed JSON"),
        "{}",
        answers[0]
    );
    assert_eq!(answers[0]["id"], Value::Null);
    assert!(!error_message(&answers[1]).is_empty());
    assert_eq!(answers[2], json!({"id": 1, "result": {}}));
    assert!(error_message(&answers[3]).contains("params"));
    assert!(error_message(&answers[4]).contains("method"));
    assert_eq!(answers[4]["id"], 4);
    // The script ran whole and the connection still answers.
    let st = c.query(json!({"motion_report": ["live_position"]}));
    assert_eq!(
        st["motion_report"]["live_position"],
        json!([40.0, 10.0, 0.0, 0.0])
    );
    assert_eq!(
        error_message(&c.call("objects/query", json!({"objects": 3}))),
        "Invalid Argument Type [objects]: expected an object"
    );
    assert!(error_message(&c.call("no/such", json!({}))).contains("no/such"));
}

#[test]
fn a_file_in_the_gcode_folder_prints_and_reports_its_progress() {
    let r = rig();
    let text: String = (1..=20)
        .map(|k| format!("G1 X{} Y{} E0.2 F6000\n", 5 * k, 3 * k))
        .collect();
    std::fs::write(r.gcodes.join("part.gcode"), format!("M83\n{text}")).unwrap();
    let mut c = Client::new(&r.sock);
    let a = c.call(
        "gcode/script",
        json!({"script": "SDCARD_PRINT_FILE FILENAME=\"../part.gcode\""}),
    );
    assert!(error_message(&a).contains("Unable to open file"));
    let a = c.call(
        "gcode/script",
        json!({"script": "SDCARD_PRINT_FILE FILENAME=missing.gcode"}),
    );
    assert!(error_message(&a).contains("Unable to open file"));
    c.ok(
        "gcode/script",
        json!({"script": "SDCARD_PRINT_FILE FILENAME=\"part.gcode\""}),
    );
    let st = c.query(
        json!({"print_stats": ["state", "filename"], "virtual_sdcard": ["is_active", "file_size"]}),
    );
    assert_eq!(
        st["print_stats"],
        json!({"state": "printing", "filename": "part.gcode"})
    );
    assert_eq!(st["virtual_sdcard"]["is_active"], true);
    // Busy: a second print and G-code from the console are refused.
    let a = c.call(
        "gcode/script",
        json!({"script": "SDCARD_PRINT_FILE FILENAME=part.gcode"}),
    );
    assert!(error_message(&a).contains("SD busy"));
    let mut progress = Vec::new();
    c.wait_for("the print to complete", |c| {
        let st = c.query(json!({"print_stats": ["state"], "virtual_sdcard": ["progress"]}));
        progress.push(st["virtual_sdcard"]["progress"].as_f64().unwrap());
        st["print_stats"]["state"] == "complete"
    });
    assert_eq!(progress.last(), Some(&1.0));
    assert!(progress.windows(2).all(|w| w[0] <= w[1]), "{progress:?}");
    let st =
        c.query(json!({"motion_report": ["live_position"], "print_stats": ["print_duration"]}));
    assert_eq!(st["motion_report"]["live_position"][0], 100.0);
    assert!(st["print_stats"]["print_duration"].as_f64().unwrap() > 0.0);
    c.ok("gcode/script", json!({"script": "SDCARD_RESET_FILE"}));
    assert_eq!(
        c.query(json!({"print_stats": ["state"]}))["print_stats"]["state"],
        "standby"
    );
}

#[test]
fn pause_resume_cancel_and_emergency_stop() {
    let r = rig();
    let text: String = (1..=40)
        .map(|k| format!("G1 X{} Y{} F1200\n", 5 * k, 2 * k))
        .collect();
    std::fs::write(r.gcodes.join("long.gcode"), text).unwrap();
    let mut c = Client::new(&r.sock);
    c.ok(
        "gcode/script",
        json!({"script": "SDCARD_PRINT_FILE FILENAME=long.gcode"}),
    );
    c.ok("pause_resume/pause", json!({}));
    c.wait_for("paused", |c| {
        c.query(json!({"print_stats": ["state"]}))["print_stats"]["state"] == "paused"
    });
    assert_eq!(
        c.query(json!({"pause_resume": null}))["pause_resume"]["is_paused"],
        true
    );
    c.ok("gcode/script", json!({"script": "RESUME"}));
    assert_eq!(
        c.query(json!({"print_stats": ["state"]}))["print_stats"]["state"],
        "printing"
    );
    c.ok("gcode/script", json!({"script": "CANCEL_PRINT"}));
    c.wait_for("cancelled", |c| {
        c.query(json!({"print_stats": ["state"]}))["print_stats"]["state"] == "cancelled"
    });
    // An emergency stop: Klipper's shutdown state until a restart.
    c.ok("gcode/script", json!({"script": "G1 X150 Y150 F600"}));
    c.ok("emergency_stop", json!({}));
    c.wait_for("shutdown", |c| {
        c.query(json!({"webhooks": ["state"]}))["webhooks"]["state"] == "shutdown"
    });
    let a = c.call("gcode/script", json!({"script": "G1 X1"}));
    assert!(error_message(&a).contains("shutdown"));
    c.ok("gcode/firmware_restart", json!({}));
    assert_eq!(
        c.query(json!({"webhooks": ["state"]}))["webhooks"]["state"],
        "ready"
    );
    assert_eq!(c.ok("info", json!({}))["state"], "ready");
}

#[test]
fn several_clients_and_a_stale_socket() {
    let r = rig();
    let mut a = Client::new(&r.sock);
    let mut b = Client::new(&r.sock);
    a.ok("gcode/script", json!({"script": "G1 X8 F3000\nM400"}));
    let st = b.query(json!({"motion_report": ["live_position"]}));
    assert_eq!(st["motion_report"]["live_position"][0], 8.0);
    // A second server on the same live socket is refused.
    let e = r._server.klipper(&r.sock, &r.gcodes).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::AddrInUse);
    // A socket file nobody listens on is replaced.
    let stale = r._dir.path().join("stale.sock");
    drop(std::os::unix::net::UnixListener::bind(&stale).unwrap());
    r._server.klipper(&stale, &r.gcodes).unwrap();
    let mut c = Client::new(&stale);
    assert_eq!(c.ok("info", json!({}))["state"], "ready");
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(&stale).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600);
}

proptest! {
    /// However the bytes are cut, the same messages come out.
    #[test]
    fn framing_does_not_depend_on_the_chunks(
        msgs in proptest::collection::vec(proptest::collection::vec(0u8..=255, 0..40), 0..8),
        cuts in proptest::collection::vec(1usize..17, 1..30),
    ) {
        let msgs: Vec<Vec<u8>> = msgs.into_iter()
            .map(|m| m.into_iter().filter(|b| *b != ETX).collect()).collect();
        let mut stream = Vec::new();
        for m in &msgs {
            stream.extend_from_slice(m);
            stream.push(ETX);
        }
        let mut f = Frames::default();
        let mut got = Vec::new();
        let mut rest = &stream[..];
        let mut k = 0;
        while !rest.is_empty() {
            let n = cuts[k % cuts.len()].min(rest.len());
            got.extend(f.push(&rest[..n]));
            rest = &rest[n..];
            k += 1;
        }
        let want: Vec<Frame> = msgs.into_iter().map(Frame::Message).collect();
        prop_assert_eq!(got, want);
        prop_assert_eq!(f.pending(), 0);
    }

    /// Any bytes parse to a request or an error; never a panic.
    #[test]
    fn parsing_never_panics(bytes in proptest::collection::vec(0u8..=255, 0..200)) {
        let _ = frame::parse(&bytes);
    }

    /// A request encoded and parsed back is the same request.
    #[test]
    fn requests_round_trip(id in 0u64..1_000_000, method in "[a-z_/]{1,20}", script in "\\PC{0,40}") {
        let v = json!({"id": id, "method": method, "params": {"script": script}});
        let bytes = frame::encode(&v);
        prop_assert_eq!(*bytes.last().unwrap(), ETX);
        let r: Request = frame::parse(&bytes[..bytes.len() - 1]).unwrap();
        prop_assert_eq!(r.id, Some(json!(id)));
        prop_assert_eq!(r.method, method);
        prop_assert_eq!(&r.params["script"], &json!(script));
    }
}

#[test]
fn a_message_too_long_is_an_error_and_the_next_is_read() {
    let mut f = Frames::default();
    let big = vec![b'x'; frame::MAX_MESSAGE + 10];
    let mut got = f.push(&big);
    got.extend(f.push(b"\x03{}\x03"));
    assert_eq!(got, vec![Frame::TooLong, Frame::Message(b"{}".to_vec())]);
}
