//! `motet dance`: a graph file run on a simulated node, driven by a CSV trace
//! or two pendulums, rendered through a machine file; optionally with a job
//! (G-code or SVG) planned alongside for the graph's trajectory readers.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use motet_api::{load_job, JobOptions};
use motet_graph::GraphFile;
use motet_host::Machine;
use motet_render::{render_png, render_svg, RenderSpec, Stroke};
use motet_sim::dance::live::{input_names, Clock, LiveSource};
use motet_sim::dance::{
    run_dance_with, CsvTrace, DanceOptions, DanceResult, InputSource, Pendulums, PlannedJob,
    Recording,
};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

pub struct DanceArgs<'a> {
    pub machine: &'a Path,
    pub graph: &'a Path,
    pub inputs: Option<&'a Path>,
    pub pendulums: bool,
    /// Live inputs: `-` for stdin, or an address to listen on.
    pub live: Option<&'a str>,
    /// With `live`: replay `t=` stamps as fast as possible instead of pacing
    /// to real time.
    pub stamped: bool,
    /// A job planned on the machine and sent to the node alongside.
    pub job: Option<&'a Path>,
    pub seconds: Option<f64>,
    /// A recording (`PATH` and `PATH.len`) loaded into the node's tape
    /// before the run, for a `player`.
    pub load_recording: Option<&'a Path>,
    /// Where to write the node's tape after the run (`PATH` and `PATH.len`).
    pub save_recording: Option<&'a Path>,
    pub out: Option<PathBuf>,
    pub quiet: bool,
}

pub fn dance(a: DanceArgs) -> Result<()> {
    let machine = crate::run::load_machine(a.machine)?;
    let recording = a.load_recording.map(Recording::load).transpose()?;
    let graph = GraphFile::load(a.graph)?;
    let (mut source, default_s) = open_inputs(&a, &graph)?;
    let job = plan_job(&machine, a.job)?;
    let seconds = dance_seconds(a.seconds, default_s, job.as_ref())?;
    let name = a
        .graph
        .file_stem()
        .map_or("dance".to_string(), |s| s.to_string_lossy().into_owned());
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&name));
    let bar = progress_bar(a.quiet);
    let mut progress = |f: f64| bar.set_position((f * 1000.0) as u64);
    let options = DanceOptions {
        job: job.as_ref(),
        recording: recording.as_ref(),
    };
    let result = run_dance_with(
        &machine,
        &graph,
        source.as_mut(),
        options,
        seconds,
        &mut progress,
    )
    .with_context(|| match a.load_recording {
        Some(p) => format!("running {} with {}", a.graph.display(), p.display()),
        None => format!("running {}", a.graph.display()),
    })?;
    bar.finish_and_clear();
    if let Some(p) = a.save_recording {
        result.recording.save(p)?;
    }
    write_outputs(&out, &format!("{} on {}", name, machine.name), &result)?;
    if !a.quiet {
        println!("{}", result.report.summary());
        println!(
            "  wrote {}/{{path.png, path.svg, report.json}}",
            out.display()
        );
        if let Some(p) = a.save_recording {
            println!(
                "  wrote the recording ({} samples) to {} and {}",
                result.recording.len(),
                p.display(),
                Recording::len_path(p).display()
            );
        }
    }
    Ok(())
}

/// The input source the flags ask for (exactly one of `--live`, `--inputs`,
/// `--pendulums`; `--live` wins), and how long a dance it makes by default,
/// s: a trace's length, 30 s of pendulums, a minute live.
fn open_inputs(a: &DanceArgs, graph: &GraphFile) -> Result<(Box<dyn InputSource>, f64)> {
    Ok(match (a.inputs, a.pendulums) {
        _ if a.live.is_some() => {
            let src = a.live.unwrap_or("-");
            let names = input_names(graph);
            let s = if src == "-" {
                LiveSource::stdin(names)
            } else {
                LiveSource::listen(src, names)?
            };
            let live = s.clock(if a.stamped {
                Clock::Stamped
            } else {
                Clock::RealTime
            });
            (Box::new(live), 60.0)
        }
        (Some(_), true) => anyhow::bail!("give --inputs or --pendulums, not both"),
        (Some(p), false) => {
            let trace = CsvTrace::load(p, graph)?;
            let end = trace.end();
            (Box::new(trace), end)
        }
        (None, true) => (Box::new(Pendulums::from_graph(graph)?), 30.0),
        (None, false) => {
            anyhow::bail!("give the inputs: --inputs TRACE.csv, --pendulums or --live")
        }
    })
}

/// The job at `path` (G-code or SVG), planned on `machine`.
fn plan_job(machine: &Machine, path: Option<&Path>) -> Result<Option<PlannedJob>> {
    let Some(p) = path else {
        return Ok(None);
    };
    let loaded = load_job(
        machine,
        p,
        &JobOptions {
            allow_unknown: false,
            ..Default::default()
        },
    )?;
    Ok(Some(
        PlannedJob::plan(machine, &loaded.commands)
            .with_context(|| format!("planning {}", p.display()))?,
    ))
}

