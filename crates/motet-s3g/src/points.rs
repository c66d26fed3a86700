//! From motet's plan to an S3G bot's queued points: which machine axis is
//! which bot axis, and each planned segment cut into points with durations
//! (command 142) that the bot runs at constant rate.
//!
//! Every point is a planned position at a whole microsecond of the plan's
//! clock: its duration is the difference of two such times, so the bot's
//! running sum of durations is the plan's time of the point exactly, and
//! its step position is the planned position there rounded to steps
//! (within half a step). Ramps are cut finely enough that running each
//! piece at constant speed stays within [`PIECE_TOLERANCE_MM`] of the plan
//! between points.

use crate::command::{Command, PointNew};
use motet_host::Machine;
use motet_planner::{AuxChannel, AuxEvent, Planned};
use motet_trajectory::{JointMap, Point, Segment};
use std::collections::VecDeque;

/// The bot's axes, in packet order.
pub const BOT_AXES: [&str; 5] = ["X", "Y", "Z", "A", "B"];

/// The machine axis each bot axis takes: x y z, the extruder e on A, b on B.
const MACHINE_AXES: [&str; 5] = ["x", "y", "z", "e", "b"];

/// How far a ramp run at constant speed between two points may stray from
/// the planned ramp, mm (a · dt² / 8 for each piece).
pub const PIECE_TOLERANCE_MM: f64 = 0.01;

/// The shortest and longest piece between points, µs.
const PIECE_US: [f64; 2] = [2_000.0, 1_000_000.0];

/// A machine that cannot be an S3G bot.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MapError {
    /// An axis the bot has no place for.
    #[error("axis `{0}`: an S3G bot's axes are X Y Z A B, motet's x y z e b")]
    Axis(String),
    /// A joint that mixes axes, or is not an axis at all.
    #[error("actuator `{0}`: an S3G bot steps each of its axes alone; describe the machine as cartesian (one actuator per axis)")]
    NotAxis(String),
    /// Two actuators on one axis.
    #[error("actuators `{0}` and `{1}` both drive axis `{2}`: an S3G bot has one motor per axis")]
    Shared(String, String, String),
    /// Tools with outputs motet would have to switch.
    #[error("tool `{0}`: S3G bots have no pen, laser or spindle output motet can drive")]
    Tool(String),
}

/// Which bot axis each machine axis is, and its steps per unit.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisMap {
    /// For each bot axis: the machine axis and its steps per unit.
    pub slots: [Option<(usize, f64)>; 5],
}

impl AxisMap {
    /// The map of a machine, or why it cannot be a bot.
    pub fn of(machine: &Machine) -> Result<AxisMap, MapError> {
        if let Some(t) = machine.tools.first() {
            return Err(MapError::Tool(t.name.clone()));
        }
        let mut slots: [Option<(usize, f64)>; 5] = [None; 5];
        let mut owner: [Option<&str>; 5] = [None; 5];
        for a in &machine.actuators {
            let JointMap::Linear { coeffs } = machine.joints[a.joint].map else {
                return Err(MapError::NotAxis(a.name.clone()));
            };
            let mut used = coeffs.iter().enumerate().filter(|(_, c)| **c != 0.0);
            let (Some((axis, &c)), None) = (used.next(), used.next()) else {
                return Err(MapError::NotAxis(a.name.clone()));
            };
            let name = &machine.axes[axis].name;
            let slot = MACHINE_AXES
                .iter()
                .position(|n| n == name)
                .ok_or_else(|| MapError::Axis(name.clone()))?;
            if let Some(other) = owner[slot] {
                return Err(MapError::Shared(other.into(), a.name.clone(), name.clone()));
            }
            owner[slot] = Some(&a.name);
            slots[slot] = Some((axis, a.steps_per_unit * c));
        }
        if let Some(ax) = machine
            .axes
            .iter()
            .enumerate()
            .find(|(i, _)| !slots.iter().flatten().any(|s| s.0 == *i))
        {
            return Err(MapError::Axis(ax.1.name.clone()));
        }
        Ok(AxisMap { slots })
    }

    /// A machine-space point in the bot's steps, rounded.
    pub fn steps(&self, p: &Point) -> [i32; 5] {
        std::array::from_fn(|i| match self.slots[i] {
            Some((axis, spu)) => (p[axis] * spu).round() as i32,
            None => 0,
        })
    }
}

