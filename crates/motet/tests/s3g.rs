//! `motet run … --nodes s3g:PTY` against `motet node --sim --type s3g` on a
//! pseudo-terminal, from the command line: the bot's executed points lie
//! within half a step of motet's plan; a bot that answers noise, CRC errors,
//! generic errors and buffer-full is retried with every point run exactly
//! once; one that stops answering, or whose acknowledgement arrives
//! corrupted, stops the run with a clear error. Also the gpx check: Debian's
//! `gpx` writes X3G that motet's decoder reads command by command, and
//! drives the simulated bot over the pseudo-terminal with every packet's
//! CRC and command checking out.

mod common;

use common::{motet, root, scratch};
use motet_s3g::bot::Executed;
use motet_s3g::check::PlannedPath;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

const MACHINE: &str = "examples/replicator.toml";
const JOB: &str = "examples/jobs/replicator-square.gcode";

/// A simulated bot in its own process, ended when dropped.
struct Bot {
    child: Child,
    port: String,
    record: PathBuf,
}

impl Bot {
    fn start(dir: &Path, faults: &str, idle_exit: &str) -> Bot {
        let record = dir.join("points.csv");
        let mut child = Command::new(env!("CARGO_BIN_EXE_motet"))
            .args([
                "node",
                "--sim",
                "--type",
                "s3g",
                "--listen",
                "pty",
                "--announce",
            ])
            .args([
                "--time-scale",
                "20",
                "--idle-exit",
                idle_exit,
                "--faults",
                faults,
            ])
            .arg("--record")
            .arg(&record)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let (link, _) = motet_net::spawn::parse_announce(line.trim()).unwrap();
        let port = link.strip_prefix("s3g:").unwrap().to_string();
        Bot {
            child,
            port,
            record,
        }
    }

    /// Waits for the bot to leave (idle) and returns its last words.
    fn finish(mut self) -> String {
        let mut err = String::new();
        use std::io::Read;
        self.child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        self.child.wait().unwrap();
        err
    }
}

/// The points a bot recorded: `n,clock_us,x,y,z,a,b` a line.
fn recorded(path: &Path) -> Vec<Executed> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines()
        .map(|l| {
            let v: Vec<i64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            Executed {
                n: v[0] as u64,
                clock_us: v[1],
                steps: std::array::from_fn(|i| v[2 + i] as i32),
            }
        })
        .collect()
}

