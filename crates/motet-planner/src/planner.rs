//! Lookahead planning: commands in, time-stamped segments and tool events out.
//!
//! Each move gets a speed cap (feed, axis and joint limits after kinematics), an
//! acceleration (the tightest axis or joint along its direction) and a junction
//! cap (junction deviation with the previous move). A backward pass from the end
//! of the queue (which must end at rest) and a forward pass from the front give
//! entry and exit speeds. A move is emitted as soon as more moves can no longer
//! change its exit speed, so planning a stream one command at a time gives the
//! same trajectory, bit for bit, as planning the whole job at once.

use crate::command::{AuxChannel, Command, Move, MoveKind};
use crate::limits::Limits;
use crate::ranges::{self, OutOfRange};
use motet_trajectory::kinematics::JointPath;
use motet_trajectory::point::distance_masked;
use motet_trajectory::profile::{fastest, reachable_entry, reachable_speed};
use motet_trajectory::{JointMap, Point, Profile, ProfileKind, Segment, MAX_AXES};
use std::collections::VecDeque;

/// Most pieces [`Limits::max_move_s`] splits one move into.
const MAX_PIECES: usize = 10_000;
/// A tool output changing value at a time on the trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolEvent {
    /// Microseconds on the host clock.
    pub time: f64,
    /// Index into the machine's tools ([`crate::Limits::tools`]).
    pub tool: u8,
    /// The output's new value, `0.0..=1.0`.
    pub value: f32,
    /// When set, the output is `value × speed / feed` (capped at `value`): power
    /// that follows the actual speed along the path.
    pub per_speed: Option<f64>,
}

/// An auxiliary channel changing value (temperature, fan, coolant).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AuxEvent {
    /// Microseconds on the host clock. A waiting change comes when
    /// everything before it has come to rest; any other one at the start of
    /// the move after it.
    pub time: f64,
    /// Which output.
    pub channel: AuxChannel,
    /// Its new value, in the channel's unit.
    pub value: f32,
    /// Motion holds until the channel reaches the value.
    pub wait: bool,
}

/// What the planner produces, in time order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // segments are the common case; boxing them would cost an allocation each
pub enum Planned {
    /// A move or a dwell (a segment of length 0), starting where the last
    /// one ended in time and place.
    Segment(Segment),
    /// A tool output change.
    Event(ToolEvent),
    /// An auxiliary channel change.
    Aux(AuxEvent),
    /// The machine is at rest and waits for the person; `optional` pauses (M1)
    /// may be skipped.
    Pause {
        /// Microseconds on the host clock: the end of everything before.
        time: f64,
        /// From an optional stop (M1; see [`Command::Pause`]).
        optional: bool,
    },
}

/// A change that happens where the next move starts.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Loose {
    Tool(u8, f32, Option<f64>),
    Aux(AuxChannel, f32),
}

/// Why the planner refused a command. A refused command leaves the plan as
/// it was (everything queued before it stays); the planner does not know
/// where the command came from, so the caller adds its place
/// ([`crate::Located`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// A move's target has a NaN or infinite coordinate.
    #[error("target coordinate {axis} is not a finite number")]
    NotFinite {
        /// Index of the axis, as in [`crate::JobTarget::axes`].
        axis: usize,
    },
    /// A feed move's or per-speed tool's feed is zero, negative or NaN.
    #[error("feed must be a positive number (got {0})")]
    BadFeed(f64),
    /// A coordinate or dwell outside what motet accepts
    /// ([`crate::ranges`]).
    #[error(transparent)]
    OutOfRange(#[from] OutOfRange),
    /// A tool index the machine has no tool for.
    #[error("tool {0} is not on this machine")]
    UnknownTool(u8),
    /// The limits leave the move no speed or acceleration: a joint's rate
    /// is unbounded along it.
    #[error("the move cannot be made within the joint limits (it passes through a kinematic singularity, such as the polar centre)")]
    Singular,
    /// The plan would last longer than [`ranges::JOB_S`].
    #[error("{}", too_long(*at_least_s))]
    TooLong {
        /// A lower bound of how long the plan would last with the command,
        /// seconds (infinite when it cannot be bounded).
        at_least_s: f64,
    },
}

