//! The node firmware on QEMU's emulated Cortex-M7 board (`mps2-an500`),
//! driven exactly as a person drives a USB board: its UART on a
//! pseudo-terminal, `motet nodes scan|pair|flash|status`, `motet run …
//! --nodes paired`, `motet resume`. The board runs its real bootloader;
//! firmware images are built from `firmware/` (`./scripts/test` builds it
//! and installs `qemu-system-arm`; these tests build it too if needed).
//!
//! Runs are in real time on the emulated clock: the jobs are seconds long.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};
use tempfile::TempDir;

mod common;
use common::{journal_seals, motet, resume_to_done, root};

/// One emulated board at a time: each runs in real time.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

fn scratch(name: &str) -> TempDir {
    common::scratch("fw", name)
}

/// The firmware's ELF files: the bootloader and the node application.
struct Firmware {
    boot: PathBuf,
    node: PathBuf,
}

/// Builds the firmware once (a no-op when `./scripts/test` built it).
fn firmware() -> &'static Firmware {
    static FW: OnceLock<Firmware> = OnceLock::new();
    FW.get_or_init(|| {
        let dir = root().join("firmware");
        let out = Command::new(env!("CARGO"))
            .args(["build", "--release", "--locked"])
            .current_dir(&dir)
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_TARGET_DIR")
            .output()
            .expect("cargo runs");
        assert!(
            out.status.success(),
            "building firmware/ failed (is the thumbv7em-none-eabihf target installed? ./scripts/test installs it):\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let bin = dir.join("target/thumbv7em-none-eabihf/release");
        Firmware {
            boot: bin.join("motet-mps2-boot"),
            node: bin.join("motet-mps2-node"),
        }
    })
}

