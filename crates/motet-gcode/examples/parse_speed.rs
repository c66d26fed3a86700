//! Parse speed on a real slicer file:
//! `cargo run --release -p motet-gcode --example parse_speed [FILE.gcode.gz]`
//! (default: the PrusaSlicer benchmark file). Prints MB/s of G-code text:
//! best wall-clock run, and mean CPU time per run (from /proc/self/stat, so
//! other processes on a busy machine do not count).

use std::io::Read;
use std::time::Instant;

use motet_gcode::{parse, GcodeOptions};
use motet_planner::{AxisInfo, JobTarget};

fn main() {
    let path = std::env::args().nth(1).unwrap_or_else(|| {
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../bench/data/prusaslicer-twisted-vase.gcode.gz"
        )
        .into()
    });
    let gz = std::fs::read(&path).expect("read the file");
    let mut text = String::new();
    flate2::read::GzDecoder::new(&gz[..])
        .read_to_string(&mut text)
        .expect("gunzip");
    let axis = |n: &str, path| AxisInfo {
        name: n.into(),
        travel: [-1000.0, 1000.0],
        path,
    };
    let target = JobTarget {
        axes: vec![
            axis("x", true),
            axis("y", true),
            axis("z", true),
            axis("e", false),
        ],
        tools: vec![],
        start: [0.0; 6],
        tolerance: 0.01,
        draw_feed: 10.0,
    };
    let opts = GcodeOptions::default();
    let mut best = f64::INFINITY;
    let mut n = 0;
    let cpu0 = cpu_seconds();
    for _ in 0..20 {
        let t = Instant::now();
        let p = parse(&text, &target, &opts).expect("parse");
        best = best.min(t.elapsed().as_secs_f64());
        n = p.commands.len();
    }
    let cpu = cpu_seconds().map(|c| (c - cpu0.unwrap_or(0.0)) / 20.0);
    let mb = text.len() as f64 / 1e6;
    print!(
        "{path}: {mb:.2} MB, {n} commands, best of 20: {:.1} ms = {:.0} MB/s",
        best * 1e3,
        mb / best
    );
    match cpu {
        Some(c) if c > 0.0 => println!("; CPU time per run {:.1} ms = {:.0} MB/s", c * 1e3, mb / c),
        _ => println!(),
    }
}

/// User + system CPU time of this process, seconds (Linux; 10 ms ticks).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}
