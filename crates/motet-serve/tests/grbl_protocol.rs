//! The grbl device alone, on a session of simulated nodes driven on a
//! simulated clock: lines in, replies out, one reply per line, grbl's
//! error numbers for every kind of bad input, holds and resets.

use motet_serve::grbl::Grbl;
use motet_serve::{serve_config, Session, SimNodes, State};
use proptest::prelude::*;
use std::path::Path;
use std::sync::Arc;

struct Device {
    s: Session,
    g: Grbl,
    now: u64,
    out: String,
}

fn device() -> Device {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/laser.toml");
    let m = motet_host::Machine::load(&path).unwrap();
    let nodes = SimNodes::new(&m, m.start, serve_config());
    let mut d = Device {
        s: Session::new(Arc::new(m.clone()), Box::new(nodes)),
        g: Grbl::new(&m),
        now: 0,
        out: String::new(),
    };
    d.g.open();
    d.drain();
    d
}

impl Device {
    fn drain(&mut self) -> String {
        let o = String::from_utf8(self.g.take_output()).unwrap();
        self.out.push_str(&o);
        o
    }

    /// Sends `bytes`, then runs the clock until every complete line is
    /// answered and the machine is at rest (or 120 s of machine time).
    fn send(&mut self, bytes: &[u8]) -> String {
        self.g.receive(bytes, &mut self.s);
        let mut out = String::new();
        for _ in 0..120_000 {
            self.g.poll(&mut self.s);
            out.push_str(&self.drain());
            let resting = !matches!(
                self.s.state(),
                State::Running | State::Holding | State::Stopping
            );
            if resting && !self.g.has_line() && !self.s.streaming() {
                break;
            }
            if resting && !self.g.has_line() && self.s.state() == State::Paused {
                break;
            }
            self.now += 1_000;
            self.s.tick(self.now);
        }
        out
    }

    /// Sends `bytes` and answers the lines, leaving the machine moving.
    fn start(&mut self, bytes: &[u8]) {
        self.g.receive(bytes, &mut self.s);
        for _ in 0..10_000 {
            self.g.poll(&mut self.s);
            self.drain();
            if !self.g.has_line() {
                break;
            }
            self.now += 1_000;
            self.s.tick(self.now);
        }
    }

    /// Runs the clock until the machine moves, at most 10 s.
    fn until_moving(&mut self) {
        for _ in 0..10_000 {
            if self.s.state() == State::Running && self.s.status().speed > 0.0 {
                return;
            }
            self.now += 1_000;
            self.s.tick(self.now);
        }
        panic!("the machine did not move: {}", self.out);
    }

    fn line(&mut self, l: &str) -> String {
        self.send(format!("{l}\n").as_bytes())
    }

    /// Runs the clock for `us` without input.
    fn wait(&mut self, us: u64) {
        let end = self.now + us;
        while self.now < end {
            self.g.poll(&mut self.s);
            self.drain();
            self.now += 1_000;
            self.s.tick(self.now);
        }
    }
}

fn replies(out: &str) -> Vec<&str> {
    out.lines()
        .filter(|l| *l == "ok" || l.starts_with("error:"))
        .collect()
}