/// The dance's length, s: `--seconds`, else `default_s` (and with a job, at
/// least until it ends, and a little after); within the dance's range and
/// positive.
fn dance_seconds(seconds: Option<f64>, default_s: f64, job: Option<&PlannedJob>) -> Result<f64> {
    let default_s = job.map_or(default_s, |j| default_s.max(j.end_us * 1e-6 + 0.5));
    let seconds = seconds.unwrap_or(default_s);
    // Every frame of a graph runs: the length comes from --seconds, or else
    // from the trace or the job, and is held to the same range either way.
    motet_planner::ranges::DANCE_S.check("the dance's length in seconds (--seconds)", seconds)?;
    if seconds <= 0.0 {
        anyhow::bail!("--seconds must be positive");
    }
    Ok(seconds)
}

/// A progress bar on a terminal, unless `quiet`; else a hidden one.
fn progress_bar(quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(1000);
    b.set_style(
        ProgressStyle::with_template("{spinner} dancing [{bar:40}] {percent}% ({eta})")
            .expect("static template")
            .progress_chars("=> "),
    );
    b
}

/// Writes `path.png`, `path.svg` (titled `title`) and `report.json` into
/// `out`, which is created if needed.
fn write_outputs(out: &Path, title: &str, result: &DanceResult) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let spec = RenderSpec::new(drawing_bounds(&result.strokes), title.to_string());
    let png = render_png(&result.strokes, &spec).context("rendering the path")?;
    std::fs::write(out.join("path.png"), png)?;
    std::fs::write(out.join("path.svg"), render_svg(&result.strokes, &spec))?;
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(&result.report)? + "\n",
    )?;
    Ok(())
}

/// The drawing's own bounds with a margin of 5 % of its larger side (at
/// least 1 mm); ±2 mm around the origin for an empty drawing.
fn drawing_bounds(strokes: &[Stroke]) -> [[f64; 2]; 2] {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for s in strokes {
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
    [[lo[0] - m, lo[1] - m], [hi[0] + m, hi[1] + m]]
}

#[cfg(test)]
mod tests {
    use motet_api::{load_job, JobOptions};
    use motet_graph::GraphFile;
    use motet_sim::dance::{run_dance_with_job, CsvTrace, InputSource, PlannedJob};
    use std::path::{Path, PathBuf};

    fn dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dance/pantograph")
    }

    /// The stylus of graph.toml's five-bar (pivots 50 mm apart, 60 mm
    /// proximal and 100 mm distal links), elbows meeting above.
    fn stylus(t1: f64, t2: f64) -> (f64, f64) {
        let (e1x, e1y) = (60.0 * t1.cos(), 60.0 * t1.sin());
        let (e2x, e2y) = (50.0 + 60.0 * t2.cos(), 60.0 * t2.sin());
        let (dx, dy) = (e2x - e1x, e2y - e1y);
        let d = dx.hypot(dy);
        let a = d / 2.0;
        let h = (100.0f64 * 100.0 - a * a).sqrt();
        let (ux, uy) = (dx / d, dy / d);
        (e1x + a * ux - h * uy, e1y + a * uy + h * ux)
    }

    /// The pantograph example as `motet dance … --job boat.svg` runs it: the
    /// belts sit at the planned point plus half the stylus's motion, within
    /// half a step, while the stylus rests, while it waves and at the end.
    #[test]
    fn pantograph_boat_is_the_plan_plus_the_hand() {
        let m = crate::run::load_machine(&dir().join("machine.toml")).unwrap();
        let g = GraphFile::load(&dir().join("graph.toml")).unwrap();
        let trace = CsvTrace::load(&dir().join("inputs.csv"), &g).unwrap();
        let loaded = load_job(
            &m,
            &dir().join("boat.svg"),
            &JobOptions {
                allow_unknown: false,
                ..Default::default()
            },
        )
        .unwrap();
        let job = PlannedJob::plan(&m, &loaded.commands).unwrap();
        assert!(job.end_us * 1e-6 < trace.end());
        let rad = 0.001533980787885641;
        let per_mm = 3200.0 / (std::f64::consts::PI * 9.0);
        for s in [0.4, 2.2, 4.9, 20.0, trace.end()] {
            let mut t = trace.clone();
            let r = run_dance_with_job(&m, &g, &mut t, Some(&job), s, &mut |_| {})
                .unwrap()
                .report;
            let last = ((s * 1e6 / g.frame_us).round() - 1.0) * g.frame_us;
            let p = job.position_at(last).unwrap();
            let mut v = [0.0; 2];
            let mut at = |ts: f64| {
                t.values(ts, &mut v);
                stylus(v[0].round() * rad, v[1].round() * rad)
            };
            let (rest, now) = (at(0.0), at(last * 1e-6));
            let x = p[0] + 0.5 * (now.0 - rest.0);
            let y = p[1] + 0.5 * (now.1 - rest.1);
            for (name, want) in [("ch_a", x + y), ("ch_b", x - y)] {
                let c = r.channels.iter().find(|c| c.name == name).unwrap();
                assert!(
                    (c.position_steps - want * per_mm).abs() <= 0.5,
                    "{s} s: {name} at {}, want {}",
                    c.position_steps,
                    want * per_mm
                );
            }
        }
    }
}
