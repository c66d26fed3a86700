//! Checks a job against the machine before anything moves.

use crate::machine::Machine;
use motet_planner::ranges::rounded;
use motet_planner::{Command, Located, SourceError};
use motet_trajectory::kinematics::{tool_point, Unreachable, Xyz};
use motet_trajectory::{KinematicsKind, Point};

/// Coordinates a job check brought back onto the travel's ends: beyond it,
/// but by less than half a step of the motors moving that axis, so that no
/// motor could have told the difference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Clamps {
    /// Moves with at least one coordinate clamped.
    pub moves: usize,
    /// The farthest a clamped coordinate was beyond travel, mm (or degrees).
    pub max_mm: f64,
}

impl Clamps {
    fn add(&mut self, distance: f64) {
        if distance > 0.0 {
            self.moves += 1;
            self.max_mm = self.max_mm.max(distance);
        }
    }
}

/// Clamps coordinates within half a step of travel onto it, and refuses moves
/// beyond travel and moves a polar machine cannot make, naming the first
/// offending command's place. Returns what was clamped.
pub fn check_job(
    machine: &Machine,
    commands: &mut [Located<Command>],
) -> Result<Clamps, SourceError> {
    let mut check = JobCheck::new(machine);
    for c in commands.iter_mut() {
        check.check(machine, c)?;
    }
    Ok(check.clamps)
}

/// [`check_job`] a command at a time, for jobs read as a stream: holds only
/// the position the last move ended at.
#[derive(Clone, Debug)]
pub struct JobCheck {
    pos: Point,
    /// What was clamped so far.
    pub clamps: Clamps,
}

impl JobCheck {
    /// A check starting where `machine` starts.
    pub fn new(machine: &Machine) -> JobCheck {
        JobCheck {
            pos: machine.start,
            clamps: Clamps::default(),
        }
    }

    /// Checks the next command of the job (clamping it as [`check_job`] does).
    pub fn check(
        &mut self,
        machine: &Machine,
        c: &mut Located<Command>,
    ) -> Result<(), SourceError> {
        let loc = c.loc;
        if let Command::Aux { channel, value, .. } = c.item {
            return crate::heater_loop::check_target(machine, channel, value)
                .map_err(|message| SourceError { loc, message });
        }
        let Command::Move(m) = &mut c.item else {
            return Ok(());
        };
        let d = clamp_move(machine, &self.pos, &mut m.target).map_err(|e| SourceError {
            loc,
            message: e.to_string(),
        })?;
        self.clamps.add(d);
        self.pos = m.target;
        Ok(())
    }
}

/// Why the machine cannot make a move.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MoveError {
    /// A target coordinate is NaN or infinite.
    #[error("move to {axis}={value}: not a number")]
    NotANumber {
        /// The axis's name in the machine file.
        axis: String,
        /// The coordinate given.
        value: f64,
    },
    /// A target is beyond the axis's travel by half a step or more (a
    /// motor would notice); less than that is clamped instead.
    #[error(
        "move to {axis}={} is {} beyond the axis's travel [{}, {}] (half a step is {})",
        rounded(*.value), rounded(*.beyond), rounded(.travel[0]), rounded(.travel[1]), rounded(*.half_step)
    )]
    BeyondTravel {
        /// The axis's name in the machine file.
        axis: String,
        /// The coordinate given, in axis units (mm or degrees).
        value: f64,
        /// How far beyond the travel's nearer end it is.
        beyond: f64,
        /// The axis's `travel = [min, max]`.
        travel: [f64; 2],
        /// [`Machine::half_step`] of the axis: the clamp it missed.
        half_step: f64,
    },
    /// On a polar machine, the straight move passes closer to the centre
    /// than `[motion] min_radius`, where the turntable would have to spin
    /// faster than it can.
    #[error("move passes {distance:.3} mm from the polar centre; the turntable cannot follow closer than min_radius = {min_radius} mm")]
    PolarCentre {
        /// The move's closest approach to the centre, mm.
        distance: f64,
        /// The machine's `min_radius`, mm.
        min_radius: f64,
    },
    /// Some point of the move is out of an arm's, linkage's or delta's
    /// reach, or within the margin of one of its singularities.
    #[error("move passes {}, {why} of the {kinematics} kinematics", show_point(&.at[..*.dims]))]
    Unreachable {
        /// The first point checked that is out of reach: x, y, z.
        at: Xyz,
        /// How many of its coordinates the kinematics replaces (2 or 3).
        dims: usize,
        /// Out of reach, or too near a singularity.
        why: Unreachable,
        /// The kinematics' name, as in `[motion] kinematics`.
        kinematics: &'static str,
    },
}

