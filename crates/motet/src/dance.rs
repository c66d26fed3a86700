//! `motet dance`: a graph file run on a simulated node, driven by a CSV trace
//! or two pendulums, rendered through a machine file.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use motet_graph::GraphFile;
use motet_render::{render_png, render_svg, RenderSpec};
use motet_sim::dance::{run_dance, CsvTrace, InputSource, Pendulums};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

pub struct DanceArgs<'a> {
    pub machine: &'a Path,
    pub graph: &'a Path,
    pub inputs: Option<&'a Path>,
    pub pendulums: bool,
    pub seconds: Option<f64>,
    pub out: Option<PathBuf>,
    pub quiet: bool,
}

pub fn dance(a: DanceArgs) -> Result<()> {
    let machine = crate::run::load_machine(a.machine)?;
    let graph = GraphFile::load(a.graph)?;
    let mut trace;
    let mut pend;
    let (source, default_s): (&mut dyn InputSource, f64) = match (a.inputs, a.pendulums) {
        (Some(_), true) => anyhow::bail!("give --inputs or --pendulums, not both"),
        (Some(p), false) => {
            trace = CsvTrace::load(p, &graph)?;
            let end = trace.end();
            (&mut trace, end)
        }
        (None, true) => {
            pend = Pendulums::from_graph(&graph)?;
            (&mut pend, 30.0)
        }
        (None, false) => anyhow::bail!("give the inputs: --inputs TRACE.csv or --pendulums"),
    };
    let seconds = a.seconds.unwrap_or(default_s);
    if !(seconds.is_finite() && seconds > 0.0) {
        anyhow::bail!("--seconds must be positive");
    }
    let name = a
        .graph
        .file_stem()
        .map_or("dance".to_string(), |s| s.to_string_lossy().into_owned());
    let out = a.out.unwrap_or_else(|| PathBuf::from("out").join(&name));
    let bar = if a.quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(1000);
        b.set_style(
            ProgressStyle::with_template("{spinner} dancing [{bar:40}] {percent}% ({eta})")
                .expect("static template")
                .progress_chars("=> "),
        );
        b
    };
    let mut progress = |f: f64| bar.set_position((f * 1000.0) as u64);
    let result = run_dance(&machine, &graph, source, seconds, &mut progress)?;
    bar.finish_and_clear();

    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    // Bounds: the drawing's own, with a margin.
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for s in &result.strokes {
        for p in &s.points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    if !(lo[0].is_finite() && lo[1].is_finite()) {
        lo = [-1.0, -1.0];
        hi = [1.0, 1.0];
    }
    let m = ((hi[0] - lo[0]).max(hi[1] - lo[1]) * 0.05).max(1.0);
    let bounds = [[lo[0] - m, lo[1] - m], [hi[0] + m, hi[1] + m]];
    let spec = RenderSpec::new(bounds, format!("{} on {}", name, machine.name));
    let png = render_png(&result.strokes, &spec).context("rendering the path")?;
    std::fs::write(out.join("path.png"), png)?;
    std::fs::write(out.join("path.svg"), render_svg(&result.strokes, &spec))?;
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(&result.report)? + "\n",
    )?;
    if !a.quiet {
        println!("{}", result.report.summary());
        println!(
            "  wrote {}/{{path.png, path.svg, report.json}}",
            out.display()
        );
    }
    Ok(())
}
