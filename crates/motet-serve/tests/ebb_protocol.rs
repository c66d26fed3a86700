//! The EiBotBoard device alone, on a session of simulated nodes driven on
//! a simulated clock: commands in, the board's replies out byte for byte
//! (legacy and future syntax), its `!N Err:` errors for bad input, the
//! AxiDraw's step geometry on the machine, the pen, flow control, `ES`.

use motet_serve::ebb::motion::MM_PER_STEP;
use motet_serve::ebb::Ebb;
use motet_serve::{serve_config, Session, SimNodes, State};
use proptest::prelude::*;
use std::path::Path;
use std::sync::Arc;

struct Device {
    s: Session,
    e: Ebb,
    now: u64,
}

fn device_on(file: &str) -> Device {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(file);
    let m = motet_host::Machine::load(&path).unwrap();
    let nodes = SimNodes::new(&m, m.start, serve_config());
    Device {
        s: Session::new(Arc::new(m.clone()), Box::new(nodes)),
        e: Ebb::new(&m),
        now: 0,
    }
}

fn device() -> Device {
    device_on("plotter.toml")
}

impl Device {
    /// Sends `bytes`, then runs the clock until every line is answered and
    /// the machine is at rest (or 120 s of machine time).
    fn send(&mut self, bytes: &[u8]) -> String {
        self.e.receive(bytes, &mut self.s);
        let mut out = String::new();
        for _ in 0..120_000 {
            self.e.poll(&mut self.s);
            out.push_str(&String::from_utf8(self.e.take_output()).unwrap());
            let resting = !matches!(
                self.s.state(),
                State::Running | State::Holding | State::Stopping
            );
            if resting && !self.s.streaming() && !self.e.has_line() {
                break;
            }
            self.now += 1_000;
            self.s.tick(self.now);
        }
        out
    }

    /// Answers what can be answered now, without running the clock.
    fn now(&mut self, bytes: &[u8]) -> String {
        self.e.receive(bytes, &mut self.s);
        self.e.poll(&mut self.s);
        String::from_utf8(self.e.take_output()).unwrap()
    }

    /// Runs the clock for `ms` of machine time.
    fn run_ms(&mut self, ms: u64) {
        for _ in 0..ms {
            self.e.poll(&mut self.s);
            self.now += 1_000;
            self.s.tick(self.now);
        }
    }

    /// Runs the clock until the machine has moved, at most 10 s.
    fn until_moving(&mut self) {
        let start = self.xy();
        for _ in 0..10_000 {
            if self.xy() != start {
                return;
            }
            self.run_ms(1);
        }
        panic!("the machine did not move");
    }

    fn xy(&self) -> (f64, f64) {
        let p = self.s.position();
        (p[0], p[1])
    }
}

fn near(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9
}

#[test]
fn the_version_line_is_the_boards() {
    let mut d = device();
    assert_eq!(
        d.now(b"v\r"),
        "EBBv13_and_above EB Firmware Version 3.0.3\r\n"
    );
    assert_eq!(d.now(b"CU,10,1\r"), "CU\n");
    assert_eq!(
        d.now(b"V\r"),
        "V,EBBv13_and_above EB Firmware Version 3.0.3\n"
    );
}

#[test]
fn legacy_replies_are_byte_exact() {
    let mut d = device();
    let cases: &[(&str, &str)] = &[
        ("EM,1,1", "OK\r\n"),
        ("SC,4,16000", "OK\r\n"),
        ("SR,60000", "OK\r\n"),
        ("SL,42", "OK\r\n"),
        ("QL", "42\r\nOK\r\n"),
        ("SL,7,3", "OK\r\n"),
        ("QL,3", "7\r\nOK\r\n"),
        ("QB", "0\r\nOK\r\n"),
        ("QC", "0394,0300\r\nOK\r\n"),
        ("QE", "16,16\r\nOK\r\n"),
        ("QG", "10\r\n"),
        ("QM", "QM,0,0,0,0\n\r"),
        ("QP", "1\n\rOK\r\n"),
        ("QR", "1\n\rOK\r\n"),
        ("QS", "0,0\n\rOK\r\n"),
        ("ST,East", "OK\r\n"),
        ("QT", "East\r\nOK\r\n"),
        ("PO,B,3,1", "OK\r\n"),
        ("PI,B,3", "PI,1\r\n"),
        ("PD,B,3,0", "OK\r\n"),
        ("CS", "OK\r\n"),
        ("ES", "0\n\rOK\r\n"),
    ];
    for (cmd, reply) in cases {
        assert_eq!(d.now(format!("{cmd}\r").as_bytes()), *reply, "{cmd}");
    }
}