/// `motet nodes image` of the node application (or of `payload`) as
/// `version` for `board`.
fn image(dir: &Path, payload: &Path, board: &str, version: &str) -> PathBuf {
    let out = dir.join(format!("{board}-{version}.img"));
    let (ok, _, stderr) = motet(&[
        "nodes",
        "image",
        "--kind",
        "stepper",
        "--board",
        board,
        "--version",
        version,
        payload.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    out
}

/// A running emulated board; QEMU is killed when dropped.
struct Board {
    qemu: Child,
    /// `serial:/dev/pts/N`
    link: String,
    console: PathBuf,
    /// The terminal's far end, held open (never read) so that QEMU never
    /// sees it hang up between two commands (it would stop reading it for a
    /// second). A plain open: a serial port's exclusive lock would keep
    /// `motet` out.
    _hold: std::fs::File,
}

impl Drop for Board {
    fn drop(&mut self) {
        let _ = self.qemu.kill();
        let _ = self.qemu.wait();
    }
}

impl Board {
    /// Boots the bootloader with `factory` loaded where a programmer puts
    /// the first image (None: a board with no application).
    fn boot(dir: &Path, factory: Option<&Path>) -> Board {
        let fw = firmware();
        let console = dir.join("console.log");
        let mut cmd = Command::new("qemu-system-arm");
        cmd.args(["-M", "mps2-an500", "-display", "none", "-monitor", "none"])
            .arg("-kernel")
            .arg(&fw.boot)
            .args([
                "-device",
                "loader,addr=0x10000,data=0x6d6f74657401,data-len=8",
            ])
            .args(["-serial", "pty", "-serial"])
            .arg(format!("file:{}", console.display()));
        if let Some(f) = factory {
            cmd.arg("-device").arg(format!(
                "loader,file={},addr=0x100000,force-raw=on",
                f.display()
            ));
        }
        let mut qemu = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("qemu-system-arm not found: ./scripts/test installs it (apt-get install qemu-system-arm)");
        // "char device redirected to /dev/pts/N (label serial0)", on either.
        let (tx, rx) = std::sync::mpsc::channel();
        for pipe in [
            Box::new(qemu.stdout.take().unwrap()) as Box<dyn Read + Send>,
            Box::new(qemu.stderr.take().unwrap()),
        ] {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(pipe).lines().map_while(Result::ok) {
                    let _ = tx.send(line);
                }
            });
        }
        let pts = loop {
            let line = rx
                .recv_timeout(Duration::from_secs(20))
                .expect("QEMU printed no pseudo-terminal");
            if let Some(at) = line.find("/dev/pts/") {
                let p: String = line[at..]
                    .chars()
                    .take_while(|c| !c.is_whitespace())
                    .collect();
                break p;
            }
        };
        let hold = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&pts)
            .expect("open the pty");
        Board {
            qemu,
            link: format!("serial:{pts}"),
            console,
            _hold: hold,
        }
    }

    fn console(&self) -> String {
        std::fs::read_to_string(&self.console).unwrap_or_default()
    }

    /// Waits until the console has printed `what`.
    fn wait_console(&self, what: &str) {
        let start = Instant::now();
        while !self.console().contains(what) {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "the board's console never said {what:?}:\n{}",
                self.console()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// A copy of the plotter machine in `dir` (pairing writes beside it).
fn plotter(dir: &Path) -> PathBuf {
    let to = dir.join("plotter.toml");
    std::fs::copy(root().join("examples/plotter.toml"), &to).unwrap();
    to
}

const JOB: &str = "crates/motet/tests/data/square-and-circle.svg";

fn pair(machine: &Path, board: &Board) {
    let (ok, stdout, stderr) = motet(&[
        "nodes",
        "pair",
        machine.to_str().unwrap(),
        "--link",
        &format!("ebb={}", board.link),
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("is now address 2"), "{stdout}");
}

fn status(machine: &Path) -> String {
    let (ok, stdout, stderr) = motet(&["nodes", "status", machine.to_str().unwrap()]);
    assert!(ok, "{stderr}");
    stdout
}

/// The last "pulses [...]" the board's console printed: the steps its pins
/// made, per channel.
fn pulses(console: &str) -> Vec<u64> {
    let line = console
        .lines()
        .rev()
        .find(|l| l.starts_with("motet: pulses"))
        .expect("the board reported its pulses");
    let inside = &line[line.find('[').unwrap() + 1..line.find(']').unwrap()];
    inside
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect()
}

#[test]
fn the_board_is_flashed_and_steps_as_the_simulator_computes() {
    let _serial = serial();
    let tmp = scratch("run");
    let dir = tmp.path();
    let fw = firmware();
    let factory = image(dir, &fw.node, "mps2-an500", "0.1.0");
    let board = Board::boot(dir, Some(&factory));
    board.wait_console("motet: stepper node on mps2-an500, firmware 0.1.0");

    let (ok, stdout, stderr) = motet(&["nodes", "scan", "--link", &board.link]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("stepper on mps2-an500")
            && stdout.contains("firmware 0.1.0")
            && stdout.contains("unpaired"),
        "{stdout}"
    );
    let machine = plotter(dir);
    pair(&machine, &board);

    // Images the board must refuse, each leaving 0.1.0 running: (image,
    // part of the error).
    let junk = dir.join("junk.bin");
    std::fs::write(&junk, vec![0x5Au8; 3000]).unwrap();
    let foreign = image(dir, &junk, "teensy41", "9.0.0");
    let not_an_app = image(dir, &junk, "mps2-an500", "0.3.0");
    let mut flipped = std::fs::read(&factory).unwrap();
    flipped[5000] ^= 0x10;
    let corrupt = dir.join("corrupt.img");
    std::fs::write(&corrupt, flipped).unwrap();
    let cases = [
        (
            &foreign,
            "the image is for board teensy41, node 0x0002 is a mps2-an500",
        ),
        (&corrupt, "CRC"),
        (
            &not_an_app,
            "restarted running firmware 0.1.0, not the 0.3.0",
        ),
    ];
    for (img, want) in cases {
        let m = machine.to_str().unwrap();
        let (ok, _, stderr) = motet(&["nodes", "flash", m, "ebb", img.to_str().unwrap()]);
        assert!(!ok && stderr.contains(want), "{}: {stderr}", img.display());
        assert!(status(&machine).contains("firmware 0.1.0"));
    }
    assert!(
        board
            .console()
            .contains("boot: staged image refused (payload is not an application for this slot)"),
        "{}",
        board.console()
    );

    // A freshly built image: the bootloader installs it, the board runs it,
    // and keeps its address across the restart.
    let fresh = image(dir, &fw.node, "mps2-an500", "0.2.0");
    let (ok, stdout, stderr) = motet(&[
        "nodes",
        "flash",
        machine.to_str().unwrap(),
        "ebb",
        fresh.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("firmware 0.2.0 verified and started"),
        "{stdout}"
    );
    let s = status(&machine);
    assert!(
        s.contains("ebb: stepper on mps2-an500") && s.contains("firmware 0.2.0 at 2"),
        "{s}"
    );
    assert!(board.console().contains("boot: installed firmware 0.2.0"));

    // The job, on the board, against the simulator's replay of the run.
    // A lead of 400 ms rides out the stalls of a test machine busy with
    // builds (QEMU and the host share its cores); the replay follows the
    // journal whatever the lead. A busy computer leaves the pty's least
    // round trip near 1 ms and the board's clock short of its target: the
    // plotter's only node starts past the connect timeout all the same.
    let out = dir.join("out");
    let (ok, _, stderr) = motet(&[
        "run",
        machine.to_str().unwrap(),
        JOB,
        "--nodes",
        "paired",
        "-q",
        "--lead-ms",
        "400",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("net.json")).unwrap()).unwrap();
    assert_eq!(report["outcome"], "done");
    let tally = &report["nodes"][0]["tally"];
    let m = motet_host::Machine::load(&machine).unwrap();
    let job =
        motet_api::load_job(&m, &root().join(JOB), &motet_api::JobOptions::default()).unwrap();
    let journal = motet_net::journal::Journal::load(&out.join("journal")).unwrap();
    let header = journal.header.unwrap();
    let journaled = (&journal.paces[..], &journal.holds[..]);
    let want = motet_net::replay::replay(&m, job.commands, &header, journaled).unwrap();
    let steps: Vec<u64> = tally["steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    let want_steps: Vec<u64> = want[0].steps.iter().map(|&s| s as u64).collect();
    assert_eq!(steps, want_steps, "steps per channel");
    assert_eq!(tally["tool_changes"], want[0].tool_changes);
    assert_eq!(
        tally["hash"],
        format!("{:016x}", want[0].hash),
        "every step's time"
    );
    assert!(want_steps.iter().sum::<u64>() > 10_000);
    // The pins made every step the node computed.
    board.wait_console("state Stopped");
    std::thread::sleep(Duration::from_millis(2100));
    assert_eq!(pulses(&board.console()), want_steps);
}

#[test]
fn a_killed_host_leaves_the_board_braked_and_resume_finishes() {
    let _serial = serial();
    let tmp = scratch("kill");
    let dir = tmp.path();
    let fw = firmware();
    let factory = image(dir, &fw.node, "mps2-an500", "0.1.0");
    let board = Board::boot(dir, Some(&factory));
    let machine = plotter(dir);
    pair(&machine, &board);
    let out = dir.join("out");
    let mut host = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "run",
            machine.to_str().unwrap(),
            JOB,
            "--nodes",
            "paired",
            "-q",
        ])
        .arg("--out")
        .arg(&out)
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if journal_seals(&out) >= 2 {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "the run never got going"
        );
        assert!(host.try_wait().unwrap().is_none(), "the run ended first");
        std::thread::sleep(Duration::from_millis(10));
    }
    host.kill().unwrap();
    host.wait().unwrap();
    // The board brakes on its committed window's tail and stops there.
    let start = Instant::now();
    while !status(&machine).contains("Stopped") {
        assert!(
            start.elapsed() < Duration::from_secs(15),
            "the board must stop on its tail: {}",
            status(&machine)
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    resume_to_done(&out, &[]);
}

/// Bad input at the board: a board with no application answers nothing;
/// a board that disappears mid-job is reported lost; a machine whose
/// actuator steps faster than the board's channels is refused at pairing.
#[test]
fn a_silent_vanishing_or_too_slow_board_is_a_clear_error() {
    let _serial = serial();
    let tmp = scratch("bad");
    let dir = tmp.path();
    let machine = plotter(dir);

    // No application: the bootloader halts, nothing answers.
    let empty = Board::boot(dir, None);
    empty.wait_console("boot: no factory image either");
    let (ok, stdout, _) = motet(&["nodes", "scan", "--link", &empty.link]);
    assert!(ok && stdout.contains("no node answered"), "{stdout}");
    let (ok, _, stderr) = motet(&[
        "nodes",
        "pair",
        machine.to_str().unwrap(),
        "--link",
        &format!("ebb={}", empty.link),
    ]);
    assert!(!ok && stderr.contains("no node answered"), "{stderr}");
    drop(empty);

    let factory = image(dir, &firmware().node, "mps2-an500", "0.1.0");
    let board = Board::boot(dir, Some(&factory));

    // 256 microsteps and 0.5 µs pulses: the plotter's motors would step
    // faster than the board's channels go.
    let fast = dir.join("fast.toml");
    let text = std::fs::read_to_string(&machine)
        .unwrap()
        .replace("{ microstep = 16 }", "{ microstep = 256 }")
        .replace("joint = \"a\"", "joint = \"a\"\npulse_us = 0.5")
        .replace("joint = \"b\"", "joint = \"b\"\npulse_us = 0.5");
    std::fs::write(&fast, text).unwrap();
    let (ok, _, stderr) = motet(&[
        "nodes",
        "pair",
        fast.to_str().unwrap(),
        "--link",
        &format!("ebb={}", board.link),
    ]);
    assert!(
        !ok && stderr.contains("but the node's channels reach 250000 (mps2-an500)"),
        "{stderr}"
    );

    // The board vanishes mid-job (its serial port with it).
    pair(&machine, &board);
    let out = dir.join("out");
    let host = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args([
            "run",
            machine.to_str().unwrap(),
            JOB,
            "--nodes",
            "paired",
            "-q",
        ])
        .arg("--out")
        .arg(&out)
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while journal_seals(&out) == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "the run never got going"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    drop(board);
    let result = host.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success());
    assert!(
        stderr.contains("node ebb") && stderr.contains("where it is is not known"),
        "{stderr}"
    );
}
