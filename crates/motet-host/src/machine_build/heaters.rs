//! `[heaters.NAME]`: each heater's channel and highest target; a simulated
//! first-order lag (`time_constant`) or, listed on a node (`[nodes.NAME]
//! heaters`), its loop, thermal model and runaway watch
//! (`[heaters.NAME.pid]`, `.model`, `.runaway`). Without the section, a
//! printer's hot end and bed when the machine has an extruder axis `e`.

use super::Source;
use crate::heater_loop::{
    default_watch, reaction_curve_gains, HeaterFault, HeaterFaultKind, HeaterLoop, ThermalPlant,
    DEFAULT_RATE_HZ, DEFAULT_READY,
};
use crate::machine::{Axis, Heater, MachineError, NodeSpec};
use crate::machine_file::{HeaterFile, MachineFile};
use motet_planner::ranges::{self, ValueRange};
use motet_planner::AuxChannel;
use motet_wire::heater::{HeaterGains, ReadyRule, RunawayWatch, HEATER_GAIN_RANGES};
use toml::Spanned;

/// Highest target a heater may take, °C.
const MAX_C: ValueRange = ValueRange::new(30.0, 1000.0, "°C");
/// Time constant, s.
const TAU_S: ValueRange = ValueRange::new(0.1, 3600.0, "s");
/// A node-driven heater's time constant when the file gives none (what
/// `motet serve` models it with), s.
const NODE_TAU_S: f64 = 20.0;
/// Heater loop rates, Hz (`motet_wire::heater::HEATER_HZ`).
const RATE_HZ: ValueRange = ValueRange::new(1.0, 100.0, "Hz");
const POWER_W: ValueRange = ValueRange::new(0.1, 10_000.0, "W");
const CAPACITY: ValueRange = ValueRange::new(0.1, 1e6, "J/K");
const LOSS: ValueRange = ValueRange::new(1e-4, 1000.0, "W/K");
const FAN_LOSS: ValueRange = ValueRange::new(0.0, 1000.0, "W/K");
const LAG_S: ValueRange = ValueRange::new(0.0, 600.0, "s");
const AMBIENT_C: ValueRange = ValueRange::new(-50.0, 100.0, "°C");
const NOISE_C: ValueRange = ValueRange::new(0.0, 10.0, "°C");
const WINDOW_S: ValueRange = ValueRange::new(0.1, 3600.0, "s");
const MARGIN_C: ValueRange = ValueRange::new(0.1, 1000.0, "°C");
const READY_C: ValueRange = ValueRange::new(0.1, 100.0, "°C");
const RESIDENCY_S: ValueRange = ValueRange::new(0.0, 3600.0, "s");
/// Most heaters a node drives (`motet_node::control::MAX_HEATERS`).
const NODE_HEATERS: usize = 4;

/// The machine's heaters, in the file's (sorted) order; those a node
/// drives get their loops from [`heater_nodes`].
pub(super) fn heaters(
    src: &Source,
    raw: &MachineFile,
    axes: &[Axis],
) -> Result<Vec<Heater>, MachineError> {
    if raw.heaters.is_empty() {
        return Ok(if axes.iter().any(|a| a.name == "e") {
            Heater::default_printer()
        } else {
            Vec::new()
        });
    }
    let mut out: Vec<Heater> = Vec::new();
    for (name, h) in &raw.heaters {
        let h = h.get_ref();
        let index = match &h.index {
            None => 0,
            Some(i) => u8::try_from(*i.get_ref())
                .map_err(|_| src.err(i.span(), format!("heater {name}: index from 0 to 255")))?,
        };
        let channel = match h.channel.get_ref().as_str() {
            "hotend" => AuxChannel::Hotend(index),
            "bed" => AuxChannel::Bed,
            "chamber" => AuxChannel::Chamber,
            other => {
                return Err(src.err(
                    h.channel.span(),
                    format!(
                        "heater {name}: unknown channel `{other}`; expected hotend, bed or chamber"
                    ),
                ))
            }
        };
        if let Some(twin) = out.iter().find(|o| o.channel == channel) {
            return Err(src.err(
                h.channel.span(),
                format!("heater {name}: {} already has this channel", twin.name),
            ));
        }
        let max_c = src.value(&h.max, MAX_C, format_args!("heater {name}: max"))?;
        let tau_s = match &h.time_constant {
            Some(t) => src.value(t, TAU_S, format_args!("heater {name}: time_constant"))?,
            // Needed unless a node drives it, which `heater_nodes` checks.
            None => f64::NAN,
        };
        out.push(Heater {
            name: name.clone(),
            channel,
            max_c,
            tau_s,
            // Built once a node lists it (`heater_nodes`).
            node_loop: None,
        });
    }
    Ok(out)
}