#[test]
fn future_replies_echo_the_command() {
    let mut d = device();
    d.now(b"CU,10,1\r");
    let cases: &[(&str, &str)] = &[
        ("EM,2,2", "EM\n"),
        ("QE", "QE,8,8\n"),
        ("QG", "QG,10\n"),
        ("QP", "QP,1\n"),
        ("QS", "QS,0,0\n"),
        ("QB", "QB,0\n"),
        ("QM", "QM,0,0,0,0\n"),
        ("PI,E,0", "PI,0\n"),
        ("ES", "ES,0\n"),
    ];
    for (cmd, reply) in cases {
        assert_eq!(d.now(format!("{cmd}\r").as_bytes()), *reply, "{cmd}");
    }
}

#[test]
fn bad_commands_get_the_boards_errors_in_both_syntaxes() {
    let mut d = device();
    let cases: &[(&str, &str, &str)] = &[
        ("SM,100", "!4 Err: Missing parameter(s)", "SM"),
        ("SM,100A,1", "!5 Err: Need comma next, found: 'A'", "SM"),
        ("TP,-1", "!6 Err: Invalid parameter value", "TP"),
        ("SM,0,10,10", "!6 Err: Invalid parameter value", "SM"),
        ("SP,2", "!6 Err: Invalid parameter value", "SP"),
        ("EM,6", "!6 Err: Invalid parameter value", "EM"),
        ("SL,256", "!6 Err: Invalid parameter value", "SL"),
        ("HM,1", "!6 Err: Invalid parameter value", "HM"),
        ("HM,1000,5", "!4 Err: Missing parameter(s)", "HM"),
        ("SM,1,1,1,0,0", "!7 Err: Extra parameter", "SM"),
        ("QS,1", "!7 Err: Extra parameter", "QS"),
        ("BB", "!8 Err: Unknown command 'BB:4242'", "BB"),
        ("B", "!8 Err: Unknown command 'B:42'", "B"),
        ("HELLO,1", "!8 Err: Unknown command 'HE:4845'", "HE"),
        (
            "SM,99999999999,1,1",
            "!6 Err: Invalid parameter value",
            "SM",
        ),
    ];
    for (cmd, err, _) in cases {
        assert_eq!(
            d.now(format!("{cmd}\r").as_bytes()),
            format!("{err}\r\n"),
            "{cmd}"
        );
    }
    d.now(b"CU,10,1\r");
    for (cmd, err, name) in cases {
        assert_eq!(
            d.now(format!("{cmd}\r").as_bytes()),
            format!("{name},{err}\n"),
            "{cmd}"
        );
    }
    assert_eq!(d.xy(), (0.0, 0.0), "nothing moved");
    assert!(!d.s.streaming(), "nothing was queued");
}

#[test]
fn a_line_longer_than_the_buffer_is_an_overrun_and_not_kept() {
    let mut d = device();
    let long = format!("SM,1{},1,1\r", "0".repeat(10_000));
    assert_eq!(d.now(long.as_bytes()), "!3 Err: RX Buffer overrun\r\n");
    assert_eq!(d.now(b"QS\r"), "0,0\n\rOK\r\n");
}

#[test]
fn steps_map_to_the_axidraw_geometry() {
    let mut d = device();
    // XM: A = x, B = y in steps of 1/2032 inch.
    d.send(b"EM,1,1\rXM,200,2032,0\r");
    assert!(near(d.xy(), (25.4, 0.0)), "{:?}", d.xy());
    d.send(b"XM,200,0,1016\r");
    assert!(near(d.xy(), (25.4, 12.7)), "{:?}", d.xy());
    // SM's motors directly: motor1 = x + y, motor2 = x - y.
    d.send(b"SM,100,100,-100\r");
    assert!(
        near(d.xy(), (25.4, 12.7 + 100.0 * MM_PER_STEP)),
        "{:?}",
        d.xy()
    );
    assert_eq!(d.now(b"QS\r"), "3148,916\n\rOK\r\n");
    // 1/8 stepping: each step is two sixteenths; the counters restart.
    d.send(b"EM,2,2\rXM,100,-1016,0\r");
    assert!(
        near(d.xy(), (0.0, 12.7 + 100.0 * MM_PER_STEP)),
        "{:?}",
        d.xy()
    );
    assert_eq!(d.now(b"QS\r"), "-1016,-1016\n\rOK\r\n");
    // Home: back to where the counters were cleared (EM), in a straight line.
    d.send(b"HM,5000\r");
    assert!(
        near(d.xy(), (25.4, 12.7 + 100.0 * MM_PER_STEP)),
        "{:?}",
        d.xy()
    );
    assert_eq!(d.now(b"QS\r"), "0,0\n\rOK\r\n");
}