impl Drop for Bot {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn plan() -> PlannedPath {
    let machine = motet_host::Machine::load(&root().join(MACHINE)).unwrap();
    let job = motet_api::load_job(&machine, &root().join(JOB), &Default::default()).unwrap();
    let commands: Vec<_> = job.commands.into_iter().map(|c| c.item).collect();
    PlannedPath::plan(&machine, &commands).unwrap()
}

/// Runs the example job on a bot with `faults`: (ok, stderr, report, points run).
fn print(faults: &str) -> (bool, String, serde_json::Value, Vec<Executed>) {
    let dir = scratch("s3g", "print");
    // Longer than the host waits for a reply, so the bot stays while the
    // host waits out a lost one.
    let bot = Bot::start(dir.path(), faults, "5");
    let out = dir.path().join("out");
    let nodes = format!("s3g:{}", bot.port);
    let (ok, _, err) = motet(&[
        "run",
        MACHINE,
        JOB,
        "--nodes",
        &nodes,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let report = std::fs::read_to_string(out.join("report.json"))
        .map(|t| serde_json::from_str(&t).unwrap())
        .unwrap_or(serde_json::Value::Null);
    let record_path = bot.record.clone();
    if !ok {
        // The bot runs what it took before the host stopped; it leaves
        // when the host has been gone a while.
        let said = bot.finish();
        assert!(
            said.contains("points received"),
            "{faults}: the bot said {said}"
        );
    }
    // After a run that ended well the bot has run everything (the host
    // waited for it), and is ended here.
    let record = recorded(&record_path);
    (ok, err, report, record)
}

/// Points numbered 1, 2, 3… with none missing or repeated.
fn once_each(faults: &str, run: &[Executed]) {
    for (i, e) in run.iter().enumerate() {
        assert_eq!(e.n, i as u64 + 1, "{faults}: point {} out of order", e.n);
    }
}

#[test]
fn prints_through_the_bot_on_a_pty() {
    let plan = plan();
    for faults in ["", "garbage=3,crc=5,generic=7,full=4,reply-crc=60"] {
        let (ok, err, report, run) = print(faults);
        assert!(ok, "{faults}: {err}");
        let points = report["points"].as_u64().unwrap();
        assert!(points > 100, "{faults}: {points} points");
        assert_eq!(
            run.len() as u64,
            points,
            "{faults}: every point sent ran, once"
        );
        once_each(faults, &run);
        let dev = plan.max_deviation(&run);
        assert!(dev <= 0.5, "{faults}: {dev} steps from the plan");
        let end = run.last().unwrap().clock_us as f64;
        assert!(
            (plan.duration_us() - end).abs() < 1000.0,
            "{faults}: {end} µs"
        );
        assert!(
            report["temperatures"]["tool0"]["peak_c"].as_i64().unwrap() >= 208,
            "{report}"
        );
        if !faults.is_empty() {
            let link = &report["link"];
            for k in ["resends", "buffer_full", "noise_bytes"] {
                assert!(link[k].as_u64().unwrap() > 0, "{faults}: no {k}: {link}");
            }
        }
    }
}

#[test]
fn stops_with_a_clear_error() {
    let plan = plan();
    for (faults, words) in [
        (
            "silent-after=80",
            "the bot stopped answering: no reply to command",
        ),
        ("ack-crc=25", "cannot tell whether the bot queued it"),
    ] {
        let (ok, err, _, run) = print(faults);
        assert!(!ok, "{faults}: the run went on");
        assert!(
            err.contains(words) && err.contains("on the bot at s3g:/dev/"),
            "{faults}: {err}"
        );
        once_each(faults, &run);
        assert!(plan.max_deviation(&run) <= 0.5, "{faults}");
    }
}

#[test]
fn refuses_a_machine_that_is_not_a_bot() {
    let (ok, _, err) = motet(&[
        "run",
        "examples/plotter.toml",
        "examples/jobs/drawing.svg",
        "--nodes",
        "s3g:/dev/null",
    ]);
    assert!(!ok && err.contains("not an S3G bot"), "{err}");
    let (ok, _, err) = motet(&["run", MACHINE, JOB, "--nodes", "s3g:"]);
    assert!(!ok && err.contains("s3g:PORT[@BAUD]"), "{err}");
}

/// Whether Debian's `gpx` is here; under CI it must be (scripts/test
/// installs it), elsewhere its tests say they are skipped.
fn have_gpx(test: &str) -> bool {
    if Command::new("gpx").arg("-?").output().is_ok() {
        return true;
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "gpx is missing under CI: scripts/test installs it (apt-get install gpx)"
    );
    eprintln!("{test}: SKIPPED, gpx is not installed (apt-get install gpx)");
    false
}

const GPX_JOB: &str = "crates/motet/tests/data/gpx-square.gcode";

/// gpx's X3G for the test job (commands without framing), and the
/// commands motet reads from it.
fn gpx_x3g(dir: &Path) -> Vec<motet_s3g::Command> {
    let x3g = dir.join("square.x3g");
    let out = Command::new("gpx")
        .args(["-m", "r2h"])
        .arg(root().join(GPX_JOB))
        .arg(&x3g)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "gpx: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(&x3g).unwrap();
    motet_s3g::stream::read_commands(&bytes).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn reads_every_command_gpx_writes() {
    if !have_gpx("reads_every_command_gpx_writes") {
        return;
    }
    let dir = scratch("s3g", "gpx-file");
    let cmds = gpx_x3g(dir.path());
    let count = |code: u8| cmds.iter().filter(|c| c.code() == code).count();
    // Five moves and the homing's set position, heaters and waits, the
    // fan, the dwell: each a known command that reads back as written.
    assert!(count(155) >= 5, "{cmds:?}");
    assert!(
        count(136) >= 4 && count(135) >= 1 && count(133) >= 1,
        "{cmds:?}"
    );
    for c in &cmds {
        let p = c.encode().unwrap();
        assert_eq!(&motet_s3g::Command::decode(&p).unwrap(), c);
        assert!(motet_s3g::command::describe(c.code()).is_some());
    }
}

#[test]
fn gpx_drives_the_simulated_bot() {
    if !have_gpx("gpx_drives_the_simulated_bot") {
        return;
    }
    let dir = scratch("s3g", "gpx-serial");
    let cmds = gpx_x3g(dir.path());
    // gpx waits 2 s after opening the port: the bot stays longer.
    let bot = Bot::start(dir.path(), "", "4");
    let out = Command::new("gpx")
        .args(["-m", "r2h", "-s"])
        .arg(root().join(GPX_JOB))
        .arg(&bot.port)
        .output()
        .unwrap();
    let record = bot.record.clone();
    let said = bot.finish();
    assert!(
        out.status.success(),
        "gpx: {}\nbot: {said}",
        String::from_utf8_lossy(&out.stderr)
    );
    // "… N good packets, M CRC errors …": every packet gpx framed checked
    // out (a wrong CRC would have made every one a mismatch).
    let figure = |what: &str| -> u64 {
        let at = said
            .find(what)
            .unwrap_or_else(|| panic!("{what} in {said}"));
        said[..at]
            .split_whitespace()
            .last()
            .unwrap()
            .parse()
            .unwrap()
    };
    assert_eq!(figure(" CRC errors"), 0, "{said}");
    assert!(figure(" good packets") >= cmds.len() as u64, "{said}");
    let points = cmds.iter().filter(|c| c.code() == 155).count();
    assert_eq!(recorded(&record).len(), points, "{said}");
}