fn too_long(at_least_s: f64) -> String {
    let limit = format!(
        "motet plans at most {} h ({} days)",
        ranges::JOB_S.max / 3600.0,
        ranges::JOB_S.max / 86_400.0
    );
    if at_least_s.is_finite() {
        let h = (at_least_s / 3600.0).ceil();
        let h = if h < 1e7 {
            format!("{h}")
        } else {
            format!("{h:.1e}")
        };
        format!("the job would last at least {h} h by here; {limit}")
    } else {
        format!("the job would last for ever by here; {limit}")
    }
}

/// A move waiting for its speeds.
#[derive(Clone, Debug)]
struct Pending {
    start: Point,
    end: Point,
    length: f64,
    /// Length over speed cap, µs: the least time the move can take.
    min_us: f64,
    /// Direction per unit length, all axes (used for junctions).
    unit: Point,
    v_cap: f64,
    accel: f64,
    jerk: f64,
    /// Cap on the entry speed from the junction with the previous move.
    entry_cap: f64,
    /// Cap on the entry speed from the stop horizon.
    horizon_cap: f64,
    /// Whether all the moves of the horizon are queued; otherwise the cap may
    /// still rise when more moves arrive.
    horizon_complete: bool,
    /// Entry speed from the latest backward pass.
    entry: f64,
    /// Whether `entry` is held down by the queue's end rather than by a cap;
    /// such a value may still rise when more moves arrive.
    end_limited: bool,
    /// Inline changes that happen where this move starts.
    events: Vec<Loose>,
}

/// Plans commands pushed one at a time into segments and events popped in
/// time order. Holds back at most [`Limits::lookahead`] moves (at least 2)
/// for lookahead; after [`Planner::finish`] everything is emitted, ending at
/// rest. Deterministic: the same commands and limits give the same
/// segments bit for bit, however they are split between pushes.
pub struct Planner {
    limits: Limits,
    path_mask: u8,
    queue: VecDeque<Pending>,
    /// Where the last queued move ends.
    tail: Point,
    /// Exit speed of the last emitted move (entry of `queue[0]`).
    emitted_exit: f64,
    /// Host time at the end of everything emitted, µs.
    clock: f64,
    /// Host time the plan started at, µs: the plan may run [`ranges::JOB_S`]
    /// from here.
    t_start: f64,
    /// The least time the queued moves can take (length over speed cap), µs:
    /// with `clock`, a lower bound of where the plan ends.
    queued_min_us: f64,
    /// Where everything emitted ends.
    emitted_pos: Point,
    out: VecDeque<Planned>,
    /// Inline events with no move after them yet.
    loose_events: Vec<Loose>,
    /// A stop is required before the next move (after a dwell or stopping tool).
    stopped: bool,
}

impl Planner {
    /// A planner for a machine at rest at `start`, with the clock at `t0` µs.
    pub fn new(limits: Limits, start: Point, t0: f64) -> Planner {
        let path_mask = limits.path_mask();
        Planner {
            limits,
            path_mask,
            queue: VecDeque::new(),
            tail: start,
            emitted_exit: 0.0,
            clock: t0,
            t_start: t0,
            queued_min_us: 0.0,
            emitted_pos: start,
            out: VecDeque::new(),
            loose_events: Vec::new(),
            stopped: true,
        }
    }

    /// The limits it plans within.
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// Plans the moves pushed from now on with this shortest move time,
    /// seconds ([`Limits::min_move_s`]): a networked run slows what it has
    /// not planned yet when the host falls behind. Moves already pushed
    /// keep theirs.
    pub fn set_min_move_s(&mut self, min_move_s: f64) {
        self.limits.min_move_s = min_move_s;
    }

    /// Host time at the end of everything emitted so far, µs.
    pub fn clock(&self) -> f64 {
        self.clock
    }

    /// Where the machine will be after every queued command.
    pub fn tail(&self) -> Point {
        self.tail
    }

