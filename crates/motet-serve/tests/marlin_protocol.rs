//! The Marlin-style device alone, on a session of simulated nodes driven
//! on a simulated clock: line numbers and checksums with `Resend:`, one
//! `ok` per command, temperature reports, heating waits held with
//! keep-alives, bad input refused without losing or repeating anything.

use motet_serve::marlin::frame::{checksum, FrameError, Framer};
use motet_serve::marlin::Marlin;
use motet_serve::{serve_config, Session, SimNodes, State};
use proptest::prelude::*;
use std::path::Path;
use std::sync::Arc;

struct Dev {
    s: Session,
    m: Marlin,
    now: u64,
}

fn device() -> Dev {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/printer.toml");
    let machine = motet_host::Machine::load(&path).unwrap();
    let nodes = SimNodes::new(&machine, machine.start, serve_config());
    let mut d = Dev {
        s: Session::new(Arc::new(machine.clone()), Box::new(nodes)),
        m: Marlin::new(&machine),
        now: 0,
    };
    d.m.open();
    d.m.take_output();
    d
}

/// `N<n> <cmd>*<checksum>` as a host frames it.
fn numbered(n: u32, cmd: &str) -> String {
    let body = format!("N{n} {cmd}");
    format!("{body}*{}\n", checksum(body.as_bytes()))
}

impl Dev {
    fn out(&mut self) -> String {
        String::from_utf8(self.m.take_output()).unwrap()
    }

    /// Sends `text`, then runs the clock (1 ms ticks) until every command is
    /// answered and the machine is at rest, at most `max_s` of machine time.
    fn send_for(&mut self, text: &str, max_s: f64) -> String {
        self.m.receive(text.as_bytes(), &mut self.s);
        let mut out = String::new();
        for _ in 0..(max_s * 1000.0) as u64 {
            self.m.poll(&mut self.s);
            out.push_str(&self.out());
            let resting = !matches!(
                self.s.state(),
                State::Running | State::Holding | State::Stopping
            );
            if resting && !self.m.busy() && !self.s.streaming() {
                break;
            }
            self.now += 1_000;
            self.s.tick(self.now);
        }
        out
    }

    fn send(&mut self, text: &str) -> String {
        self.send_for(text, 60.0)
    }
}

fn oks(out: &str) -> usize {
    out.lines().filter(|l| l.starts_with("ok")).count()
}

#[test]
fn numbered_lines_with_good_checksums_get_one_ok_each() {
    let mut d = device();
    let mut text = numbered(0, "M110 N0");
    for (n, cmd) in ["G28", "G1 X10 Y5 F3000", "G1 X20 E1", "M114"]
        .iter()
        .enumerate()
    {
        text.push_str(&numbered(n as u32 + 1, cmd));
    }
    let out = d.send(&text);
    assert_eq!(oks(&out), 5, "{out}");
    assert!(!out.contains("Error"), "{out}");
    assert!(out.contains("X:20.00 Y:5.00 Z:0.00 E:1.00"), "{out}");
    assert_eq!(d.m.last_line(), 4);
    let p = d.s.status().position;
    assert!(
        (p[0] - 20.0).abs() < 1e-6 && (p[1] - 5.0).abs() < 1e-6,
        "{p:?}"
    );
}

#[test]
fn a_bad_checksum_or_a_skipped_number_asks_for_the_line_again_and_runs_nothing() {
    let mut d = device();
    d.send(&numbered(0, "M110 N0"));
    let mut bad = numbered(1, "G1 X50 F3000");
    bad = bad.replace("X50", "X80"); // corrupted in transit
    let out = d.send(&bad);
    assert_eq!(
        out, "Error:checksum mismatch, Last Line: 0\nResend: 1\nok\n",
        "Marlin's own words"
    );
    let out = d.send(&numbered(2, "G1 X60 F3000"));
    assert!(
        out.starts_with("Error:Line Number is not Last Line Number+1, Last Line: 0\nResend: 1\n"),
        "{out}"
    );
    let out = d.send("N1 G1 X60 F3000\n");
    assert!(
        out.starts_with("Error:No Checksum with line number, Last Line: 0\nResend: 1"),
        "{out}"
    );
    assert_eq!(
        d.s.status().position[0],
        0.0,
        "nothing of the bad lines ran"
    );
    // The host resends line 1: it runs once.
    let out = d.send(&numbered(1, "G1 X50 F3000"));
    assert_eq!(out, "ok\n");
    assert!((d.s.status().position[0] - 50.0).abs() < 1e-6);
    assert_eq!(d.s.stream_status().runs, 1);
    assert_eq!(d.m.replies, 2, "the M110 and the good line 1");
}