/// (lines sent first, the line, its reply, something the output must hold)
const CASES: &[(&[&str], &str, &str, &str)] = &[
    (&[], "", "ok", ""),
    (&[], "   ", "ok", ""),
    (&[], "; only a comment", "ok", ""),
    (&[], "G21 G90", "ok", ""),
    (&[], "g0 x1", "ok", ""),
    (&[], "N5 G0 X1", "ok", ""),
    // 80 characters is the longest line; 81 is refused whole.
    (
        &[],
        "G0 X1                                                                           ",
        "ok",
        "",
    ),
    (
        &[],
        "G0 X1                                                                            ",
        "error:11",
        "",
    ),
    (&[], "G1 X5 Y5", "error:22", "no F word"),
    (&[], "G38.2 X1", "error:20", "unsupported G-code G38.2"),
    (&[], "G0 G1 X1", "error:21", "same modal group"),
    (&[], "G1 X1 X2 F100", "error:25", "twice"),
    (&[], "G1 X1.2.3 F100", "error:2", ""),
    (&[], "G2 X10 Y10 I0 J0 F100", "error:34", "radius"),
    (&[], "G1 X500 F100", "error:9", "ALARM:2"),
    (&["G1 X500 F100"], "G0 X1", "error:9", ""),
    (&["G1 X500 F100"], "$X", "ok", "[MSG:Caution: Unlocked]"),
    (&[], "$", "ok", "[HLP:"),
    (&[], "$I", "ok", "[VER:1.1h.motet:]\r\n[OPT:V,128,128]"),
    (
        &[],
        "$G",
        "ok",
        "[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]",
    ),
    (
        &["G91 G1 F600"],
        "$G",
        "ok",
        "[GC:G1 G54 G17 G21 G91 G94 M5 M9 T0 F600 S0]",
    ),
    (&[], "$#", "ok", "[G54:0.000,0.000,0.000]"),
    (&["G10 L2 P1 X5 Y6"], "$#", "ok", "[G54:5.000,6.000,0.000]"),
    (
        &[],
        "$$",
        "ok",
        "$100=160.000\r\n$101=160.000\r\n$102=0.000",
    ),
    (&[], "$$", "ok", "$110=24000.000\r\n$111=24000.000"),
    (&[], "$Q", "error:3", ""),
    (&[], "$999=1", "error:3", "no such setting"),
    (&[], "$100=5", "error:3", "machine file"),
    (&[], "$130=5", "error:3", "machine file"),
    (&[], "$110=-5", "error:4", ""),
    (&[], "$110=abc", "error:2", ""),
    (
        &[],
        "$110=60000",
        "error:3",
        "up to the machine file's 24000.000",
    ),
    (&["$110=6000"], "$$", "ok", "$110=6000.000"),
    (&["$10=0"], "$$", "ok", "$10=0"),
    (&[], "$10=7", "error:3", ""),
    (&[], "$N0=G21 G90", "ok", ""),
    (&["$N0=G21 G90"], "$N", "ok", "$N0=G21 G90\r\n$N1="),
    (
        &[],
        "$J=G91 X1000 F100",
        "error:15",
        "beyond the axis's travel",
    ),
    (&[], "$J=G90 X-1 F100", "error:15", ""),
    (&[], "$J=G91 Z1 F100", "error:15", ""),
    (&[], "$J=G91 X1", "error:22", ""),
    (&[], "$J=G91 Q1 F100", "error:16", ""),
    (&[], "$J=G91 G1 X1 F100", "error:16", ""),
    (&[], "$J=G91 X1 X2 F100", "error:25", ""),
    (&[], "$J=F100", "error:26", ""),
    (&[], "$J=G91 X1 F-100", "error:4", ""),
    (&[], "$J=G91 X1.2.3 F100", "error:2", ""),
    (&[], "$J=G91 X2 F600", "ok", ""),
    (&["$C"], "G1 X500 F100", "error:33", "beyond"),
    (&["$C"], "G1 X5 F100", "ok", ""),
    (&[], "$C", "ok", "[MSG:Enabled]"),
    (&["$C"], "$C", "ok", "[MSG:Disabled]"),
];

#[test]
fn every_line_gets_grbls_reply() {
    for (setup, line, reply, holds) in CASES {
        let mut d = device();
        for l in *setup {
            d.line(l);
        }
        let out = d.line(line);
        assert_eq!(
            replies(&out),
            vec![*reply],
            "{line:?} after {setup:?}: {out}"
        );
        assert!(
            out.contains(holds),
            "{line:?} after {setup:?}: {out:?} lacks {holds:?}"
        );
    }
}

fn position(d: &Device) -> Vec<f64> {
    d.s.status().position
}

#[test]
fn streamed_lines_run_and_the_jog_starts_where_they_ended() {
    let mut d = device();
    let out = d.send(b"G21 G90\nG1 X10 Y10 F3000\nG2 X20 Y10 I5 J0\nG91 G1 X-5\n");
    assert_eq!(replies(&out), ["ok"; 4]);
    assert_eq!(position(&d), [15.0, 10.0]);
    d.line("$J=G91 X5 Y-2 F1000");
    assert_eq!(position(&d), [20.0, 8.0]);
    // The next relative move starts where the jog left the machine.
    d.line("G1 X1");
    assert_eq!(position(&d), [21.0, 8.0]);
}