    /// Adds a command. Output becomes available through [`Planner::pop`].
    pub fn push(&mut self, cmd: &Command) -> Result<(), PlanError> {
        match *cmd {
            Command::Move(ref m) => self.push_move(m),
            Command::Dwell { seconds } => {
                ranges::DWELL_S.check("dwell", seconds)?;
                self.fits(seconds * 1e6)?;
                self.flush();
                self.emit_loose_events();
                if seconds > 0.0 {
                    self.emit_dwell(seconds);
                }
                Ok(())
            }
            Command::Tool { tool, value } => self.push_tool(tool, value, None),
            Command::ToolPerSpeed { tool, value, feed } => {
                if feed.is_nan() || feed <= 0.0 {
                    return Err(PlanError::BadFeed(feed));
                }
                self.push_tool(tool, value, Some(feed))
            }
            Command::Aux {
                channel,
                value,
                wait,
            } => {
                if wait {
                    self.flush();
                    self.emit_loose_events();
                    let time = self.clock;
                    self.out.push_back(Planned::Aux(AuxEvent {
                        time,
                        channel,
                        value,
                        wait,
                    }));
                } else {
                    self.loose_events.push(Loose::Aux(channel, value));
                }
                Ok(())
            }
            Command::Pause { optional } => {
                self.flush();
                self.emit_loose_events();
                self.out.push_back(Planned::Pause {
                    time: self.clock,
                    optional,
                });
                Ok(())
            }
            Command::Sync => {
                self.flush();
                self.emit_loose_events();
                Ok(())
            }
        }
    }

    fn push_tool(&mut self, tool: u8, value: f32, per_speed: Option<f64>) -> Result<(), PlanError> {
        let timing = *self
            .limits
            .tools
            .get(tool as usize)
            .ok_or(PlanError::UnknownTool(tool))?;
        if timing.stop {
            self.fits(timing.settle * 1e6)?;
            self.flush();
            self.emit_loose_events();
            let time = self.clock;
            self.out.push_back(Planned::Event(ToolEvent {
                time,
                tool,
                value,
                per_speed,
            }));
            if timing.settle > 0.0 {
                self.emit_dwell(timing.settle);
            }
        } else {
            self.loose_events.push(Loose::Tool(tool, value, per_speed));
        }
        Ok(())
    }

    /// Ends the job: everything queued is planned to come to rest.
    pub fn finish(&mut self) {
        self.flush();
        self.emit_loose_events();
    }

    /// The next planned segment or event, in time order.
    pub fn pop(&mut self) -> Option<Planned> {
        self.out.pop_front()
    }

