//! The Stepdance wire encoding: bit-exact layout, round trips, chaining.

use motet_node::graph::wire::*;

fn subset(mask: u8, fwd: u8) -> Signals {
    let mut s = Signals::NONE;
    for c in 0..6u8 {
        if mask & (1 << c) != 0 {
            s.set(c, fwd & (1 << c) != 0);
        }
    }
    s
}

/// Which codes of `mask` fit the window, packed in code order.
fn expected_fit(mask: u8) -> u8 {
    let mut t = FIRST_PULSE_US;
    let mut fit = 0;
    for c in 0..6u8 {
        if mask & (1 << c) != 0 {
            let w = c as usize + 2;
            if t + w <= WINDOW_US {
                fit |= 1 << c;
                t += w + GAP_US;
            }
        }
    }
    fit
}

#[test]
fn pulse_widths_are_code_plus_two() {
    for (sig, w) in [
        (Signal::X, 2),
        (Signal::Y, 3),
        (Signal::R, 4),
        (Signal::T, 5),
        (Signal::Z, 6),
        (Signal::E, 7),
    ] {
        assert_eq!(pulse_width(sig as u8), w);
        let e = encode(subset(1 << sig as u8, 0));
        assert_eq!(e.lines.step.iter().filter(|&&b| b).count(), w);
    }
}

#[test]
fn all_six_drop_e_and_layout_is_exact() {
    let e = encode(subset(0b111111, 0b111111));
    assert_eq!(e.dropped, 1 << Signal::E as u8);
    assert_eq!(e.sent.active, 0b011111);
    // X 1..3, Y 5..8, R 10..14, T 16..21, Z 23..29 (µs, end exclusive).
    let mut want = [false; FRAME_US];
    for (a, b) in [(1, 3), (5, 8), (10, 14), (16, 21), (23, 29)] {
        want[a..b].fill(true);
    }
    assert_eq!(e.lines.step, want);
    // All forward: direction high from 0 to 30 (gaps bridged).
    let mut dir = [false; FRAME_US];
    dir[0..30].fill(true);
    assert_eq!(e.lines.dir, dir);
    // Everything within the 32 µs window.
    assert!(e.lines.step[WINDOW_US..].iter().all(|&b| !b));
}

#[test]
fn direction_brackets_forward_pulses_only() {
    // Y forward, R reverse: Y at 1..4, dir 0..5; R at 6..10, dir low.
    let e = encode(subset(0b110, 0b010));
    let mut dir = [false; FRAME_US];
    dir[0..5].fill(true);
    assert_eq!(e.lines.dir, dir);
    let edges = edges(&e.lines);
    let times: Vec<(f64, Line, bool)> = edges.iter().map(|e| (e.t_us, e.line, e.rising)).collect();
    assert_eq!(
        times,
        vec![
            (0.0, Line::Dir, true),
            (1.0, Line::Step, true),
            (4.0, Line::Step, false),
            (5.0, Line::Dir, false),
            (6.0, Line::Step, true),
            (10.0, Line::Step, false),
        ]
    );
}

#[test]
fn round_trip_all_subsets_and_directions() {
    for mask in 0u8..64 {
        for fwd in [0u8, 0b111111, 0b010101, 0b101010, mask ^ 0b110011] {
            let s = subset(mask, fwd);
            let e = encode(s);
            let fit = expected_fit(mask);
            assert_eq!(e.dropped, mask & !fit, "mask {mask:06b}");
            assert_eq!(e.sent, s.masked(fit));
            let d = decode(&e.lines);
            assert_eq!(d, s.masked(fit), "mask {mask:06b} fwd {fwd:06b}");
            // From edges, with up to ±0.3 µs jitter on every edge.
            let mut jittered: Vec<Edge> = edges(&e.lines).to_vec();
            for (i, ed) in jittered.iter_mut().enumerate() {
                ed.t_us += [0.3, -0.3, 0.1, -0.2, 0.0][i % 5]
                    * if ed.line == Line::Step { 0.5 } else { 1.0 };
            }
            jittered.sort_by(|a, b| a.t_us.partial_cmp(&b.t_us).unwrap());
            assert_eq!(decode_edges(&jittered), s.masked(fit));
        }
    }
}

#[test]
fn up_to_four_wide_signals_fit() {
    // The four widest codes fit; R..E end at 29.
    let e = encode(subset(0b111100, 0));
    assert_eq!(e.dropped, 0);
    // Y..E: E would end at 33.
    let e = encode(subset(0b111110, 0));
    assert_eq!(e.dropped, 0b100000);
}

#[test]
fn chain_encoder_lines_decoder_encoder() {
    // Module A encodes, module B decodes and re-encodes: identical lines.
    for mask in 0u8..64 {
        let s = subset(mask, mask.rotate_left(3));
        let a = encode(s);
        let received = decode(&a.lines);
        let b = encode(received);
        assert_eq!(b.lines, a.lines);
        assert_eq!(b.dropped, 0);
        assert_eq!(decode(&b.lines), received);
    }
}
