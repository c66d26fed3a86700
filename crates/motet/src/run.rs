//! `motet run` and `motet check`.

use crate::modules::{BUS, MODULES};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use motet_api::{job_name, scan_job, JobOptions, JobReader, Placed};
use motet_host::Machine;
use motet_render::{PngCanvas, RenderSpec, SvgWriter};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

pub fn load_machine(path: &Path) -> Result<Machine> {
    Ok(Machine::load(path)?)
}

pub fn check(machine: &Path, job_path: Option<&Path>, opts: &JobOptions, bus: bool) -> Result<()> {
    let m = load_machine(machine)?;
    println!(
        "{}: ok ({}, {} axes, {} actuators, {} nodes)",
        machine.display(),
        m.name,
        m.axes.len(),
        m.actuators.len(),
        m.nodes.len()
    );
    let composed = crate::modules::check_machine(&m, true)?;
    if bus && composed.is_none() {
        anyhow::bail!(
            "--nodes paired checks the modules of a machine composed from them; {} has no [modules]",
            machine.display()
        );
    }
    let mut needs = None;
    if let Some(j) = job_path {
        let scan = scan_job(JobReader::open(&m, j, opts)?, &mut |_, _| {})?;
        for w in &scan.warnings {
            eprintln!("warning: {w}");
        }
        println!(
            "{}: ok ({} commands, {} of motion planned)",
            j.display(),
            scan.commands,
            motet_sim::format_duration(scan.planned_s)
        );
        if let Some(p) = &scan.placed {
            println!("  {}", placed_line(p));
        }
        if scan.clamps.moves > 0 {
            println!(
                "  {} move(s) clamped onto the travel, by {} mm at most (less than half a step)",
                scan.clamps.moves,
                motet_planner::ranges::number(scan.clamps.max_mm)
            );
        }
        if let Some(c) = &composed {
            crate::modules::check_fit(c, &scan.needs, j, MODULES)?;
            println!("  fits the machine its modules make");
        }
        needs = Some((j, scan.needs));
    }
    if bus {
        let (check, _) = crate::modules::scan_the_bus(&m, machine)?;
        if let (Some((j, needs)), Ok(())) = (&needs, &check.viability) {
            crate::modules::check_fit(&check.now, needs, j, BUS)?;
            println!("  the job fits the machine the modules on the bus make");
        }
        crate::modules::require_same(&check, machine)?;
    }
    Ok(())
}

/// Where the drawing went: `placed at x 10..290, y 52.5..247.5 mm (scale
/// 17.5, rotated 0°)`, and what was put back on the travel.
fn placed_line(p: &Placed) -> String {
    let n = motet_planner::ranges::rounded;
    let mut line = format!(
        "placed at x {}..{}, y {}..{} mm (scale {}, rotated {}°)",
        n(p.min[0]),
        n(p.max[0]),
        n(p.min[1]),
        n(p.max[1]),
        n(p.scale),
        n(p.rotate_deg)
    );
    if p.clamps.moves > 0 {
        line += &format!(
            "; {} move(s) put on the travel's edge, {} mm beyond it at most",
            p.clamps.moves,
            n(p.clamps.max_mm)
        );
    }
    line
}

/// `report.json`: the run's report, and where the drawing was placed when
/// it was (without placement, the report alone, as it always was).
#[derive(serde::Serialize)]
struct ReportJson<'a> {
    #[serde(flatten)]
    report: &'a motet_sim::Report,
    #[serde(skip_serializing_if = "Option::is_none")]
    placement: Option<serde_json::Value>,
}

/// The report's `placement` entry: what [`placed_line`] says, for programs.
fn placed_json(p: &Placed) -> serde_json::Value {
    serde_json::json!({
        "scale": p.scale,
        "rotate_deg": p.rotate_deg,
        "min_mm": p.min,
        "max_mm": p.max,
        "clamped_moves": p.clamps.moves,
        "max_clamp_mm": p.clamps.max_mm,
    })
}

/// A progress bar on a terminal, hidden otherwise.
fn bar(quiet: bool, len: u64, template: &str) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(len);
    b.set_style(
        ProgressStyle::with_template(template)
            .expect("static template")
            .progress_chars("=> "),
    );
    b
}

