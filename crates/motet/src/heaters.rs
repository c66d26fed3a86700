//! `motet run`'s heaters: faults injected from `--heater-fault`, and each
//! node-driven heater's plot, `heater-NAME.png`, beside `path.png`.

use anyhow::{Context, Result};
use motet_host::heater_loop::{HeaterFault, HeaterFaultKind};
use motet_host::heater_trace::HeaterTrace;
use motet_host::Machine;
use std::path::Path;

/// `--heater-fault NAME=KIND@SECONDS`: a fault for the simulator to
/// inject into a heater a node drives.
pub fn parse_fault(s: &str) -> Result<(String, HeaterFault), String> {
    let (name, rest) = s
        .split_once('=')
        .ok_or("expected NAME=KIND@SECONDS, e.g. hotend=disconnected@60")?;
    let (kind, at) = rest.split_once('@').unwrap_or((rest, "0"));
    let kind = HeaterFaultKind::parse(kind).ok_or_else(|| {
        format!(
            "unknown fault `{kind}`; expected {}",
            HeaterFaultKind::NAMES
        )
    })?;
    let at_s: f64 = at
        .parse()
        .map_err(|_| format!("`{at}` is not a number of seconds"))?;
    let at_s = motet_planner::ranges::JOB_S
        .check("--heater-fault time", at_s)
        .map_err(|e| e.to_string())?;
    Ok((name.to_string(), HeaterFault { kind, at_s }))
}

/// The faults of `--heater-fault` put on `machine`'s heaters, each of
/// which a node must drive.
pub fn inject(machine: &mut Machine, faults: &[(String, HeaterFault)]) -> Result<()> {
    for (name, fault) in faults {
        let Some(h) = machine.heaters.iter_mut().find(|h| h.name == *name) else {
            anyhow::bail!("--heater-fault: the machine has no heater `{name}`");
        };
        let Some(l) = h.node_loop.as_mut() else {
            anyhow::bail!("--heater-fault: no node drives heater `{name}` ([nodes.NAME] heaters)");
        };
        l.fault = Some(*fault);
    }
    Ok(())
}

/// Writes each heater's plot into `out`; the file names, by heater.
pub fn write_plots(
    machine: &Machine,
    traces: &[HeaterTrace],
    out: &Path,
) -> Result<Vec<(String, String)>> {
    let mut written = vec![];
    for t in traces {
        let file = format!("heater-{}.png", t.name);
        let plot = motet_sim::heaters::heater_plot(machine, t);
        let png =
            motet_render::plot::plot_png(&plot).with_context(|| format!("rendering {file}"))?;
        let path = out.join(&file);
        std::fs::write(&path, png).with_context(|| format!("writing {}", path.display()))?;
        written.push((t.name.clone(), file));
    }
    Ok(written)
}

/// The plots written into `out` for the report (each heater's `plot`).
pub fn plot_into(
    machine: &Machine,
    traces: &[HeaterTrace],
    out: &Path,
    report: &mut motet_sim::Report,
) -> Result<()> {
    for (name, file) in write_plots(machine, traces, out)? {
        if let Some(h) = report.heaters.iter_mut().find(|h| h.name == name) {
            h.plot = Some(file);
        }
    }
    Ok(())
}

/// The heaters' plots (`heater-hotend.png`, …), for the summary's last
/// line.
pub fn plot_names(report: &motet_sim::Report) -> impl Iterator<Item = String> + '_ {
    report.heaters.iter().filter_map(|h| h.plot.clone())
}

/// A simulation's error as `motet run` says it: the job's own errors name
/// their file, a loop's fault its node; a heater that stopped the run gets its plots written, to
/// show what it saw; others are located in the job.
pub fn sim_error(
    machine: &Machine,
    job: &Path,
    out: &Path,
    e: motet_sim::SimError,
) -> anyhow::Error {
    match e {
        motet_sim::SimError::Source(e) => anyhow::anyhow!("{e}"),
        // A loop's fault names its node and actuator.
        motet_sim::SimError::Fault(e) => anyhow::anyhow!("{e}"),
        motet_sim::SimError::Heater { message, heaters } => {
            match write_plots(machine, &heaters, out) {
                Ok(files) => {
                    let names: Vec<String> = files.into_iter().map(|f| f.1).collect();
                    anyhow::anyhow!(
                        "{message}; the run was stopped (plots in {}: {})",
                        out.display(),
                        names.join(", ")
                    )
                }
                Err(e) => anyhow::anyhow!("{message}; the run was stopped ({e})"),
            }
        }
        e => anyhow::anyhow!("{}:{e}", job.display()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_parse_or_say_why_not() {
        let f = parse_fault("hotend=disconnected@60").unwrap();
        assert_eq!(f.0, "hotend");
        assert_eq!((f.1.kind, f.1.at_s), (HeaterFaultKind::Disconnected, 60.0));
        assert_eq!(parse_fault("bed=sensor-lost").unwrap().1.at_s, 0.0);
        for (bad, words) in [
            ("hotend", "expected NAME=KIND@SECONDS"),
            ("hotend=melted@3", "unknown fault `melted`"),
            ("hotend=disconnected@soon", "not a number"),
            ("hotend=disconnected@-1", "must be from 0"),
        ] {
            let e = parse_fault(bad).unwrap_err();
            assert!(e.contains(words), "{bad}: {e}");
        }
    }
}
