//! The report's plots, beside `path.png`: for each servo actuator its
//! planned and measured position and its following error
//! (`servo-NAME.png`), for each sensor its readings against the planned
//! acceleration (`sensor-NAME.png`); a heater loop's temperature against
//! its target goes to `heater-NAME.png` (see [`heater_plot`]).
//!
//! Everything plotted came upstream from the nodes as samples, stamped in
//! trajectory time; the planned position is the measured one plus the
//! window's mean following error (the node's set point, within half the
//! window's spread), the planned acceleration is the plan's own.

use crate::loops::LoopWatch;
use motet_host::samples::Series;
use motet_host::Machine;
use motet_render::{write_plot, Line, Panel, Plot, PlotError};
use motet_wire::control::SampleSource;
use std::path::Path;

const PLANNED: [u8; 3] = [40, 90, 200];
const MEASURED: [u8; 3] = [220, 90, 30];
const ERROR: [u8; 3] = [150, 30, 160];

/// Writes every plot of a run into `dir`; their file names.
pub fn write_plots(
    machine: &Machine,
    loops: &LoopWatch,
    dir: &Path,
) -> Result<Vec<String>, PlotError> {
    let mut written = Vec::new();
    for s in &loops.store.series {
        let (file, plot) = match s.source {
            SampleSource::Servo(ch) => {
                let Some(&a) = machine.nodes[s.node].actuators.get(ch as usize) else {
                    continue;
                };
                let act = &machine.actuators[a];
                (
                    format!("servo-{}.png", act.name),
                    servo_plot(&act.name, act.steps_per_unit, s),
                )
            }
            SampleSource::Sensor(i) => {
                let Some(&k) = machine.nodes[s.node].sensors.get(i as usize) else {
                    continue;
                };
                let sensor = &machine.sensors[k];
                (
                    format!("sensor-{}.png", sensor.name),
                    sensor_plot(&sensor.name, s, loops.planned.get(k)),
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

/// A servo's plot: position (planned and measured, joint units) over
/// following error (counts, least to most over each sample's window).
pub fn servo_plot(name: &str, counts_per_unit: f64, s: &Series) -> Plot {
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
                            .map(|p| (seconds(p.t_us), unit(p.value + (p.lo + p.hi) / 2.0)))
                            .collect(),
                        band: vec![],
                    },
                    Line {
                        label: "measured".into(),
                        color: MEASURED,
                        points: pts
                            .iter()
                            .map(|p| (seconds(p.t_us), unit(p.value)))
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
                        .map(|p| (seconds(p.t_us), (p.lo + p.hi) / 2.0))
                        .collect(),
                    band: pts.iter().map(|p| (seconds(p.t_us), p.lo, p.hi)).collect(),
                }],
            },
        ],
    }
}

/// A sensor's plot: its readings against its axis's planned acceleration.
pub fn sensor_plot(name: &str, s: &Series, planned: Option<&Series>) -> Plot {
    let mut lines = vec![Line {
        label: format!("{name} (measured)"),
        color: MEASURED,
        points: s.all_points().map(|p| (seconds(p.t_us), p.value)).collect(),
        band: vec![],
    }];
    if let Some(p) = planned {
        let (t0, t1) = s
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
                    .filter(|q| q.t_us >= t0 && q.t_us <= t1)
                    .map(|q| (seconds(q.t_us), q.value))
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

/// A heater's plot: its temperature against its target (a heater loop's
/// samples, readings in °C, and its targets as a series of the same
/// times): the hook `heater-NAME.png` is drawn with.
pub fn heater_plot(name: &str, temperature: &Series, target: &[(f64, f64)]) -> Plot {
    Plot {
        title: format!("heater {name}: temperature and target"),
        panels: vec![Panel {
            label: "temperature, °C".into(),
            lines: vec![
                Line {
                    label: "target".into(),
                    color: PLANNED,
                    points: target.iter().map(|&(t, v)| (seconds(t), v)).collect(),
                    band: vec![],
                },
                Line {
                    label: "measured".into(),
                    color: MEASURED,
                    points: temperature
                        .all_points()
                        .map(|p| (seconds(p.t_us), p.value))
                        .collect(),
                    band: vec![],
                },
            ],
        }],
    }
}
