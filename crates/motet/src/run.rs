//! `motet run` and `motet check`.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use motet_api::{job_name, load_job, JobOptions};
use motet_host::Machine;
use motet_render::{render_png, render_svg, RenderSpec};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

pub fn load_machine(path: &Path) -> Result<Machine> {
    Ok(Machine::load(path)?)
}

pub fn check(machine: &Path, job_path: Option<&Path>, allow_unknown: bool) -> Result<()> {
    let m = load_machine(machine)?;
    println!(
        "{}: ok ({}, {} axes, {} actuators, {} nodes)",
        machine.display(),
        m.name,
        m.axes.len(),
        m.actuators.len(),
        m.nodes.len()
    );
    if let Some(j) = job_path {
        let loaded = load_job(&m, j, &JobOptions { allow_unknown })?;
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
        println!(
            "{}: ok ({} commands, {} of motion planned)",
            j.display(),
            loaded.commands.len(),
            motet_sim::format_duration(loaded.planned_s.unwrap_or(0.0))
        );
        if loaded.clamps.moves > 0 {
            println!(
                "  {} move(s) clamped onto the travel, by {} mm at most (less than half a step)",
                loaded.clamps.moves,
                motet_planner::ranges::number(loaded.clamps.max_mm)
            );
        }
    }
    Ok(())
}

pub fn run(
    machine_path: &Path,
    job_path: &Path,
    out: Option<PathBuf>,
    allow_unknown: bool,
    quiet: bool,
) -> Result<()> {
    let machine = load_machine(machine_path)?;
    let loaded = load_job(&machine, job_path, &JobOptions { allow_unknown })?;
    if !quiet {
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
    }
    let name = job_name(job_path);
    let out = out.unwrap_or_else(|| PathBuf::from("out").join(&name));

    let bar = if quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(loaded.commands.len() as u64);
        b.set_style(
            ProgressStyle::with_template(
                "{spinner} simulating [{bar:40}] {pos}/{len} commands ({eta})",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        b
    };
    let mut progress = |done: usize, _total: usize| bar.set_position(done as u64);
    let mut result = motet_sim::simulate(&machine, &name, &loaded.commands, &mut progress)
        .map_err(|e| anyhow::anyhow!("{}:{e}", job_path.display()))?;
    bar.finish_and_clear();
    result.report.clamped_moves = loaded.clamps.moves;
    result.report.max_clamp_mm = loaded.clamps.max_mm;

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
    let png = render_png(&result.strokes, &spec).context("rendering the tool path")?;
    std::fs::write(out.join("path.png"), png)?;
    std::fs::write(out.join("path.svg"), render_svg(&result.strokes, &spec))?;
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(&result.report)? + "\n",
    )?;
    if !quiet {
        println!("{}", result.report.summary());
        println!(
            "  wrote {}/{{path.png, path.svg, report.json}}",
            out.display()
        );
    }
    Ok(())
}