#[test]
fn rate_moves_take_the_firmware_models_steps() {
    let mut d = device();
    d.send(b"EM,1,1\rLM,85899346,1000,0,85899346,500,0,3\r");
    assert_eq!(d.now(b"QS\r"), "1000,500\n\rOK\r\n");
    // LT for 12500 ticks from 17179000 slowing by 687: 75 steps.
    d.send(b"LT,12500,17179000,-687,0,0,3\r");
    assert_eq!(d.now(b"QS\r"), "1075,500\n\rOK\r\n");
    // T3 that moves nothing (plotink clears accumulators this way).
    assert_eq!(d.send(b"T3,1,0,0,0,0,0,0,3\r"), "OK\r\n");
    assert_eq!(d.now(b"QS\r"), "1075,500\n\rOK\r\n");
}

#[test]
fn the_five_bar_machine_draws_the_same_steps() {
    let mut d = device_on("fivebar.toml");
    let (x0, y0) = d.xy();
    d.send(b"EM,1,1\rSP,0,100\rXM,300,1016,508\rXM,300,-1016,0\rSP,1,100\r");
    assert!(near(d.xy(), (x0, y0 + 6.35)), "{:?}", d.xy());
    assert_eq!(d.s.state(), State::Idle);
}

#[test]
fn the_pen_follows_sp_and_tp() {
    let mut d = device();
    assert_eq!(d.send(b"SP,0,200\r"), "OK\r\n");
    assert_eq!(d.now(b"QP\r"), "0\n\rOK\r\n");
    assert_eq!(d.now(b"QG\r"), "00\r\n");
    assert_eq!(d.send(b"TP\r"), "OK\r\n");
    assert_eq!(d.now(b"QP\r"), "1\n\rOK\r\n");
    assert_eq!(d.now(b"QG\r"), "10\r\n");
}

#[test]
fn a_move_beyond_the_travel_is_refused_and_the_machine_stays_safe() {
    let mut d = device();
    d.send(b"XM,100,400,400\r");
    let before = d.xy();
    assert_eq!(
        d.send(b"XM,2000,-40000,0\r"),
        "!6 Err: Invalid parameter value\r\n"
    );
    assert_eq!(d.s.state(), State::Idle);
    assert_eq!(d.xy(), before);
    assert_eq!(d.now(b"QS\r"), "800,0\n\rOK\r\n");
    d.send(b"XM,100,-400,-400\r");
    assert!(near(d.xy(), (0.0, 0.0)));
}

#[test]
fn errors_between_moves_lose_nothing_queued() {
    let mut d = device();
    let out = d.send(b"XM,200,500,0\rXM,1\rZZ\rXM,200,0,500\rSM,10,1,2,3,4,5\rXM,200,-100,-100\r");
    assert_eq!(
        out,
        "OK\r\n!4 Err: Missing parameter(s)\r\n!8 Err: Unknown command 'ZZ:5A5A'\r\n\
         OK\r\n!7 Err: Extra parameter\r\nOK\r\n"
    );
    let want = (400.0 * MM_PER_STEP, 400.0 * MM_PER_STEP);
    assert!(near(d.xy(), want), "{:?}", d.xy());
}