/// Each heater a node lists in `heaters` goes on that node (at most
/// [`NODE_HEATERS`] a node, each on one); the others are first-order lags
/// and need their `time_constant`, and no loop tables.
pub(super) fn heater_nodes(
    src: &Source,
    raw: &MachineFile,
    heaters: &mut [Heater],
    nodes: &[NodeSpec],
) -> Result<(), MachineError> {
    let mut placed = vec![false; heaters.len()];
    for (name, n) in &raw.nodes {
        let k = nodes.iter().position(|x| x.name == *name).unwrap_or(0);
        let listed = &n.get_ref().heaters;
        if listed.len() > NODE_HEATERS {
            return Err(src.err(
                listed[NODE_HEATERS].span(),
                format!("node {name}: at most {NODE_HEATERS} heaters a node"),
            ));
        }
        for (i, h) in listed.iter().enumerate() {
            let found = heaters
                .iter()
                .position(|x| x.name == *h.get_ref())
                .filter(|_| !raw.heaters.is_empty());
            let Some(j) = found else {
                return Err(src.err(
                    h.span(),
                    format!(
                        "node {name}: unknown heater `{}` (a [heaters.NAME] table)",
                        h.get_ref()
                    ),
                ));
            };
            if placed[j] {
                return Err(src.err(
                    h.span(),
                    format!("heater `{}` is already on a node", h.get_ref()),
                ));
            }
            placed[j] = true;
            let heater = &mut heaters[j];
            let file = raw.heaters[&heater.name].get_ref();
            let mut l = heater_loop(src, &heater.name, file, heater.channel, heater.max_c)?;
            l.node = k;
            l.index = i as u8;
            heater.node_loop = Some(l);
        }
    }
    for (j, heater) in heaters.iter_mut().enumerate() {
        if placed[j] {
            if heater.tau_s.is_nan() {
                heater.tau_s = NODE_TAU_S;
            }
            continue;
        }
        let Some(file) = raw.heaters.get(&heater.name) else {
            // A printer's default heaters: first-order lags.
            continue;
        };
        let f = file.get_ref();
        let table = [
            ("pid", f.pid.as_ref().map(|t| t.span())),
            ("model", f.model.as_ref().map(|t| t.span())),
            ("runaway", f.runaway.as_ref().map(|t| t.span())),
        ];
        if let Some((what, Some(span))) = table.into_iter().find(|(_, s)| s.is_some()) {
            return Err(src.err(
                span,
                format!(
                    "heater {}: [heaters.{}.{what}] is for a heater a node drives; list it in a node's `heaters`",
                    heater.name, heater.name
                ),
            ));
        }
        if heater.tau_s.is_nan() {
            return Err(src.err(
                file.span(),
                format!(
                    "heater {}: time_constant is needed unless a node drives it ([nodes.NAME] heaters)",
                    heater.name
                ),
            ));
        }
    }
    Ok(())
}

/// A value of a table if given (checked against `range`), else `default`.
fn opt(
    src: &Source,
    v: &Option<Spanned<f64>>,
    range: ValueRange,
    what: std::fmt::Arguments,
    default: f64,
) -> Result<f64, MachineError> {
    src.value_or(v.as_ref(), range, what, default)
}

/// The loop, model and watch of heater `name` as its tables give them,
/// defaults derived from the model for what they leave out.
fn heater_loop(
    src: &Source,
    name: &str,
    h: &HeaterFile,
    channel: AuxChannel,
    max_c: f64,
) -> Result<HeaterLoop, MachineError> {
    let plant = plant(src, name, h, channel, max_c)?;
    let empty = Default::default();
    let m = h.model.as_ref().map_or(&empty, |m| m.get_ref());
    let fault = fault(src, name, m)?;
    let (rate_hz, gains) = gains(src, name, h, &plant)?;
    let (watch, min_c) = watch(src, name, h, &plant, channel, max_c)?;
    let v = |f: &Option<Spanned<f64>>, range, key: &str, d: f32| {
        opt(
            src,
            f,
            range,
            format_args!("heater {name}: {key}"),
            d as f64,
        )
        .map(|v| v as f32)
    };
    let ready = ReadyRule {
        window_c: v(&h.window, READY_C, "window", DEFAULT_READY.window_c)?,
        residency_s: v(
            &h.residency,
            RESIDENCY_S,
            "residency",
            DEFAULT_READY.residency_s,
        )?,
    };
    Ok(HeaterLoop {
        node: usize::MAX,
        index: 0,
        rate_hz,
        gains,
        plant,
        watch,
        min_c,
        ready,
        fault,
    })
}