#[test]
fn m105_m115_and_auto_reports_speak_marlin() {
    let mut d = device();
    let out = d.send("M105\n");
    assert_eq!(out, "ok T:25.00 /0.00 B:25.00 /0.00 @:0 B@:0\n");
    let out = d.send("M115\n");
    assert!(out.starts_with("FIRMWARE_NAME:Marlin"), "{out}");
    assert!(out.contains("Cap:AUTOREPORT_TEMP:1\n"), "{out}");
    assert!(out.contains("Cap:EMERGENCY_PARSER:1\n"), "{out}");
    assert!(out.ends_with("ok\n"));
    assert_eq!(d.send("M21\n"), "echo:SD init fail\nok\n");
    // M155 S1: a report every second of the session's clock.
    assert_eq!(d.send("M155 S1\n"), "ok\n");
    let mut out = String::new();
    for _ in 0..3500 {
        d.now += 1_000;
        d.s.tick(d.now);
        d.m.poll(&mut d.s);
        out.push_str(&d.out());
    }
    let reports = out.lines().filter(|l| l.starts_with(" T:")).count();
    assert_eq!(reports, 3, "{out}");
    d.send("M155 S0\n");
    d.now += 3_000_000;
    d.s.tick(d.now);
    d.m.poll(&mut d.s);
    assert_eq!(d.out(), "", "reports off");
}

#[test]
fn m109_holds_its_ok_with_keepalives_until_the_moves_are_done_and_the_hotend_is_hot() {
    let mut d = device();
    d.send("M155 S0\n");
    // A long move, then the wait: the `ok` for M109 comes only after both.
    d.m.receive(b"G1 X200 F600\nM109 S40\nG1 X0\n", &mut d.s);
    let mut log: Vec<(u64, String)> = Vec::new();
    let mut moved_at = None;
    let mut temp_at_ok = None;
    for _ in 0..200_000 {
        d.m.poll(&mut d.s);
        for l in d.out().lines() {
            if l == "ok" && log.iter().filter(|(_, l)| l == "ok").count() == 1 {
                temp_at_ok = Some(d.s.heaters()[0].temp);
            }
            log.push((d.now, l.to_string()));
        }
        if moved_at.is_none() && d.s.state() == State::Idle && d.s.status().position[0] > 199.999 {
            moved_at = Some(d.now);
        }
        if oks_in(&log) == 3 {
            break;
        }
        d.now += 1_000;
        d.s.tick(d.now);
    }
    assert_eq!(oks_in(&log), 3, "{log:?}");
    let ok_times: Vec<u64> = log
        .iter()
        .filter(|(_, l)| l == "ok")
        .map(|(t, _)| *t)
        .collect();
    let moved_at = moved_at.expect("the move ran");
    assert!(
        ok_times[1] >= moved_at,
        "M109's ok after the move: {ok_times:?} {moved_at}"
    );
    let temp = temp_at_ok.unwrap();
    assert!(temp >= 38.0, "hot when answered: {temp}");
    // Keep-alives every 2 s and temperatures every second while held.
    let busy: Vec<u64> = log
        .iter()
        .filter(|(_, l)| l == "echo:busy: processing")
        .map(|(t, _)| *t)
        .collect();
    let held_s = (ok_times[1] - ok_times[0]) as f64 * 1e-6;
    assert!(
        busy.len() as f64 >= held_s / 2.0 - 1.0,
        "{} in {held_s} s",
        busy.len()
    );
    assert!(
        busy.windows(2).all(|w| w[1] - w[0] == 2_000_000),
        "{busy:?}"
    );
    let waits = log.iter().filter(|(_, l)| l.ends_with(" W:?")).count();
    assert!(waits >= 5, "temperatures during the wait: {waits}");
    assert_eq!(d.s.heaters()[0].target, 40.0);
    println!(
        "M109 S40 held {held_s:.1} s of machine time, {} keep-alives",
        busy.len()
    );
}