#[test]
fn a_full_queue_holds_the_line_and_every_move_runs() {
    let mut d = device();
    let mut bytes = Vec::new();
    for _ in 0..300 {
        bytes.extend_from_slice(b"XM,2,10,3\r");
    }
    // The port reads in pieces while the device wants input.
    let mut out = String::new();
    let mut at = 0;
    let mut held = false;
    for _ in 0..200_000 {
        if at < bytes.len() && d.e.wants_input() {
            let end = (at + 64).min(bytes.len());
            d.e.receive(&bytes[at..end], &mut d.s);
            at = end;
        }
        held |= !d.e.wants_input();
        d.e.poll(&mut d.s);
        out.push_str(&String::from_utf8(d.e.take_output()).unwrap());
        if at == bytes.len() && !d.e.has_line() && !d.s.streaming() && d.s.state() == State::Idle {
            break;
        }
        d.now += 1_000;
        d.s.tick(d.now);
    }
    assert!(held, "the queue filled and the port stopped reading");
    assert_eq!(out, "OK\r\n".repeat(300));
    assert_eq!(d.now(b"QS\r"), "3900,2100\n\rOK\r\n");
    assert!(near(d.xy(), (3000.0 * MM_PER_STEP, 900.0 * MM_PER_STEP)));
}

#[test]
fn es_stops_the_motion_and_the_board_goes_on() {
    let mut d = device();
    d.now(b"EM,1,1\rXM,2000,8000,0\rXM,2000,0,8000\r");
    d.until_moving();
    d.run_ms(300);
    assert_eq!(d.s.state(), State::Running);
    assert_eq!(d.now(b"ES\r"), "1\n\rOK\r\n");
    d.send(b"");
    d.run_ms(50);
    assert_eq!(d.s.state(), State::Idle, "unlocked after the stop");
    let (x, y) = d.xy();
    assert!(
        x > 1.0 && x < 8000.0 * MM_PER_STEP && y.abs() < 1e-9,
        "{x},{y}"
    );
    // The counters say where the motors stopped, to the step.
    let qs = d.now(b"QS\r");
    let a: i64 = qs.split(',').next().unwrap().parse().unwrap();
    assert!(
        (a as f64 * MM_PER_STEP - x).abs() <= MM_PER_STEP,
        "{qs} vs {x}"
    );
    // And it takes moves again, from there.
    d.send(b"XM,100,100,0\r");
    assert!((d.xy().0 - x - 100.0 * MM_PER_STEP).abs() <= MM_PER_STEP);
}

#[test]
fn a_hold_from_another_client_is_the_pause_button() {
    let mut d = device();
    d.now(b"XM,2000,8000,0\r");
    d.until_moving();
    d.s.pause(Some("page")).unwrap();
    d.run_ms(300);
    assert_eq!(d.now(b"QB\r"), "1\r\nOK\r\n");
    assert_eq!(d.now(b"QB\r"), "0\r\nOK\r\n", "reading clears it");
}

/// Lines of the board's commands with random parameters, and noise.
fn line() -> impl Strategy<Value = String> {
    let name = prop_oneof![
        proptest::sample::select(vec![
            "V", "QB", "QC", "QE", "QG", "QL", "QM", "QP", "QR", "QS", "QT", "CS", "SC", "SP",
            "SL", "SR", "PI", "PO", "PD", "EM", "ES", "SM", "XM", "LM", "LT", "T3", "HM", "TP",
            "ST",
        ])
        .prop_map(str::to_string),
        "[A-Za-z]{1,3}",
    ];
    let param = prop_oneof![
        (-400i64..400).prop_map(|v| v.to_string()),
        "[0-9A-Z ,.-]{0,4}",
    ];
    (name, proptest::collection::vec(param, 0..8)).prop_map(|(n, ps)| {
        let mut l = n;
        for p in ps {
            l.push(',');
            l.push_str(&p);
        }
        l
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Random commands never panic, and in the future syntax every line
    /// gets exactly one reply line; the machine never ends in alarm.
    #[test]
    fn every_line_gets_one_reply(lines in proptest::collection::vec(line(), 0..24)) {
        let mut d = device();
        d.now(b"CU,10,1\r");
        let text: String = lines.iter().map(|l| format!("{l}\r")).collect();
        let out = d.send(text.as_bytes());
        let expected = lines.iter().filter(|l| !l.trim().is_empty()).count();
        prop_assert_eq!(out.matches('\n').count(), expected, "{:?}", out);
        prop_assert!(d.s.state() != State::Alarm);
    }

    /// The parser on raw bytes: no panic, at most one reply per line.
    #[test]
    fn raw_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let mut d = device();
        d.now(b"CU,10,1\r");
        let out = d.send(&bytes);
        let lines = bytes.iter().filter(|b| **b == b'\r').count();
        prop_assert!(out.matches('\n').count() <= lines);
    }
}