/// The bot's tool and heater commands for an auxiliary change; `None`
/// for channels a bot does not have (chamber, coolant).
pub fn aux_commands(e: &AuxEvent) -> Option<Vec<Command>> {
    use crate::tool::{sub, Heater};
    let temp = |h: Heater| {
        let c = e.value.round().clamp(0.0, i16::MAX as f32) as i16;
        let mut v = vec![Command::ToolAction {
            tool: h.tool(),
            sub: h.set_temp(),
            data: c.to_le_bytes().to_vec(),
        }];
        // The bot holds its queue until the heater is there; the host keeps
        // polling buffer room (and temperatures) meanwhile.
        if e.wait {
            let (tool, ping_ms, timeout_s) = (h.tool(), 100, u16::MAX);
            v.push(match h {
                Heater::Tool(_) => Command::WaitForTool {
                    tool,
                    ping_ms,
                    timeout_s,
                },
                Heater::Platform => Command::WaitForPlatform {
                    tool,
                    ping_ms,
                    timeout_s,
                },
            });
        }
        v
    };
    match e.channel {
        AuxChannel::Hotend(i) => Some(temp(Heater::Tool(i))),
        AuxChannel::Bed => Some(temp(Heater::Platform)),
        AuxChannel::Fan(i) => Some(vec![Command::ToolAction {
            tool: i,
            sub: sub::TOGGLE_VALVE,
            data: vec![u8::from(e.value > 0.0)],
        }]),
        _ => None,
    }
}

/// Cuts planned segments into points; keeps the bot's clock (the sum of
/// the durations sent) and the last step position sent.
#[derive(Debug)]
pub struct Emitter {
    map: AxisMap,
    /// The bot's clock: µs of motion and delays sent, from the plan's 0.
    sent_us: i64,
    /// Steps of the last point sent.
    at: [i32; 5],
    /// Recent segments, for point times that fall in an earlier one.
    recent: VecDeque<Segment>,
}

impl Emitter {
    /// An emitter for a bot that rests at `start`, on the plan's clock at 0.
    pub fn new(map: AxisMap, start: &Point) -> Emitter {
        let at = map.steps(start);
        Emitter {
            map,
            sent_us: 0,
            at,
            recent: VecDeque::new(),
        }
    }

    /// The step position the bot is given first (command 140).
    pub fn start_steps(&self) -> [i32; 5] {
        self.at
    }

    /// The bot's clock after everything emitted, µs.
    pub fn clock_us(&self) -> i64 {
        self.sent_us
    }

    /// The commands for one planned segment (points, or a delay).
    pub fn segment(&mut self, seg: &Segment, out: &mut Vec<Command>) {
        if seg.profile.length() <= 0.0 {
            let delay_ms = (seg.t1().floor() as i64 - self.sent_us) / 1000;
            if delay_ms > 0 {
                out.push(Command::Delay(delay_ms.min(u32::MAX as i64) as u32));
                self.sent_us += delay_ms * 1000;
            }
            return;
        }
        self.recent.push_back(*seg);
        while self.recent.len() > 8 {
            self.recent.pop_front();
        }
        for i in 0..motet_trajectory::profile::PIECES {
            let piece = seg.profile.piece(i);
            if piece.duration <= 0.0 {
                continue;
            }
            let span_us = piece.duration * 1e6;
            let accel = piece.a.abs() + piece.j.abs() * piece.duration;
            let max_us = if accel > 0.0 {
                (8.0 * PIECE_TOLERANCE_MM / accel).sqrt() * 1e6
            } else {
                PIECE_US[1]
            };
            let n = (span_us / max_us.clamp(PIECE_US[0], PIECE_US[1]))
                .ceil()
                .max(1.0) as usize;
            for k in 1..=n {
                let t = seg.t0 + (piece.t0 + piece.duration * k as f64 / n as f64) * 1e6;
                self.point_at(t.min(seg.t1()).floor(), out);
            }
        }
    }

    /// A point at whole µs `t` of the plan, unless no time or no step
    /// separates it from the last (its time then goes to the next point).
    fn point_at(&mut self, t: f64, out: &mut Vec<Command>) {
        let ti = t as i64;
        if ti <= self.sent_us {
            return;
        }
        let Some(seg) = self.recent.iter().rev().find(|s| s.t0 <= t) else {
            return;
        };
        let steps = self.map.steps(&seg.position_at(t));
        if steps == self.at {
            return;
        }
        let us = (ti - self.sent_us).min(u32::MAX as i64) as u32;
        out.push(Command::PointNew(PointNew {
            steps,
            us,
            relative: 0,
        }));
        self.sent_us += us as i64;
        self.at = steps;
    }

    /// The commands for one planned item (a segment, an auxiliary change);
    /// tool events and pauses are the driver's.
    pub fn planned(&mut self, p: &Planned, out: &mut Vec<Command>) {
        match p {
            Planned::Segment(s) => self.segment(s, out),
            Planned::Aux(a) => out.extend(aux_commands(a).unwrap_or_default()),
            Planned::Event(_) | Planned::Pause { .. } => {}
        }
    }
}
