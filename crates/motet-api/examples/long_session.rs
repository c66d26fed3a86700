//! A long scripted session on the pen plotter, for measuring what a session
//! costs as it grows: `MOVES` short moves along a slowly turning spiral, the
//! pen lifted and lowered every 25 moves, saved halfway and at the end.
//!
//! ```text
//! cargo run --release -p motet-api --example long_session -- MOVES OUT_DIR
//! /usr/bin/time -f %M target/release/examples/long_session 200000 out/long
//! ```

use motet_api::{ApiError, Machine};
use std::path::PathBuf;

fn main() -> Result<(), ApiError> {
    let mut args = std::env::args().skip(1);
    let moves: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(200_000);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "out/long-session".into()));
    let machine = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/plotter.toml");
    let mut m = Machine::open(machine)?;
    std::fs::create_dir_all(&out).map_err(|error| ApiError::Io {
        path: out.display().to_string(),
        error,
    })?;
    for k in 0..moves {
        if k.is_multiple_of(25) {
            m.set_tool("pen", if (k / 25).is_multiple_of(2) { 1.0 } else { 0.0 })?;
        }
        // A spiral over the bed, 0.5 mm a move.
        let a = k as f64 * 0.05;
        let r = 20.0 + 80.0 * ((k as f64 * 1e-4).sin() * 0.5 + 0.5);
        m.move_to(
            &[("x", 150.0 + r * a.cos()), ("y", 109.0 + r * a.sin())],
            Some(100.0),
        )?;
        if k == moves / 2 {
            m.save(out.join("half"))?;
        }
    }
    m.wait()?;
    m.save(out.join("end"))?;
    let r = m.report();
    println!(
        "{moves} moves, {:.0} mm drawn in {:.0} s simulated; wrote {}",
        r.tool_on_distance_mm,
        r.duration_s,
        out.display()
    );
    Ok(())
}