/// Runs a job on the simulated machine. The job is read twice and never
/// held: first through to its end, checked and planned (every error found
/// before anything moves), then again as it runs, each stroke of the executed
/// path drawn into the renders as it ends. Memory stays the same however
/// long the job is (ARCHITECTURE.md, "Constant memory").
pub fn run(
    machine_path: &Path,
    job_path: &Path,
    out: Option<PathBuf>,
    opts: &JobOptions,
    quiet: bool,
    heater_faults: &[(String, motet_host::heater_loop::HeaterFault)],
) -> Result<()> {
    let mut machine = load_machine(machine_path)?;
    crate::heaters::inject(&mut machine, heater_faults)?;
    let scan_bar = bar(
        quiet,
        0,
        "{spinner} checking [{bar:40}] {bytes}/{total_bytes} ({eta})",
    );
    let scan = scan_job(
        JobReader::open(&machine, job_path, opts)?,
        &mut |done, size| {
            scan_bar.set_length(size);
            scan_bar.set_position(done);
        },
    )?;
    scan_bar.finish_and_clear();
    if !quiet {
        for w in &scan.warnings {
            eprintln!("warning: {w}");
        }
    }
    // A machine composed from modules runs only what fits it.
    if let Some(c) = crate::modules::check_machine(&machine, false)? {
        crate::modules::check_fit(&c, &scan.needs, job_path, MODULES)?;
    }
    let name = job_name(job_path);
    let out = out.unwrap_or_else(|| PathBuf::from("out").join(&name));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;

    let (x, y) = (
        machine.axis("x").unwrap_or(0),
        machine.axis("y").unwrap_or(0),
    );
    let mut bounds = [
        [machine.axes[x].travel[0], machine.axes[y].travel[0]],
        [machine.axes[x].travel[1], machine.axes[y].travel[1]],
    ];
    if !bounds.iter().flatten().all(|v| v.is_finite()) {
        bounds = [[-100.0, -100.0], [100.0, 100.0]];
    }
    let spec = RenderSpec::new(bounds, format!("{} on {}", name, machine.name));
    let mut png = PngCanvas::new(&spec).context("rendering the tool path")?;
    let svg_path = out.join("path.svg");
    let svg_file = std::fs::File::create(&svg_path)
        .with_context(|| format!("cannot create {}", svg_path.display()))?;
    let mut svg = SvgWriter::new(std::io::BufWriter::new(svg_file), &spec)
        .context("rendering the tool path")?;
    let mut svg_error = None;

    let run_bar = bar(
        quiet,
        scan.commands as u64,
        "{spinner} simulating [{bar:40}] {pos}/{len} commands ({eta})",
    );
    let mut progress = |done: usize, _total: usize| run_bar.set_position(done as u64);
    let run = motet_sim::simulate_stream(
        &machine,
        &name,
        JobReader::open(&machine, job_path, opts)?,
        scan.commands,
        &mut progress,
        &mut |stroke| {
            png.draw(&stroke);
            if svg_error.is_none() {
                svg_error = svg.stroke(&stroke).err();
            }
        },
    )
    .map_err(|e| crate::heaters::sim_error(&machine, job_path, &out, e))?;
    run_bar.finish_and_clear();
    if let Some(e) = svg_error {
        return Err(e).with_context(|| format!("writing {}", svg_path.display()));
    }
    svg.finish()
        .with_context(|| format!("writing {}", svg_path.display()))?;
    let mut report = run.report;
    crate::heaters::plot_into(&machine, &run.heaters, &out, &mut report)?;
    report.clamped_moves = scan.clamps.moves;
    report.max_clamp_mm = scan.clamps.max_mm;
    report.plots =
        motet_sim::plots::write_plots(&machine, &run.loops.store, &run.loops.planned, 0.0, &out)?;

    std::fs::write(
        out.join("path.png"),
        png.encode().context("rendering the tool path")?,
    )?;
    let json = ReportJson {
        report: &report,
        placement: scan.placed.as_ref().map(placed_json),
    };
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    if !quiet {
        println!("{}", report.summary());
        if let Some(p) = &scan.placed {
            println!("  {}", placed_line(p));
        }
        if let Some(peak) = crate::peak::own_peak_mib() {
            println!("  {}{peak:.1} MiB", crate::peak::PEAK_LINE);
        }
        let mut files = vec!["path.png".to_string(), "path.svg".into()];
        files.extend(report.plots.iter().cloned());
        files.extend(crate::heaters::plot_names(&report));
        files.push("report.json".into());
        println!("  wrote {}/{{{}}}", out.display(), files.join(", "));
    }
    Ok(())
}