/// [`check_move`] after clamping `to` onto the travel where it is beyond it
/// by less than [`Machine::half_step`]; returns the largest clamp (0 if none).
pub fn clamp_move(machine: &Machine, from: &Point, to: &mut Point) -> Result<f64, MoveError> {
    let mut largest = 0.0f64;
    for (i, a) in machine.axes.iter().enumerate() {
        let [lo, hi] = a.travel;
        let v = to[i];
        let beyond = if v < lo { lo - v } else { v - hi };
        if beyond > 0.0 && beyond < machine.half_step(i) {
            to[i] = v.clamp(lo, hi);
            largest = largest.max(beyond);
        }
    }
    check_move(machine, from, to)?;
    Ok(largest)
}

/// Whether the machine can move straight from `from` to `to`; the reason if
/// not. A coordinate may be beyond travel by less than half a step (what
/// [`clamp_move`] would clamp).
pub fn check_move(machine: &Machine, from: &Point, to: &Point) -> Result<(), MoveError> {
    for (i, a) in machine.axes.iter().enumerate() {
        let v = to[i];
        let [lo, hi] = a.travel;
        if !v.is_finite() {
            return Err(MoveError::NotANumber {
                axis: a.name.clone(),
                value: v,
            });
        }
        let beyond = if v < lo { lo - v } else { v - hi };
        let half = machine.half_step(i);
        // At the travel's end exactly is within it, whatever the half step.
        if beyond > 0.0 && beyond >= half {
            return Err(MoveError::BeyondTravel {
                axis: a.name.clone(),
                value: v,
                beyond,
                travel: [lo, hi],
                half_step: half,
            });
        }
    }
    if let Some(axes) = machine.kinematic_axes {
        let axes = axes.map(|a| a as u8);
        check_reach(
            machine.kinematics,
            tool_point(axes, from),
            tool_point(axes, to),
        )?;
    }
    if let (KinematicsKind::Polar(_), Some([x, y, _])) =
        (machine.kinematics, machine.kinematic_axes)
    {
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
            return Err(MoveError::PolarCentre {
                distance: d,
                min_radius: machine.min_radius,
            });
        }
    }
    Ok(())
}

/// Points per millimetre of a move at which an arm's reach is checked, and
/// the most per move: the kinematics' singularity margins are far wider
/// than a millimetre's worth of joint motion.
const REACH_PER_MM: f64 = 1.0;
const REACH_MAX_POINTS: usize = 4096;

/// Whether every point of the straight move from `a` to `b` is within the
/// kinematics' reach, clear of singularities (every kinematics whose joints
/// are not linear and whose reach is limited: arms, linkages, deltas).
fn check_reach(kin: KinematicsKind, a: Xyz, b: Xyz) -> Result<(), MoveError> {
    if kin.joints().is_empty() || kin.linear(0).is_some() || !kin.limited_reach() {
        return Ok(());
    }
    let length = (0..3).map(|i| (b[i] - a[i]).powi(2)).sum::<f64>().sqrt();
    let n = ((length * REACH_PER_MM).ceil() as usize).clamp(1, REACH_MAX_POINTS);
    for k in 0..=n {
        let t = k as f64 / n as f64;
        let p = [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t);
        if let Err(why) = kin.reach(p) {
            return Err(MoveError::Unreachable {
                at: p,
                dims: kin.joints().len().clamp(2, 3),
                why,
                kinematics: kin.name(),
            });
        }
    }
    Ok(())
}

/// `(x, y)` or `(x, y, z)`, rounded for messages.
fn show_point(p: &[f64]) -> String {
    let parts: Vec<String> = p.iter().map(|v| rounded(*v).to_string()).collect();
    format!("({})", parts.join(", "))
}