#[test]
fn a_hold_stops_on_the_path_and_resume_ends_where_the_file_does() {
    let mut d = device();
    d.start(b"G21 G90 G1 F3000\nG1 X100 Y0\nG1 X100 Y50\n");
    d.until_moving();
    d.wait(300_000);
    d.send(b"!");
    assert_eq!(d.s.state(), State::Paused, "{}", d.out);
    let held = position(&d);
    let on_path = (held[1] == 0.0 && held[0] > 0.0 && held[0] <= 100.0)
        || (held[0] == 100.0 && held[1] >= 0.0 && held[1] < 50.0);
    assert!(on_path, "held at {held:?}");
    // Lines sent while held are queued behind the held ones.
    d.send(b"G1 X0 Y50\n");
    assert_eq!(position(&d), held, "nothing moves while held");
    d.send(b"?");
    assert!(d.out.contains("<Hold:0|"), "{}", d.out);
    d.send(b"~");
    assert_eq!(position(&d), [0.0, 50.0]);
}

#[test]
fn a_program_end_leaves_the_next_program_free_to_run() {
    let mut d = device();
    let out = d.send(b"G21 G90 G1 X5 F600\nM30\nG0 X3\nG91 G0 X1\n");
    assert_eq!(replies(&out), ["ok"; 4]);
    assert_eq!(position(&d), [4.0, 0.0]);
}

#[test]
fn a_hold_before_the_first_move_starts_holds_it_there() {
    // Before the queued line's run starts, and while its run waits for the
    // nodes' clocks (eight exchanges 10 ms apart before a slope is known).
    for after_us in [0, 40_000] {
        let mut d = device();
        d.start(b"G21 G90 G0 X5\n");
        d.wait(after_us);
        d.send(b"!");
        assert_eq!(d.s.state(), State::Paused, "{after_us}: {}", d.out);
        assert_eq!(position(&d), [0.0, 0.0], "{after_us}");
        d.send(b"G0 Y3\n");
        d.send(b"~");
        assert_eq!(position(&d), [5.0, 3.0], "{after_us}");
    }
}

#[test]
fn a_soft_reset_while_moving_brakes_on_the_path_and_raises_alarm_3() {
    let mut d = device();
    d.start(b"G21 G90 G1 F3000\nG1 X200 Y0\n");
    d.until_moving();
    d.wait(300_000);
    let out = d.send(&[0x18]);
    assert!(
        out.contains("ALARM:3\r\n\r\nGrbl 1.1h ['$' for help]"),
        "{out:?}"
    );
    assert_eq!(d.s.state(), State::Stopped);
    let p = position(&d);
    assert!(p[0] > 0.0 && p[0] < 200.0 && p[1] == 0.0, "{p:?}");
    assert_eq!(replies(&d.line("G0 X1")), ["error:9"]);
    assert_eq!(replies(&d.line("$X")), ["ok"]);
    assert_eq!(replies(&d.line("G0 X1")), ["ok"]);
    assert_eq!(position(&d), [1.0, 0.0]);
}

#[test]
fn jog_cancel_stops_a_jog_short_of_its_target() {
    let mut d = device();
    d.start(b"$J=G91 X100 F600\n");
    d.until_moving();
    d.wait(300_000);
    assert!(d.s.jogging(), "{}", d.out);
    d.send(&[0x85]);
    let p = position(&d);
    assert!(p[0] > 0.0 && p[0] < 100.0, "{p:?}");
    assert_eq!(d.s.state(), State::Idle);
}

#[test]
fn overrides_are_kept_and_reported() {
    let mut d = device();
    let out = d.send(&[0x91, 0x91, 0x94, 0x96, 0x9A, b'?']);
    assert!(out.contains("|Ov:119,50,110|"), "{out}");
    let out = d.send(&[0x90, 0x95, 0x99, b'?']);
    assert!(out.contains("|Ov:100,100,100|"), "{out}");
}

#[test]
fn status_reports_work_positions_under_10_rules() {
    let mut d = device();
    d.line("G10 L2 P1 X5 Y6");
    d.line("G0 X1 Y1");
    let out = d.send(b"?");
    assert!(
        out.contains("<Idle|MPos:6.000,7.000,0.000|Bf:128,128|"),
        "{out}"
    );
    assert!(out.contains("|WCO:5.000,6.000,0.000>"), "{out}");
    d.line("$10=0");
    let out = d.send(b"?");
    assert!(out.contains("<Idle|WPos:1.000,1.000,0.000|FS:"), "{out}");
}