    /// Number of commands held for lookahead.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    fn push_move(&mut self, m: &Move) -> Result<(), PlanError> {
        let pieces = self.pieces(m);
        if pieces <= 1 {
            return self.push_piece(m);
        }
        // Straight pieces of the same move: collinear junctions keep the
        // speed, so the profile is the move's own, in shorter segments.
        let start = self.tail;
        for k in 1..=pieces {
            let mut piece = *m;
            if k < pieces {
                let f = k as f64 / pieces as f64;
                for (t, (a, b)) in piece.target.iter_mut().zip(start.iter().zip(&m.target)) {
                    *t = a + (b - a) * f;
                }
            }
            self.push_piece(&piece)?;
        }
        Ok(())
    }

    /// Into how many pieces [`Limits::max_move_s`] splits a move: its
    /// length over the farthest it can go in that time (at its feed, or at
    /// every path axis's top speed at once: a move never goes faster).
    fn pieces(&self, m: &Move) -> usize {
        if self.limits.max_move_s <= 0.0 {
            return 1;
        }
        let length = distance_masked(&self.tail, &m.target, self.path_mask);
        let top = self
            .limits
            .axes
            .iter()
            .filter(|a| a.path)
            .map(|a| a.max_velocity * a.max_velocity)
            .sum::<f64>()
            .sqrt();
        let speed = match m.kind {
            MoveKind::Rapid => top.min(rapid_cap(m.feed)),
            MoveKind::Feed => m.feed.min(top),
        };
        let reach = speed * self.limits.max_move_s;
        if !(length.is_finite() && reach > 0.0 && reach.is_finite()) {
            return 1;
        }
        // Bounded: a job of endless pieces is not what the limit is for.
        (length / reach).ceil().clamp(1.0, MAX_PIECES as f64) as usize
    }

    fn push_piece(&mut self, m: &Move) -> Result<(), PlanError> {
        for (axis, v) in m.target.iter().enumerate() {
            if !v.is_finite() {
                return Err(PlanError::NotFinite { axis });
            }
            ranges::RIDING_COORDINATE.check(format_args!("coordinate {axis}"), *v)?;
        }
        let feed = match m.kind {
            MoveKind::Rapid => rapid_cap(m.feed),
            MoveKind::Feed => {
                if m.feed.is_nan() || m.feed <= 0.0 {
                    return Err(PlanError::BadFeed(m.feed));
                }
                m.feed
            }
        };
        let start = self.tail;
        let end = m.target;
        let mut length = distance_masked(&start, &end, self.path_mask);
        if length <= 1e-9 {
            // Moves of riding axes only (a retraction) measure their own length.
            length = distance_masked(&start, &end, 0xff);
        }
        if length <= 1e-9 {
            return Ok(());
        }
        let mut unit = [0.0; MAX_AXES];
        for i in 0..MAX_AXES {
            unit[i] = (end[i] - start[i]) / length;
        }
        let (v_cap, accel, jerk) = self.move_limits(&start, &end, &unit, length, feed);
        if !(v_cap > 0.0 && accel > 0.0 && accel.is_finite()) {
            return Err(PlanError::Singular);
        }
        // No faster than its cap: a lower bound of the time the move takes.
        let min_us = length / v_cap * 1e6;
        self.fits(min_us)?;
        let entry_cap = match self.queue.back() {
            Some(prev) if !self.stopped => self.junction_speed(prev, &unit, v_cap, accel),
            _ => 0.0,
        };
        self.stopped = false;
        self.tail = end;
        let events = std::mem::take(&mut self.loose_events);
        self.queued_min_us += min_us;
        self.queue.push_back(Pending {
            start,
            end,
            length,
            min_us,
            unit,
            v_cap,
            accel,
            jerk,
            entry_cap,
            horizon_cap: f64::INFINITY,
            horizon_complete: true,
            entry: 0.0,
            end_limited: true,
            events,
        });
        self.update_horizons();
        self.backward_pass();
        self.emit_final();
        if self.queue.len() > self.limits.lookahead.max(2) {
            self.emit_front_as_is();
        }
        Ok(())
    }

    /// Refuses a command that would make the plan last longer than
    /// [`ranges::JOB_S`] (checked before anything changes, so a refused
    /// command leaves the plan as it was). Past that, time stamps would
    /// lose the resolution the nodes need.
    fn fits(&self, extra_us: f64) -> Result<(), PlanError> {
        let end = self.clock + self.queued_min_us + extra_us - self.t_start;
        if end <= ranges::JOB_S.max * 1e6 {
            Ok(())
        } else {
            Err(PlanError::TooLong {
                at_least_s: end * 1e-6,
            })
        }
    }

    /// Speed cap, acceleration and jerk for a move along `unit`.
    fn move_limits(
        &self,
        start: &Point,
        end: &Point,
        unit: &Point,
        length: f64,
        feed: f64,
    ) -> (f64, f64, f64) {
        let mut v = feed;
        let mut a = f64::INFINITY;
        let mut j = f64::INFINITY;
        for (i, lim) in self.limits.axes.iter().enumerate().take(MAX_AXES) {
            let u = unit[i].abs();
            if u > 0.0 {
                v = v.min(lim.max_velocity / u);
                a = a.min(lim.max_acceleration / u);
                if let Some(mj) = lim.max_jerk {
                    j = j.min(mj / u);
                }
            }
        }
        for jl in &self.limits.joints {
            if let JointMap::Linear { coeffs } = jl.map {
                // A linear joint moves at a constant rate along the line:
                // its coefficients projected on the direction.
                let rate = coeffs
                    .iter()
                    .zip(unit)
                    .map(|(c, u)| c * u)
                    .sum::<f64>()
                    .abs();
                if rate > 0.0 {
                    v = v.min(jl.max_velocity / rate);
                    a = a.min(jl.max_acceleration / rate);
                }
            } else {
                let path = JointPath::between(&jl.map, start, end, length, 0.0);
                let rate = path.max_rate(0.0, length);
                if rate > 0.0 {
                    v = v.min(jl.max_velocity / rate);
                }
                // joint'' = rate · a + curvature · v²: give each term half the budget.
                if rate > 0.0 {
                    a = a.min(0.5 * jl.max_acceleration / rate);
                }
                let curv = path.max_curvature(0.0, length);
                if curv > 0.0 {
                    v = v.min((0.5 * jl.max_acceleration / curv).sqrt());
                }
            }
        }
        if self.limits.min_move_s > 0.0 {
            v = v.min(length / self.limits.min_move_s);
        }
        let jerk = match self.limits.profile {
            ProfileKind::Trapezoid => 0.0,
            ProfileKind::SCurve if j.is_finite() => j,
            // No jerk limit on any moving axis: plain ramps.
            ProfileKind::SCurve => 0.0,
        };
        (v, a, jerk)
    }

    /// grbl's junction deviation: the speed at which a circle of deviation `δ`
    /// tangent to both moves is taken at acceleration `a`.
    fn junction_speed(&self, prev: &Pending, unit: &Point, v_cap: f64, accel: f64) -> f64 {
        let norm = |u: &Point| u.iter().map(|x| x * x).sum::<f64>().sqrt();
        let (n0, n1) = (norm(&prev.unit), norm(unit));
        let dot: f64 = prev.unit.iter().zip(unit).map(|(a, b)| a * b).sum();
        let cos = -dot / (n0 * n1);
        let cap = prev.v_cap.min(v_cap);
        if cos <= -0.999_999 {
            // Straight on.
            return cap;
        }
        if cos >= 0.999_999 {
            // Full reversal.
            return 0.0;
        }
        let sin_half = (0.5 * (1.0 - cos)).sqrt();
        let a = prev.accel.min(accel);
        let v2 = a * self.limits.junction_deviation * sin_half / (1.0 - sin_half);
        v2.sqrt().min(cap)
    }

    /// Recomputes the stop-horizon caps of the moves whose horizon reaches the
    /// newest move. Each sum runs in queue order over its own window, so the
    /// cap is the same whenever it is computed.
    fn update_horizons(&mut self) {
        let h = self.limits.stop_horizon;
        if h == 0 {
            return;
        }
        let n = self.queue.len();
        for k in n.saturating_sub(h)..n {
            let last = (k + h).min(n);
            let mut sum = 0.0;
            for j in k..last {
                let m = &self.queue[j];
                sum += m.accel * m.length;
            }
            let m = &mut self.queue[k];
            m.horizon_cap = (2.0 * sum).sqrt();
            m.horizon_complete = k + h <= n;
        }
    }

    /// Recomputes entry speeds from the end of the queue (which ends at rest),
    /// stopping where nothing changes any more.
    fn backward_pass(&mut self) {
        let mut exit = 0.0;
        let mut exit_end_limited = true;
        let n = self.queue.len();
        // Moves whose horizon cap the newest move changed are always revisited.
        let revisit = self.limits.stop_horizon.max(1);
        for k in (0..n).rev() {
            let fixed_entry = k == 0;
            let m = &mut self.queue[k];
            // Entries are fixed before exits stop rising: every exit from
            // this one up must stay reachable (S-curve ramps down are not
            // monotone in their end speed).
            let reach = reachable_entry(exit, m.length, m.accel, m.jerk);
            // An incomplete horizon's cap may still rise, like a speed held
            // down by the queue's end.
            let (cap, cap_end_limited) = if m.horizon_cap < m.entry_cap {
                (m.horizon_cap, !m.horizon_complete)
            } else {
                (m.entry_cap, false)
            };
            let (entry, end_limited) = if fixed_entry {
                (self.emitted_exit, false)
            } else if cap <= reach {
                (cap, cap_end_limited)
            } else {
                (reach, exit_end_limited)
            };
            if k + revisit < n && entry == m.entry && end_limited == m.end_limited {
                break;
            }
            m.entry = entry;
            m.end_limited = end_limited;
            exit = entry;
            exit_end_limited = end_limited;
        }
    }

    /// Emits moves from the front whose exit speed can no longer change.
    fn emit_final(&mut self) {
        while self.queue.len() >= 2 {
            let (entry, length, accel, jerk) = {
                let m = &self.queue[0];
                (self.emitted_exit, m.length, m.accel, m.jerk)
            };
            let next = &self.queue[1];
            let forward = reachable_speed(entry, length, accel, jerk);
            let exit = forward.min(next.entry);
            if forward > next.entry && next.end_limited {
                break;
            }
            self.emit_front(exit);
        }
    }

    /// Emits the front move with the exit the current queue allows (the queue's
    /// end counted as a stop): always safe, possibly slower than optimal.
    fn emit_front_as_is(&mut self) {
        let m = &self.queue[0];
        let forward = reachable_speed(self.emitted_exit, m.length, m.accel, m.jerk);
        let exit = if self.queue.len() >= 2 {
            forward.min(self.queue[1].entry)
        } else {
            0.0
        };
        self.emit_front(exit);
        self.emit_final();
    }

    fn emit_front(&mut self, exit: f64) {
        let m = self
            .queue
            .pop_front()
            .expect("emit_front on an empty queue");
        self.queued_min_us = if self.queue.is_empty() {
            0.0
        } else {
            (self.queued_min_us - m.min_us).max(0.0)
        };
        for e in &m.events {
            self.emit_loose(*e);
        }
        let entry = self.emitted_exit;
        // Rounding can leave the exit a hair above what the move can reach.
        let exit = exit.min(reachable_speed(entry, m.length, m.accel, m.jerk));
        let profile = fastest(
            m.length,
            entry,
            exit,
            m.v_cap.max(entry).max(exit),
            m.accel,
            m.jerk,
        );
        let seg = Segment {
            t0: self.clock,
            start: m.start,
            end: m.end,
            profile,
        };
        self.clock = seg.t1();
        self.emitted_pos = m.end;
        self.emitted_exit = exit;
        if let Some(next) = self.queue.front_mut() {
            next.entry = exit;
        }
        self.out.push_back(Planned::Segment(seg));
    }

    /// Plans everything queued to end at rest.
    fn flush(&mut self) {
        while !self.queue.is_empty() {
            if self.queue.len() == 1 {
                self.emit_front(0.0);
            } else {
                // The backward pass already assumed a stop at the end.
                let m = &self.queue[0];
                let forward = reachable_speed(self.emitted_exit, m.length, m.accel, m.jerk);
                let exit = forward.min(self.queue[1].entry);
                self.emit_front(exit);
            }
        }
        self.stopped = true;
    }

    fn emit_loose_events(&mut self) {
        for e in std::mem::take(&mut self.loose_events) {
            self.emit_loose(e);
        }
    }

    fn emit_loose(&mut self, e: Loose) {
        let time = self.clock;
        self.out.push_back(match e {
            Loose::Tool(tool, value, per_speed) => Planned::Event(ToolEvent {
                time,
                tool,
                value,
                per_speed,
            }),
            Loose::Aux(channel, value) => Planned::Aux(AuxEvent {
                time,
                channel,
                value,
                wait: false,
            }),
        });
    }

    fn emit_dwell(&mut self, seconds: f64) {
        let seg = Segment {
            t0: self.clock,
            start: self.emitted_pos,
            end: self.emitted_pos,
            profile: Profile::dwell(seconds),
        };
        self.clock = seg.t1();
        self.out.push_back(Planned::Segment(seg));
    }
}

/// A rapid's speed cap: its `feed` when finite and positive (a rapid
/// override), else none (the axes' limits alone).
fn rapid_cap(feed: f64) -> f64 {
    if feed.is_finite() && feed > 0.0 {
        feed
    } else {
        f64::INFINITY
    }
}
