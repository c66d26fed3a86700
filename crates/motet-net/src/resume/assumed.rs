//! Where the person says the machine is (`--assume-position`), for the axes
//! of nodes that lost their position.

use super::nodes::Known;
use super::{show, ResumeError};
use motet_host::Machine;
use motet_trajectory::Point;

/// The axes of lost nodes (`needed`) from what the person says; returns the
/// lost nodes' names. Refuses a position not needed, an axis missing, or
/// one that contradicts a node that knows.
pub(super) fn apply_assumed(
    m: &Machine,
    assumed: Option<&[(usize, f64)]>,
    lost: &[(usize, String)],
    needed: u8,
    known: &Known,
    from: &mut Point,
) -> Result<Vec<String>, ResumeError> {
    let lost_why = || {
        lost.iter()
            .map(|l| l.1.clone())
            .collect::<Vec<_>>()
            .join("; ")
    };
    let given = match assumed {
        None if needed != 0 => {
            let axes: Vec<&str> = (0..m.axes.len())
                .filter(|i| needed & (1 << i) != 0)
                .map(|i| m.axes[i].name.as_str())
                .collect();
            return Err(ResumeError::Unknown {
                nodes: lost_why(),
                is: if axes.len() == 1 { "is" } else { "are" },
                example: axes
                    .iter()
                    .map(|a| format!("{a}=…"))
                    .collect::<Vec<_>>()
                    .join(","),
                axes: axes.join(", "),
            });
        }
        None => return Ok(Vec::new()),
        Some(_) if needed == 0 => {
            return Err(ResumeError::AssumeNotNeeded {
                at: show(m, from, u8::MAX),
            })
        }
        Some(given) => given,
    };
    for i in (0..m.axes.len()).filter(|i| needed & (1 << i) != 0) {
        let v = given
            .iter()
            .rev()
            .find(|g| g.0 == i)
            .map(|g| g.1)
            .ok_or_else(|| ResumeError::Unknown {
                nodes: lost_why(),
                is: "is",
                axes: m.axes[i].name.clone(),
                example: format!("{}=…", m.axes[i].name),
            })?;
        from[i] = v;
    }
    for &(i, v) in given {
        if i >= m.axes.len() {
            return Err(ResumeError::AssumeAxis(i.to_string()));
        }
        if needed & (1 << i) != 0 {
            continue;
        }
        if let Some((k, known)) = known[i] {
            if (v - known).abs() > 1e-6 * (1.0 + known.abs()) {
                return Err(ResumeError::AssumeConflict {
                    axis: m.axes[i].name.clone(),
                    given: v,
                    node: m.nodes[k].name.clone(),
                    known,
                });
            }
        }
    }
    Ok(lost.iter().map(|&(k, _)| m.nodes[k].name.clone()).collect())
}

/// Parses `--assume-position x=10,y=20.5` against the machine's axes.
pub fn parse_assumed(m: &Machine, text: &str) -> Result<Vec<(usize, f64)>, String> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, value) = part
            .split_once('=')
            .ok_or_else(|| format!("`{part}`: expected AXIS=VALUE, e.g. x=10.5"))?;
        let i = m
            .axes
            .iter()
            .position(|a| a.name == name.trim())
            .ok_or_else(|| {
                format!(
                    "`{part}`: the machine has no axis `{}` (it has: {})",
                    name.trim(),
                    m.axes
                        .iter()
                        .map(|a| a.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("`{part}`: `{}` is not a number", value.trim()))?;
        out.push((i, v));
    }
    if out.is_empty() {
        return Err("give at least one AXIS=VALUE, e.g. x=10.5,y=20".into());
    }
    Ok(out)
}