/// Lines in a byte string, as the receive buffer splits them (`\r\n` is one
/// end), real-time bytes taken out.
fn complete_lines(bytes: &[u8]) -> usize {
    let mut n = 0;
    let mut after_cr = false;
    for &b in bytes {
        // Real-time bytes and the other bytes from 0x80 up never reach
        // the line buffer.
        if motet_serve::grbl::realtime::classify(b).is_some() || b >= 0x80 {
            continue;
        }
        match b {
            b'\n' if after_cr => after_cr = false,
            b'\n' => n += 1,
            b'\r' => {
                n += 1;
                after_cr = true;
            }
            _ => after_cr = false,
        }
    }
    n
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random bytes never panic, and every complete line gets exactly one
    /// reply (holds, resets and M0, which wait or drop lines, left out).
    #[test]
    fn random_bytes_get_one_reply_per_line(
        bytes in proptest::collection::vec(
            prop_oneof![
                4 => proptest::sample::select(b"G0123XYZFJ$=. -\n\r?".to_vec()),
                1 => any::<u8>().prop_filter("no hold, door, reset or M0 (which wait for ~)", |b| {
                    !matches!(b, b'!' | 0x84 | 0x18 | b'M' | b'm')
                }),
            ],
            0..300,
        )
    ) {
        let mut d = device();
        let out = d.send(&bytes);
        prop_assert_eq!(replies(&out).len(), complete_lines(&bytes), "{:?}", out);
    }
}

#[test]
fn an_endless_line_is_refused_once_and_not_kept() {
    let mut d = device();
    let long = format!("G0 X1{}", "9".repeat(100_000));
    d.g.receive(long.as_bytes(), &mut d.s);
    assert!(d.g.wants_input(), "the overlong line's bytes are not kept");
    let out = d.send(b"\nG0 X2\n");
    assert_eq!(replies(&out), ["error:11", "ok"]);
    assert_eq!(position(&d), [2.0, 0.0]);
}

#[test]
fn m0_pauses_after_the_motion_before_it_until_resumed() {
    let mut d = device();
    d.start(b"G21 G90 G0 X5\nM0\nG0 X10\n");
    for _ in 0..10_000 {
        d.wait(1_000);
        if replies(&d.out).len() == 2 {
            break;
        }
    }
    // The M0 line is answered once the machine rests after X5; the line
    // after it waits.
    assert_eq!(replies(&d.out), ["ok", "ok"], "{}", d.out);
    assert_eq!(position(&d), [5.0, 0.0]);
    d.wait(500_000);
    assert_eq!(position(&d), [5.0, 0.0], "nothing runs until ~");
    assert!(d.send(b"?").contains("<Hold:0|"));
    let out = d.send(b"~");
    assert_eq!(replies(&out), ["ok"]);
    assert_eq!(position(&d), [10.0, 0.0]);
}

#[test]
fn queued_lines_report_run_before_their_run_starts() {
    let mut d = device();
    d.start(b"G21 G90 G0 X5\n");
    assert!(d.send(b"?").contains("<Run|"), "{}", d.out);
}

#[test]
fn overrides_apply_live_to_queued_lines() {
    let mut d = device();
    // Four 50 mm lines at 10 mm/s, all queued before the first ends.
    d.start(b"G21 G90 G1 F600\nG1 X50 Y0\nG1 X50 Y50\nG1 X0 Y50\nG1 X0 Y0\n");
    d.until_moving();
    d.wait(1_000_000);
    let before = d.s.status().speed;
    assert!((before - 10.0).abs() < 0.5, "{before} mm/s");
    // Feed override to 200 %: the lines not yet planned run at twice the
    // feed (the one under way keeps its speed).
    d.g.receive(&[0x91; 10], &mut d.s);
    d.wait(6_000_000);
    let after = d.s.status().speed;
    assert!(
        (after - 20.0).abs() < 1.0,
        "{after} mm/s after the override"
    );
    // Back to 100 %, then rapids at 25 %: a rapid queued after is capped at a
    // quarter of the slowest path axis.
    d.g.receive(&[0x90, 0x97], &mut d.s);
    d.wait(3_000_000);
    assert!(
        (d.s.status().speed - 10.0).abs() < 0.5,
        "{}",
        d.s.status().speed
    );
    d.send(b"G0 X200 Y0\n");
    let m = motet_host::Machine::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/laser.toml"),
    )
    .unwrap();
    let slowest = m
        .axes
        .iter()
        .filter(|a| a.path)
        .map(|a| a.max_velocity)
        .fold(f64::INFINITY, f64::min);
    d.start(b"G0 X0 Y0\n");
    d.until_moving();
    d.wait(500_000);
    let rapid = d.s.status().speed;
    assert!(
        (rapid - slowest / 4.0).abs() < 0.02 * slowest,
        "rapid {rapid} mm/s, slowest axis {slowest}"
    );
    d.send(b"");
    assert_eq!(position(&d), [0.0, 0.0]);
}
