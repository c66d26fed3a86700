//! What `motet run --nodes` writes and prints of a networked run besides
//! its outcome: the loops' plots, and `net.json`'s per-source, per-heater
//! and per-node figures.

use anyhow::{Context, Result};
use motet_host::Machine;
use motet_net::run::NetRun;
use std::path::Path;

/// The loops' plots as an in-process run writes them, from the samples the
/// nodes sent (a stopped run's too: they show what led to it); their files.
pub fn write_loop_plots(machine: &Machine, run: &NetRun, out: &Path) -> Result<Vec<String>> {
    let t0 = run.trajectory_start().unwrap_or(0.0);
    let mut plots =
        motet_sim::plots::write_plots(machine, run.samples(), run.sensor_plan(), t0, out)
            .context("writing the loops' plots")?;
    let traces: Vec<_> = run.heater_traces().cloned().collect();
    for (_, file) in crate::heaters::write_plots(machine, &traces, out)? {
        plots.push(file);
    }
    Ok(plots)
}

/// `net.json`'s `loops`: per servo, the following error's least and most
/// (counts), its measured position's range and last value; per sensor,
/// its readings'.
pub fn loops_json(machine: &Machine, run: &NetRun) -> Vec<serde_json::Value> {
    let range = |s: &motet_host::samples::Series,
                 f: fn(&motet_host::samples::SamplePoint) -> (f64, f64)| {
        s.all_points()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                let (lo, hi) = f(p);
                (a.min(lo), b.max(hi))
            })
    };
    run.samples()
        .series
        .iter()
        .map(|s| {
            let (lo, hi) = range(s, |p| (p.lo, p.hi));
            let (low, high) = range(s, |p| (p.value, p.value));
            let last = s.all_points().last().map(|p| p.value);
            serde_json::json!({ "name": s.name, "node": machine.nodes[s.node].name, "points": s.all_points().count(), "least": lo, "most": hi, "low": low, "high": high, "last": last })
        })
        .collect()
}

/// `net.json`'s `heaters`: per heater a node drives, its samples' count,
/// its first and highest reading, its highest target and power (°C, 0-1).
pub fn heaters_json(run: &NetRun) -> Vec<serde_json::Value> {
    run.heater_traces()
        .map(|t| {
            let pts = t.points();
            let most = |f: fn(&motet_host::heater_trace::TracePoint) -> f64| {
                pts.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
            };
            serde_json::json!({
                "name": t.name,
                "points": pts.len(),
                "first_c": pts.first().map(|p| p.reading),
                "highest_c": most(|p| p.reading),
                "highest_target_c": most(|p| p.target),
                "highest_power": most(|p| p.power),
            })
        })
        .collect()
}

/// `net.json`'s `nodes`: each node's link and clock figures, where it
/// rests and what it counted.
pub fn nodes_json(
    run: &NetRun,
    figures: &[motet_net::run::PeerFigures],
    tallies: &[Option<motet_net::run::Tally>],
) -> Vec<serde_json::Value> {
    figures
        .iter()
        .enumerate()
        .map(|(k, f)| {
            serde_json::json!({
                "name": f.name,
                "rtt_us": f.rtt_us,
                "retransmits": f.retransmits,
                "crc_errors": f.crc_errors,
                "bytes_out": f.bytes_out,
                "bytes_in": f.bytes_in,
                "frames_out": f.frames_out,
                "frames_in": f.frames_in,
                "sync_error_us": f.sync_error_us,
                "skew_ppm": f.skew_ppm,
                "underruns": f.underruns,
                "window": window(run.node_status(k)),
                "tally": tallies[k].map(|t| serde_json::json!({
                    "steps": t.steps,
                    "tool_changes": t.tool_changes,
                    "hash": format!("{:016x}", t.hash),
                })),
            })
        })
        .collect()
}

/// Each node's link and clock figures, a line each.
pub fn print_figures(figures: &[motet_net::run::PeerFigures]) {
    for f in figures {
        println!(
            "  node {}: rtt {:.2} ms, {} retransmits, {} CRC errors, {} B out / {} B in, clock ±{:.1} µs ({:+.1} ppm)",
            f.name,
            f.rtt_us as f64 / 1000.0,
            f.retransmits,
            f.crc_errors,
            f.bytes_out,
            f.bytes_in,
            f.sync_error_us,
            f.skew_ppm
        );
    }
}

/// The node's committed window end and whether it stopped on its tail.
fn window(m: Option<&motet_wire::NodeMessage>) -> serde_json::Value {
    match m {
        Some(motet_wire::NodeMessage::Status {
            committed, stopped, ..
        }) => {
            serde_json::json!({ "committed": committed, "stopped": stopped })
        }
        _ => serde_json::Value::Null,
    }
}
