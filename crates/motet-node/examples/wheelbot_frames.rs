//! Frame cost of the Wheelbot graph (the one in `tests/graph_wheelbot.rs`),
//! and the long exactness run of `tests/graph_latency.rs`.
//!
//! ```text
//! cargo run --release -p motet-node --example wheelbot_frames [FRAMES] [--ipf N] [--minutes M]
//! ```
//!
//! * `FRAMES` (default 1,000,000): Wheelbot frames with scripted inputs (pedal
//!   swinging, radius encoder turning, stretch knob changed now and then);
//!   prints ns/frame.
//! * `--ipf N`: instructions per frame, as measured with callgrind (see
//!   `bench/README.md`); default [`MEASURED_IPF`]. Gives the frame rate a
//!   600 MHz Cortex-M7 would sustain with 50 % headroom, assuming it executes
//!   about as many instructions per frame as x86-64 does (both have a
//!   double-precision FPU; sin/cos are software `libm` on both) at
//!   [`M7_IPC`] instructions per cycle.
//! * `--minutes M`: then runs the mixed-input exactness graph for M simulated
//!   minutes at 25 kHz and prints the largest |position − exact sum| per
//!   channel.

use heapless::Deque;
use motet_node::graph::*;
use motet_trajectory::Segment;

use std::time::Instant;

#[path = "../tests/graph_latency.rs"]
#[allow(dead_code)]
mod latency;

/// Instructions per Wheelbot frame measured with callgrind (x86-64, release),
/// see `bench/README.md`.
const MEASURED_IPF: f64 = 1975.0;
/// Assumed Cortex-M7 instructions per cycle (dual issue; 1.0 is conservative
/// for f64-heavy code with branches).
const M7_IPC: f64 = 1.0;
const M7_HZ: f64 = 600e6;
/// Fraction of the M7 the graph may use.
const BUDGET: f64 = 0.5;

#[path = "../tests/graph_wheelbot.rs"]
#[allow(dead_code)]
mod wheelbot_graph;
use wheelbot_graph::wheelbot;

fn usage() -> ! {
    eprintln!("usage: wheelbot_frames [FRAMES] [--ipf INSTRUCTIONS] [--minutes M]");
    std::process::exit(2)
}

fn number(s: Option<String>) -> f64 {
    s.and_then(|s| s.replace('_', "").parse().ok())
        .filter(|x: &f64| x.is_finite() && *x >= 0.0)
        .unwrap_or_else(|| usage())
}

fn main() {
    let mut frames: u64 = 1_000_000;
    let mut ipf = MEASURED_IPF;
    let mut minutes = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--ipf" => ipf = number(args.next()),
            "--minutes" => minutes = Some(number(args.next())),
            "-h" | "--help" => usage(),
            _ => frames = number(Some(a)) as u64,
        }
    }

    let mut w = wheelbot();
    w.g.reset_deep(port(w.enc_r, 0), 50.0).unwrap();
    let mut inputs = Inputs::default();
    let segs: Deque<Segment, 4> = Deque::new();
    let mut out = FrameOut::default();
    let mut steps = [0i64; 24];
    let mut t = 0.0;
    let start = Instant::now();
    for i in 0..frames {
        // Scripted: the pedal swings every 2 s between raw 300 and 1000,
        // the radius encoder turns one count every 10 frames, the stretch
        // knob changes every 4 s.
        let swing = ((i / 50_000) % 2) as f32;
        inputs.analog[0] = 300.0 + 700.0 * swing;
        inputs.encoders[0] = (i / 10) as i64;
        if i % 100_000 == 0 {
            let r = 0.1 * ((i / 100_000) % 3) as f64;
            w.g.set_param(w.x_stretch, ScalingFilter1D::RATIO, r)
                .unwrap();
        }
        let mut none = [];
        let mut tape = Tape::new(&mut none);
        w.g.frame(t, &inputs, &segs, &mut out, &mut tape);
        t += 40.0;
        if (i + 1) % 25 == 0 {
            w.g.slow_frame(&inputs);
        }
        for s in &out.steps {
            steps[s.channel as usize] += if s.forward { 1 } else { -1 };
        }
    }
    let el = start.elapsed();
    std::hint::black_box(&w.g);
    let ns = el.as_nanos() as f64 / frames.max(1) as f64;
    println!(
        "wheelbot: {frames} frames in {:.3} s: {ns:.1} ns/frame ({:.2} MHz frame rate on this host)",
        el.as_secs_f64(),
        1e3 / ns
    );
    println!(
        "  steps: a {}, b {}, z {}, e {}",
        steps[w.ch[0] as usize],
        steps[w.ch[1] as usize],
        steps[w.ch[2] as usize],
        steps[w.ch[3] as usize]
    );
    if ipf > 0.0 {
        let cycles = ipf / M7_IPC;
        let rate = M7_HZ * BUDGET / cycles;
        println!(
            "  Cortex-M7 @ 600 MHz: {ipf:.0} instructions/frame at {M7_IPC} instruction/cycle = \
             {:.2} µs/frame; with 50 % headroom up to {:.0} kHz ({:.0} % of the CPU at 25 kHz)",
            cycles / M7_HZ * 1e6,
            rate / 1e3,
            cycles * 25e3 / M7_HZ * 100.0
        );
    } else {
        println!("  (give --ipf N, instructions/frame from callgrind, for the Cortex-M7 estimate)");
    }

    if let Some(m) = minutes {
        let n = (m * 60.0 * 25_000.0).round() as u64;
        let mut x = latency::Mixed::new();
        let start = Instant::now();
        x.run(n);
        println!(
            "exactness: {n} frames ({m} min at 25 kHz) of mixed inputs in {:.2} s",
            start.elapsed().as_secs_f64()
        );
        for k in 0..3 {
            println!(
                "  channel {}: position {:.0}, exact {:.3}; max |position − exact sum| {:.6} steps \
                 (|position − target| {:.6}, |target − exact| {:.2e})",
                latency::Mixed::CHANNELS[k],
                x.rig.position(x.ch[k]),
                x.exact()[k],
                x.max_error[k],
                x.max_lag[k],
                x.max_drift[k]
            );
        }
        x.check();
        println!("  all within half a step");
    }
}