fn oks_in(log: &[(u64, String)]) -> usize {
    log.iter().filter(|(_, l)| l.starts_with("ok")).count()
}

#[test]
fn m108_ends_a_heating_wait_and_m112_stops_everything_and_cools() {
    let mut d = device();
    d.m.receive(b"M190 S100\n", &mut d.s);
    for _ in 0..100 {
        d.m.poll(&mut d.s);
        d.now += 10_000;
        d.s.tick(d.now);
    }
    assert!(d.m.busy(), "still heating");
    d.m.receive(b"M108\n", &mut d.s);
    d.m.poll(&mut d.s);
    let out = d.out();
    assert_eq!(oks(&out), 2, "the wait and M108 answered: {out}");
    assert_eq!(d.s.heaters()[1].target, 100.0, "the target stays");
    d.m.receive(b"M104 S200\nG1 X100 F600\n", &mut d.s);
    // Until the move is under way (the nodes connect first).
    for _ in 0..10_000 {
        d.m.poll(&mut d.s);
        d.now += 1_000;
        d.s.tick(d.now);
        if d.s.status().position[0] > 1.0 {
            break;
        }
    }
    assert_eq!(d.s.state(), State::Running);
    assert_eq!(
        d.s.heaters()[0].target,
        200.0,
        "M104 set as the stream reached it"
    );
    d.m.receive(b"M112\n", &mut d.s);
    assert!(d.out().contains("kill() called"));
    assert!(d.s.heaters().iter().all(|h| h.target == 0.0), "heaters off");
    for _ in 0..2000 {
        d.now += 1_000;
        d.s.tick(d.now);
    }
    assert_eq!(d.s.state(), State::Stopped);
    let out = d.send("G1 X10\n");
    assert!(out.starts_with("Error:Printer halted"), "{out}");
    assert_eq!(d.send("M999\n"), "ok\n");
    assert_eq!(d.send("G1 X10 F600\n"), "ok\n");
}

#[test]
fn bad_targets_and_unknown_commands_get_their_own_answers() {
    let mut d = device();
    let out = d.send("M104 S400\n");
    assert!(
        out.starts_with("Error:hotend target 400 °C is above its maximum"),
        "{out}"
    );
    assert_eq!(d.s.heaters()[0].target, 0.0);
    assert_eq!(d.send("M4242\n"), "echo:Unknown command: \"M4242\"\nok\n");
    let out = d.send("G1 X999 F600\n");
    assert!(out.starts_with("Error:") && out.ends_with("ok\n"), "{out}");
    // The refused move left nothing behind: a relative move starts at 0.
    assert_eq!(d.send("G91\nG1 X5 F600\nG90\n"), "ok\nok\nok\n");
    assert!((d.s.status().position[0] - 5.0).abs() < 1e-6);
}

proptest! {
    #[test]
    fn the_framer_takes_good_lines_and_refuses_bad_ones_whatever_the_bytes(
        raw in "[ -~]{0,300}", cmd in "[GM][0-9]{1,3}( [XYZEFS][0-9]{1,3})*",
        n in 1u32..100_000, flip in 0usize..40,
    ) {
        let mut f = Framer { last: n - 1 };
        let before = f.last;
        match f.frame(&raw) {
            Ok(_) => {}
            Err(FrameError::TooLong { len }) => prop_assert!(len > 256),
            Err(_) => prop_assert_eq!(f.last, before, "a refused line moves nothing"),
        }
        // M110 takes any number (it sets the numbering): not this case.
        prop_assume!(motet_serve::marlin::frame::code(&cmd) != "M110");
        // A good numbered line is taken exactly.
        let mut f = Framer { last: n - 1 };
        let line = numbered(n, &cmd);
        prop_assert_eq!(f.frame(line.trim_end()), Ok(Some(cmd.clone())));
        prop_assert_eq!(f.last, n);
        // The same line again, or with one byte changed: refused.
        prop_assert!(f.frame(line.trim_end()).is_err());
        let mut f = Framer { last: n - 1 };
        let mut bytes = line.trim_end().as_bytes().to_vec();
        let i = flip % bytes.len();
        bytes[i] ^= 0x01;
        let changed = String::from_utf8_lossy(&bytes).into_owned();
        // One bit changes the XOR (or the number, or the `*`): refused.
        prop_assert!(f.frame(&changed).is_err(), "{:?} taken", changed);
    }
}
