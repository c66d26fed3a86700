//! The report's plots, beside `path.png`: for each servo actuator its
//! planned and measured position and its following error
//! (`servo-NAME.png`), for each sensor its readings against the planned
//! acceleration (`sensor-NAME.png`); a heater's temperature against its
//! target goes to `heater-NAME.png` (`crate::heaters::heater_plot`). An
//! in-process run and a networked one plot alike: samples kept per source
//! and the sensors' planned acceleration.
//!
//! Everything plotted came upstream from the nodes as samples, stamped in
//! trajectory time; the planned position is the measured one plus the
//! window's mean following error (the node's set point, within half the
//! window's spread), the planned acceleration is the plan's own.

use motet_host::samples::{SampleStore, Series};
use motet_host::sensor_plan::SensorPlan;
use motet_host::Machine;
use motet_render::{write_plot, Line, Panel, Plot, PlotError};
use motet_wire::control::SampleSource;
use std::path::Path;

const PLANNED: [u8; 3] = [40, 90, 200];
const MEASURED: [u8; 3] = [220, 90, 30];
const ERROR: [u8; 3] = [150, 30, 160];

/// Writes every plot of a run into `dir` (the samples of `store`, each
/// sensor against its acceleration in `plan`), time from the trajectory's
/// start at host time `t0` µs; their file names.
pub fn write_plots(
    machine: &Machine,
    store: &SampleStore,
    plan: &SensorPlan,
    t0: f64,
    dir: &Path,
) -> Result<Vec<String>, PlotError> {
    let mut written = Vec::new();
    for s in &store.series {
        let (file, plot) = match s.source {
            SampleSource::Servo(ch) => {
                let Some(&a) = machine.nodes[s.node].actuators.get(ch as usize) else {
                    continue;
                };
                let act = &machine.actuators[a];
                (
                    format!("servo-{}.png", act.name),
                    servo_plot(&act.name, act.steps_per_unit, s, t0),
                )
            }
            SampleSource::Sensor(i) => {
                let Some(&k) = machine.nodes[s.node].sensors.get(i as usize) else {
                    continue;
                };
                let sensor = &machine.sensors[k];
                (
                    format!("sensor-{}.png", sensor.name),
                    sensor_plot(&sensor.name, s, plan.get(k), t0),
                )
            }
            SampleSource::Heater(_) => continue,
        };
        if s.all_points().next().is_none() {
            continue;
        }
        write_plot(&plot, &dir.join(&file))?;
        written.push(file);
    }
    Ok(written)
}

fn seconds(t_us: f64) -> f64 {
    t_us * 1e-6
}

/// A servo's plot (time from host time `t0` µs): position (planned and measured, joint units) over
/// following error (counts, least to most over each sample's window).
pub fn servo_plot(name: &str, counts_per_unit: f64, s: &Series, t0: f64) -> Plot {
    let pts: Vec<_> = s.all_points().copied().collect();
    let unit = |c: f64| c / counts_per_unit;
    Plot {
        title: format!("servo {name}: planned and measured position, following error"),
        panels: vec![
            Panel {
                label: "position, joint units".into(),
                lines: vec![
                    Line {
                        label: "planned".into(),
                        color: PLANNED,
                        points: pts
                            .iter()
                            .map(|p| (seconds(p.t_us - t0), unit(p.value + (p.lo + p.hi) / 2.0)))
                            .collect(),
                        band: vec![],
                    },
                    Line {
                        label: "measured".into(),
                        color: MEASURED,
                        points: pts
                            .iter()
                            .map(|p| (seconds(p.t_us - t0), unit(p.value)))
                            .collect(),
                        band: vec![],
                    },
                ],
            },
            Panel {
                label: "following error, counts (least to most per sample)".into(),
                lines: vec![Line {
                    label: "error".into(),
                    color: ERROR,
                    points: pts
                        .iter()
                        .map(|p| (seconds(p.t_us - t0), (p.lo + p.hi) / 2.0))
                        .collect(),
                    band: pts
                        .iter()
                        .map(|p| (seconds(p.t_us - t0), p.lo, p.hi))
                        .collect(),
                }],
            },
        ],
    }
}

/// A sensor's plot (time from host time `t0` µs): its readings against its axis's planned acceleration.
pub fn sensor_plot(name: &str, s: &Series, planned: Option<&Series>, t0: f64) -> Plot {
    let mut lines = vec![Line {
        label: format!("{name} (measured)"),
        color: MEASURED,
        points: s
            .all_points()
            .map(|p| (seconds(p.t_us - t0), p.value))
            .collect(),
        band: vec![],
    }];
    if let Some(p) = planned {
        let (first, last) = s
            .all_points()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.t_us), b.max(p.t_us))
            });
        lines.insert(
            0,
            Line {
                label: "planned acceleration".into(),
                color: PLANNED,
                points: p
                    .all_points()
                    .filter(|q| q.t_us >= first && q.t_us <= last)
                    .map(|q| (seconds(q.t_us - t0), q.value))
                    .collect(),
                band: vec![],
            },
        );
    }
    Plot {
        title: format!("sensor {name} against the planned acceleration, on the shared clock"),
        panels: vec![Panel {
            label: "acceleration, units/s²".into(),
            lines,
        }],
    }
}