/// The heater's thermal model: its `[model]` table over the channel's
/// defaults, checked to reach the heater's `max` and to heat as a heater
/// does.
fn plant(
    src: &Source,
    name: &str,
    h: &HeaterFile,
    channel: AuxChannel,
    max_c: f64,
) -> Result<ThermalPlant, MachineError> {
    let d = ThermalPlant::default_for(channel);
    let empty = Default::default();
    let m = h.model.as_ref().map_or(&empty, |m| m.get_ref());
    let v = |f: &Option<Spanned<f64>>, range, key: &str, d: f64| {
        opt(src, f, range, format_args!("heater {name}: model {key}"), d)
    };
    let plant = ThermalPlant {
        power_w: v(&m.power, POWER_W, "power", d.power_w)?,
        capacity_j_per_k: v(&m.capacity, CAPACITY, "capacity", d.capacity_j_per_k)?,
        loss_w_per_k: v(&m.loss, LOSS, "loss", d.loss_w_per_k)?,
        fan_loss_w_per_k: v(&m.fan_loss, FAN_LOSS, "fan_loss", d.fan_loss_w_per_k)?,
        sensor_lag_s: v(&m.sensor_lag, LAG_S, "sensor_lag", d.sensor_lag_s)?,
        ambient_c: v(&m.ambient, AMBIENT_C, "ambient", d.ambient_c)?,
        noise_c: v(&m.noise, NOISE_C, "noise", d.noise_c)?,
    };
    let reach = plant.full_power_c();
    if max_c >= reach {
        return Err(src.err(
            h.max.span(),
            format!(
                "heater {name}: max {max_c} °C is beyond what its model reaches at full power ({} °C)",
                ranges::rounded(reach)
            ),
        ));
    }
    let rate = plant.power_w / plant.capacity_j_per_k;
    if !(1e-4..=1000.0).contains(&rate) || plant.loss_w_per_k / plant.capacity_j_per_k > 10.0 {
        let span = h.model.as_ref().map_or(h.max.span(), |m| m.span());
        return Err(src.err(
            span,
            format!(
                "heater {name}: model heats at {} °C/s or loses more than 10 °C/s per °C: no heater does",
                ranges::rounded(rate)
            ),
        ));
    }
    Ok(plant)
}

/// The loop's rate and gains: its `[pid]` table over the gains the
/// reaction curve gives the model.
fn gains(
    src: &Source,
    name: &str,
    h: &HeaterFile,
    plant: &ThermalPlant,
) -> Result<(f64, HeaterGains), MachineError> {
    let empty = Default::default();
    let p = h.pid.as_ref().map_or(&empty, |p| p.get_ref());
    let rate_hz = opt(
        src,
        &p.rate_hz,
        RATE_HZ,
        format_args!("heater {name}: pid rate_hz"),
        DEFAULT_RATE_HZ,
    )?;
    let mut values = reaction_curve_gains(plant, rate_hz).values();
    let given = [
        &p.kp,
        &p.ki,
        &p.kd,
        &p.integral_limit,
        &p.output_limit,
        &p.derivative_s,
        &p.feed_forward,
    ];
    for ((v, file), (key, lo, hi)) in values.iter_mut().zip(given).zip(HEATER_GAIN_RANGES) {
        let range = ValueRange::new(lo as f64, hi as f64, "");
        *v = opt(
            src,
            file,
            range,
            format_args!("heater {name}: pid {key}"),
            *v as f64,
        )? as f32;
    }
    let gains = HeaterGains {
        kp: values[0],
        ki: values[1],
        kd: values[2],
        integral_limit: values[3],
        output_limit: values[4],
        derivative_s: values[5],
        feed_forward: values[6],
    };
    Ok((rate_hz, gains))
}

/// The runaway watch and the lowest plausible reading: its `[runaway]`
/// table over what the model gives.
fn watch(
    src: &Source,
    name: &str,
    h: &HeaterFile,
    plant: &ThermalPlant,
    channel: AuxChannel,
    max_c: f64,
) -> Result<(RunawayWatch, f64), MachineError> {
    let w = default_watch(plant, channel);
    let empty = Default::default();
    let r = h.runaway.as_ref().map_or(&empty, |r| r.get_ref());
    let v = |f: &Option<Spanned<f64>>, range, key: &str, d: f32| {
        opt(
            src,
            f,
            range,
            format_args!("heater {name}: runaway {key}"),
            d as f64,
        )
        .map(|v| v as f32)
    };
    let watch = RunawayWatch {
        window_s: v(&r.window, WINDOW_S, "window", w.window_s)?,
        margin_c: v(&r.margin, MARGIN_C, "margin", w.margin_c)?,
        hysteresis_c: v(&r.hysteresis, MARGIN_C, "hysteresis", w.hysteresis_c)?,
        period_s: v(&r.period, WINDOW_S, "period", w.period_s)?,
    };
    let below = ValueRange::new(-273.15, max_c - 1.0, "°C");
    let min_c = opt(
        src,
        &r.min,
        below,
        format_args!("heater {name}: runaway min"),
        0.0,
    )?;
    Ok((watch, min_c))
}

/// The fault the model table injects, if any.
fn fault(
    src: &Source,
    name: &str,
    m: &crate::machine_file_heaters::HeaterModelFile,
) -> Result<Option<HeaterFault>, MachineError> {
    let Some(f) = &m.fault else {
        if let Some(at) = &m.fault_at {
            return Err(src.err(
                at.span(),
                format!("heater {name}: fault_at without a fault"),
            ));
        }
        return Ok(None);
    };
    let kind = HeaterFaultKind::parse(f.get_ref()).ok_or_else(|| {
        src.err(
            f.span(),
            format!(
                "heater {name}: unknown fault `{}`; expected {}",
                f.get_ref(),
                HeaterFaultKind::NAMES
            ),
        )
    })?;
    let at_s = opt(
        src,
        &m.fault_at,
        ranges::JOB_S,
        format_args!("heater {name}: model fault_at"),
        0.0,
    )?;
    Ok(Some(HeaterFault { kind, at_s }))
}
