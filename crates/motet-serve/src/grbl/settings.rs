//! `$$`: grbl's settings as the machine file gives them, and which of
//! them a sender may change on the running machine (`$N=value`). Changes
//! last until the server stops: nothing is written back to the machine
//! file (docs/compat.md).

use super::axes::Axes;
use super::errors::code;
use motet_host::Machine;
use motet_planner::ToolKind;

/// Settings the protocol itself keeps (not the machine's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Local {
    /// `$10`: bit 0 MPos (else WPos), bit 1 `Bf:` in status reports.
    pub status_mask: u8,
    /// `$13`: report inches.
    pub inches: bool,
}

impl Default for Local {
    fn default() -> Self {
        Local {
            status_mask: 3,
            inches: false,
        }
    }
}

/// Every setting `$$` lists, in order, with its value.
pub fn list(machine: &Machine, axes: &Axes, local: &Local) -> Vec<(u16, String)> {
    let laser = machine.tools.iter().any(|t| t.kind == ToolKind::Laser);
    let pulse = machine
        .actuators
        .iter()
        .map(|a| a.pulse_us)
        .fold(0.0f32, f32::max);
    let mut out: Vec<(u16, String)> = vec![
        (0, format!("{}", pulse.ceil().max(1.0) as u32)),
        (1, "25".into()),
        (2, "0".into()),
        (3, "0".into()),
        (4, "0".into()),
        (5, "0".into()),
        (6, "0".into()),
        (10, local.status_mask.to_string()),
        (11, format!("{:.3}", machine.junction_deviation)),
        (12, format!("{:.3}", machine.tolerance)),
        (13, u8::from(local.inches).to_string()),
        // Soft limits: motet checks every move against the travel.
        (20, "1".into()),
        (21, "0".into()),
        (22, "0".into()),
        (23, "0".into()),
        (24, "25.000".into()),
        (25, "500.000".into()),
        (26, "250".into()),
        (27, "1.000".into()),
        (30, "1000".into()),
        (31, "0".into()),
        (32, u8::from(laser).to_string()),
    ];
    let per_axis = |base: u16, f: &dyn Fn(usize) -> f64| -> Vec<(u16, String)> {
        axes.map
            .iter()
            .enumerate()
            .map(|(k, m)| (base + k as u16, format!("{:.3}", m.map_or(0.0, f))))
            .collect()
    };
    out.extend(per_axis(100, &|i| 0.5 / machine.half_step(i)));
    out.extend(per_axis(110, &|i| machine.axes[i].max_velocity * 60.0));
    out.extend(per_axis(120, &|i| machine.axes[i].max_acceleration));
    out.extend(per_axis(130, &|i| {
        let [lo, hi] = machine.axes[i].travel;
        hi - lo
    }));
    out
}

/// What a `$N=value` write does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Write {
    /// A setting the protocol keeps.
    Local(Local),
    /// A planning limit of the running machine: apply with
    /// [`apply_to`] at rest.
    Machine {
        /// Which (`$11`, `$110`…`$129`).
        setting: u16,
        /// Its new value, grbl's unit.
        value: f64,
    },
}

/// Checks `$N=value`. Steps, travel, pulses and homing are the machine
/// file's and the nodes' configuration: changing them under a running
/// server is not sound, so they are refused (`error:3`, with a message);
/// speeds, accelerations and the junction deviation may go down to any
/// positive value or back up to the machine file's.
pub fn check(
    n: u16,
    value: f64,
    file: &Machine,
    axes: &Axes,
    local: &Local,
) -> Result<Write, (u8, String)> {
    if !value.is_finite() {
        return Err((code::BAD_NUMBER, format!("${n}: not a number")));
    }
    if value < 0.0 {
        return Err((code::NEGATIVE, format!("${n}: negative")));
    }
    let listed = list(file, axes, local).iter().any(|(k, _)| *k == n);
    if !listed {
        return Err((code::INVALID_STATEMENT, format!("${n}: no such setting")));
    }
    let axis = |base: u16| -> Option<usize> {
        n.checked_sub(base)
            .and_then(|k| axes.map.get(k as usize).copied().flatten())
    };
    match n {
        10 if value <= 3.0 && value.fract() == 0.0 => Ok(Write::Local(Local {
            status_mask: value as u8,
            ..*local
        })),
        13 if value <= 1.0 && value.fract() == 0.0 => Ok(Write::Local(Local {
            inches: value == 1.0,
            ..*local
        })),
        11 if value > 0.0 && value <= file.junction_deviation => {
            Ok(Write::Machine { setting: n, value })
        }
        110..=129 => {
            let base = if n < 120 { 110 } else { 120 };
            let Some(i) = axis(base) else {
                return Err((code::INVALID_STATEMENT, format!("${n}: the machine has no such axis")));
            };
            let most = if base == 110 {
                file.axes[i].max_velocity * 60.0
            } else {
                file.axes[i].max_acceleration
            };
            if value > 0.0 && value <= most * (1.0 + 1e-9) {
                Ok(Write::Machine { setting: n, value })
            } else {
                Err((
                    code::INVALID_STATEMENT,
                    format!("${n} may be set above 0 and up to the machine file's {most:.3}"),
                ))
            }
        }
        _ => Err((
            code::INVALID_STATEMENT,
            format!(
                "${n} comes from the machine file and the nodes' configuration: edit {} and restart",
                file.file.display()
            ),
        )),
    }
}

/// Applies a machine write checked by [`check`].
pub fn apply_to(m: &mut Machine, axes: &Axes, setting: u16, value: f64) {
    let axis = |base: u16| axes.map.get((setting - base) as usize).copied().flatten();
    match setting {
        11 => m.junction_deviation = value,
        110..=119 => {
            if let Some(i) = axis(110) {
                m.axes[i].max_velocity = value / 60.0;
            }
        }
        120..=129 => {
            if let Some(i) = axis(120) {
                m.axes[i].max_acceleration = value;
            }
        }
        _ => {}
    }
}
