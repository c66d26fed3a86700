//! Checks a job against the machine before anything moves.

use crate::machine::Machine;
use motet_planner::{Command, Located, SourceError};
use motet_trajectory::{KinematicsKind, Point};

/// Refuses moves beyond travel and moves a polar machine cannot make, naming the
/// first offending command's place.
pub fn check_job(machine: &Machine, commands: &[Located<Command>]) -> Result<(), SourceError> {
    let mut pos = machine.start;
    for c in commands {
        let Command::Move(m) = &c.item else { continue };
        check_move(machine, &pos, &m.target).map_err(|message| SourceError {
            loc: c.loc,
            message,
        })?;
        pos = m.target;
    }
    Ok(())
}

/// Whether the machine can move straight from `from` to `to`; the reason if not.
pub fn check_move(machine: &Machine, from: &Point, to: &Point) -> Result<(), String> {
    for (i, a) in machine.axes.iter().enumerate() {
        let v = to[i];
        let eps = 1e-6 * (1.0 + v.abs());
        if !v.is_finite() || v < a.travel[0] - eps || v > a.travel[1] + eps {
            return Err(format!(
                "move to {}={:.4} is beyond the axis's travel [{}, {}]",
                a.name, v, a.travel[0], a.travel[1]
            ));
        }
    }
    if let (KinematicsKind::Polar, Some((x, y))) = (machine.kinematics, machine.xy) {
        let (px, py) = (from[x], from[y]);
        let (wx, wy) = (to[x] - px, to[y] - py);
        let ww = wx * wx + wy * wy;
        let t = if ww > 0.0 {
            (-(px * wx + py * wy) / ww).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = ((px + wx * t).powi(2) + (py + wy * t).powi(2)).sqrt();
        if d < machine.min_radius && (ww > 0.0 || d == 0.0) {
            return Err(format!(
                "move passes {:.3} mm from the polar centre; the turntable cannot follow closer than min_radius = {} mm",
                d, machine.min_radius
            ));
        }
    }
    Ok(())
}
