//! `motet serve` in a real browser: Debian's chromium, driven by Playwright
//! (`tests/web/page.mjs`), loads the page of a server started from the
//! command line, uploads the plotter drawing, checks the preview, starts,
//! sees the position move, pauses, resumes and presses the emergency stop;
//! the machine must rest on the job's path. `./scripts/test` installs
//! chromium and the script's npm package. A screenshot of the running page
//! is written to `target/web/serve.png` (the README shows a copy). A
//! hand-driven machine's page (`--graph`, `tests/web/graph.mjs`) shows the
//! graph's inputs and its components' live parameters as sliders, and
//! moving them moves the machine.

mod common;

use common::root;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command};
use std::time::{Duration, Instant};

fn terminate(child: &mut Child) -> bool {
    // SAFETY: kill(2) on our own child's pid.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM);
    }
    let end = Instant::now() + Duration::from_secs(10);
    while Instant::now() < end {
        if let Ok(Some(status)) = child.try_wait() {
            return status.success();
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

/// GET `path` answers 200.
fn answers(addr: &str, path: &str) -> bool {
    let Ok(mut s) = TcpStream::connect(addr) else {
        return false;
    };
    let _ = write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    );
    let mut text = String::new();
    let _ = s.read_to_string(&mut text);
    text.starts_with("HTTP/1.1 200")
}

/// Runs the browser script `script` (in `tests/web`) with `args` in
/// Debian's chromium; returns what it saw (the JSON of its last line).
fn browse(script: &str, args: &[&std::ffi::OsStr]) -> serde_json::Value {
    let web = root().join("crates/motet/tests/web");
    assert!(
        web.join("node_modules/playwright-core").exists(),
        "playwright-core missing: ./scripts/test installs it (npm ci --prefix crates/motet/tests/web)"
    );
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    assert!(
        std::path::Path::new(&chromium).exists(),
        "{chromium} missing: ./scripts/test installs it (apt-get install chromium)"
    );
    let out = Command::new("node")
        .arg(web.join(script))
        .args(args)
        .env("CHROMIUM", &chromium)
        .output()
        .expect("node (Node.js) runs the browser script");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{script} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(stdout.lines().last().unwrap()).unwrap()
}

/// One browser at a time: the figures one prints are its own.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn the_page_drives_the_plotter_in_a_real_browser() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::scratch("web", "serve");
    let started = Instant::now();
    let mut serve = common::serve(
        &["examples/plotter.toml", "--listen", "127.0.0.1:0"],
        dir.path(),
    );
    let addr = serve.addr.clone();
    let url = format!("http://{addr}/");
    while !answers(&addr, "/") {
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "the page never answered"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let to_page = started.elapsed();

    let shots = root().join("target/web");
    std::fs::create_dir_all(&shots).unwrap();
    let drawing = root().join("examples/jobs/drawing.svg");
    let seen = browse(
        "page.mjs",
        &[url.as_ref(), drawing.as_os_str(), shots.as_os_str()],
    );
    eprintln!("serve start to page served: {to_page:?}; the browser saw: {seen}");
    assert_eq!(seen["page_errors"], serde_json::json!([]));
    assert!(seen["preview_strokes"].as_u64().unwrap() > 10, "{seen}");
    assert!(
        seen["positions_moved"].as_u64().unwrap() > 5,
        "the position did not move: {seen}"
    );
    assert_eq!(seen["still_when_paused"], true, "{seen}");
    assert_eq!(seen["final_state"], "stopped", "{seen}");
    assert_eq!(seen["pair_hidden"], true, "{seen}");
    assert_eq!(seen["stop_event"], true, "{seen}");
    assert!(
        seen["click_to_braking_ms"].is_number(),
        "no braking time in the stop event: {seen}"
    );
    let off = seen["off_path"].as_f64().unwrap();
    assert!(off < 1e-3, "stopped {off} mm off the path");
    assert_eq!(seen["phone_estop_visible"], true, "{seen}");
    assert_eq!(seen["phone_no_sideways_scroll"], true, "{seen}");
    assert!(shots.join("serve.png").exists());
    assert!(
        terminate(&mut serve.child),
        "motet serve did not stop cleanly on SIGTERM"
    );
}

#[test]
fn a_hand_driven_machine_moves_with_the_page_sliders() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (machine, graph) = (
        "examples/dance/game-controller/machine.toml",
        "examples/dance/game-controller/graph.toml",
    );
    let dir = common::scratch("web", "graph");
    let mut serve = common::serve(
        &[machine, "--graph", graph, "--listen", "127.0.0.1:0"],
        dir.path(),
    );
    let url = format!("http://{}/", serve.addr);
    let shot = root().join("target/web/serve-graph.png");
    std::fs::create_dir_all(shot.parent().unwrap()).unwrap();
    let seen = browse(
        "graph.mjs",
        &[
            url.as_ref(),
            r#"[["knob_y", "invert", 1]]"#.as_ref(),
            r#"{"knob_x": 250, "knob_y": 400}"#.as_ref(),
            shot.as_os_str(),
        ],
    );
    eprintln!("the browser saw: {seen}");
    assert_eq!(seen["page_errors"], serde_json::json!([]));
    assert_eq!(
        seen["sliders"],
        serde_json::json!([
            "graph-joy_x:range",
            "graph-joy_y:range",
            "graph-knob_x:range",
            "graph-knob_y:range"
        ])
    );
    // Every live parameter has its slider (the game controller's analog
    // inputs have 7, the velocity generators, knobs 1 each, channels 5).
    assert_eq!(seen["param_sliders"], 7 * 2 + 2 + 2 + 5 * 2, "{seen}");
    assert_eq!(seen["params"]["knob_y.invert"], 1.0, "{seen}");
    assert_eq!(seen["inputs"]["knob_x"], 250.0, "{seen}");
    assert_eq!(seen["inputs"]["knob_y"], 400.0, "{seen}");
    // Where the same graph fed the same change and values offline puts the
    // machine.
    let m = motet_host::Machine::load(&root().join(machine)).unwrap();
    let g = motet_graph::GraphFile::load(&root().join(graph)).unwrap();
    let (component, param) = g.param_id("knob_y", "invert").unwrap();
    let mut held = motet_sim::dance::HeldWithChanges {
        values: vec![512.0, 512.0, 250.0, 400.0],
        changes: [motet_sim::dance::ParamChange {
            component,
            param,
            value: 1.0,
        }]
        .into(),
        refused: Vec::new(),
    };
    let want = motet_sim::dance::run_dance(&m, &g, &mut held, 3.0, &mut |_| {})
        .unwrap()
        .report
        .final_xy;
    let got = [
        seen["position"][0].as_f64().unwrap(),
        seen["position"][1].as_f64().unwrap(),
    ];
    assert!(
        (got[0] - want[0]).hypot(got[1] - want[1]) < 1e-6,
        "at {got:?}, want {want:?}"
    );
    assert!(
        terminate(&mut serve.child),
        "motet serve did not stop cleanly"
    );
}
