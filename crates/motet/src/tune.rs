//! `motet tune MACHINE ACTUATOR`: a servo's gains from experiments its node
//! runs on the simulated plant (drive steps, a relay), checked on a move,
//! plotted, and with `--write` put into the machine file, its comments and
//! layout kept.

use anyhow::{bail, Context, Result};
use motet_render::{write_plot, Line, Panel, Plot};
use motet_sim::tune::{tune, Method, Rule};
use motet_wire::control::ServoGains;
use std::path::{Path, PathBuf};

pub struct TuneArgs {
    pub machine: PathBuf,
    pub actuator: String,
    pub method: String,
    pub rule: String,
    pub write: bool,
    pub out: Option<PathBuf>,
}

pub fn tune_cmd(a: TuneArgs) -> Result<()> {
    let method = match a.method.as_str() {
        "step" => Method::Step,
        "relay" => Method::Relay,
        m => bail!("--method {m:?}: expected step or relay"),
    };
    let rule = match a.rule.as_str() {
        "model" => Rule::Model,
        "zn" => Rule::ZieglerNichols,
        r => bail!("--rule {r:?}: expected model or zn"),
    };
    let machine = motet_host::Machine::load(&a.machine)?;
    let t = tune(&machine, &a.actuator, method, rule)?;
    let id = &t.identified;
    println!(
        "{}: identified Kv {:.0} counts/s per duty, friction {:.4} duty, load {:.4} duty, reaction curve L {:.2} ms, T {:.2} ms, lag at speed {:.2} ms",
        a.actuator,
        id.kv,
        id.friction_duty,
        id.load_duty,
        id.delay_s * 1e3,
        id.tau_s * 1e3,
        id.lag_s * 1e3
    );
    if let Some((ku, tu)) = id.ultimate {
        println!(
            "  relay: ultimate gain {ku:.3e} duty/count, period {:.2} ms",
            tu * 1e3
        );
    }
    let g = &t.gains;
    println!(
        "  gains: kp {:.4e} ki {:.4e} kd {:.4e} kv {:.4e} ka {:.4e} kf {:.4e} lead {:.3} ms",
        g.kp,
        g.ki,
        g.kd,
        g.kv,
        g.ka,
        g.kf,
        g.lead * 1e3
    );
    let report = &t.check.report;
    if let Some(f) = report
        .actuators
        .iter()
        .find(|x| x.name == a.actuator)
        .and_then(|x| x.following.as_ref())
    {
        println!(
            "  check move: following error {:.2} counts max cruising ({:.2} settled), {:.2} accelerating, {:.2} at rest, {:.2} rms",
            f.max_cruise_counts,
            f.max_settled_cruise_counts,
            f.max_accel_counts,
            f.max_rest_counts,
            f.rms_counts
        );
    }
    let out = a.out.unwrap_or_else(|| PathBuf::from("out").join("tune"));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let png = out.join(format!("tune-{}.png", a.actuator));
    write_plot(&plot(&a.actuator, &t), &png)?;
    println!("  wrote {}", png.display());
    if a.write {
        write_gains(&a.machine, &a.actuator, &t.gains)?;
        println!("  wrote the gains into {}", a.machine.display());
    }
    Ok(())
}

/// The experiments' responses over the check move's following error.
fn plot(name: &str, t: &motet_sim::tune::Tuning) -> Plot {
    let colors = [[40, 90, 200], [220, 90, 30], [30, 150, 60]];
    let experiments = Panel {
        label: "experiments: counts from the start".into(),
        lines: t
            .experiments
            .iter()
            .zip(colors)
            .map(|((label, trace), color)| Line {
                label: label.clone(),
                color,
                points: trace.clone(),
                band: vec![],
            })
            .collect(),
    };
    let mut panels = vec![experiments];
    if let Some(s) = t.check.loops.store.series.first() {
        let cpu = t
            .check
            .report
            .actuators
            .iter()
            .find(|a| a.name == name)
            .map_or(1.0, |a| a.steps_per_unit);
        let check = motet_sim::plots::servo_plot(name, cpu, s, 0.0);
        panels.extend(check.panels);
    }
    Plot {
        title: format!("tuning {name}: experiments, then a move with the new gains"),
        panels,
    }
}

/// Puts `gains` into `[actuators.NAME.servo]` of the machine file at
/// `path`, leaving every other line as it was.
pub fn write_gains(path: &Path, actuator: &str, g: &ServoGains) -> Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut doc: toml_edit::DocumentMut = text
        .parse()
        .with_context(|| format!("{}: not TOML", path.display()))?;
    let servo = doc["actuators"][actuator]["servo"]
        .as_table_mut()
        .with_context(|| format!("{}: no [actuators.{actuator}.servo] table", path.display()))?;
    // Three significant digits: what an experiment tells.
    let round = |v: f32| -> f64 { format!("{:.2e}", v as f64).parse().unwrap_or(0.0) };
    for (key, v) in [
        ("kp", g.kp),
        ("ki", g.ki),
        ("kd", g.kd),
        ("kv", g.kv),
        ("ka", g.ka),
        ("kf", g.kf),
        ("derivative_hz", g.derivative_hz),
        ("lead", g.lead),
    ] {
        let value = toml_edit::value(round(v));
        match servo.get_mut(key).and_then(|i| i.as_value_mut()) {
            Some(old) => {
                // The old value's comment and spacing stay.
                let decor = old.decor().clone();
                let mut new = value.into_value().expect("a value");
                *new.decor_mut() = decor;
                *old = new;
            }
            None => {
                servo.insert(key, value);
            }
        }
    }
    std::fs::write(path, doc.to_string())
        .with_context(|| format!("cannot write {}", path.display()))?;
    // What was written must still be a machine file.
    motet_host::Machine::load(path)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gains replace the old ones in place: comments, spacing and the
    /// other keys stay, a missing gain is added, and the file still loads.
    #[test]
    fn written_gains_keep_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        let text = "# my mill\nname = \"m\"\n[axes.x]\ntravel = [0, 100]\nmax_velocity = 100\nmax_acceleration = 1000\n\n[actuators.xm]\njoint = \"x\"\nchain = [{ leadscrew = { lead = 5.0 } }, { encoder = { lines = 1000 } }]\n[actuators.xm.servo]\nrate_hz = 10000\nkp = 0.1   # too high\nfollowing_limit = 40\n";
        std::fs::write(&path, text).unwrap();
        let g = ServoGains {
            kp: 0.00173,
            ki: 0.0907,
            kd: 1.15e-5,
            kv: 3.29e-6,
            ka: 2.18e-8,
            kf: 0.004,
            integral_limit: 0.2,
            output_limit: 1.0,
            derivative_hz: 500.0,
            lead: 4.7e-4,
        };
        write_gains(&path, "xm", &g).unwrap();
        let out = std::fs::read_to_string(&path).unwrap();
        assert!(out.starts_with("# my mill\n"), "{out}");
        assert!(out.contains("kp = 0.00173   # too high"), "{out}");
        let m = motet_host::Machine::load(&path).unwrap();
        let s = m.actuators[0].servo.as_ref().unwrap();
        assert_eq!(
            (s.gains.kp, s.gains.kf, s.following_limit),
            (0.00173, 0.004, 40.0)
        );
        assert!(write_gains(&path, "ym", &g).is_err(), "no such actuator");
    }
}
