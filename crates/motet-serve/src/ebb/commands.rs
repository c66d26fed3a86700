//! Each command the board takes: its parameters checked (arity, ranges),
//! then acted on. Motion and the pen go into the session's stream; the
//! rest is the board's own state.

use super::parse::Line;
use super::ramp::{self, AxisMove};
use super::reply::{EbbError, Ending};
use super::{Ebb, Step, VERSION};
use crate::session::{ActionError, Session, State};
use motet_planner::{Command, Located, Move, MoveKind};

const I32: (i64, i64) = (i32::MIN as i64, i32::MAX as i64);
const U32: i64 = u32::MAX as i64;
/// The board's fastest step rate, steps/s.
const MAX_RATE: i64 = 25_000;
/// The slowest feed the planner takes, mm/s: slower moves run at it.
const MIN_FEED: f64 = 1e-3;
/// The longest `LT`/`T3` move taken, ticks (a minute).
const MAX_TICKS: i64 = 25_000 * 60;

impl Ebb {
    pub(super) fn command(&mut self, l: &Line, s: &mut Session) -> Result<Step, EbbError> {
        let sy = self.syntax;
        let ok = || Ok(Step::Reply(sy.ok(&l.name)));
        match l.name.as_str() {
            "V" => {
                l.arity(0, 0)?;
                Ok(Step::Reply(sy.data("V", VERSION, Ending::Norm, false)))
            }
            "CU" => {
                l.arity(2, 0)?;
                let p = l.req(0, 0, 255)?;
                let v = l.req(1, I32.0, I32.1)?;
                if p == 10 {
                    self.syntax = if v == 1 {
                        super::Syntax::Future
                    } else {
                        super::Syntax::Legacy
                    };
                }
                Ok(Step::Reply(self.syntax.ok("CU")))
            }
            "CS" => {
                l.arity(0, 0)?;
                self.steps.counters = [0, 0];
                self.steps.accum = [0, 0];
                ok()
            }
            "EM" => {
                l.arity(1, 1)?;
                let m1 = l.req(0, 0, 5)?;
                let m2 = l.int(1, 0, 5)?.unwrap_or(self.motors[1]);
                self.motors = [m1, m2];
                self.steps.set_mode(m1);
                ok()
            }
            "SC" => {
                l.arity(2, 0)?;
                let p = l.req(0, 0, 255)?;
                let v = l.req(1, 0, 65_535)?;
                self.servo.insert(p, v);
                ok()
            }
            "SR" => {
                l.arity(1, 1)?;
                self.servo_timeout_ms = l.req(0, 0, U32)?;
                if let Some(st) = l.int(1, 0, 1)? {
                    self.servo_power = st == 1;
                }
                ok()
            }
            "SL" => {
                l.arity(1, 1)?;
                let v = l.req(0, 0, 255)?;
                let i = l.int(1, 0, 31)?.unwrap_or(0);
                self.vars[i as usize] = v as u8;
                ok()
            }
            "ST" => {
                l.arity(0, 1)?;
                let name = l.params.first().cloned().unwrap_or_default();
                if name.len() > 16 {
                    return Err(EbbError::Invalid);
                }
                self.nickname = name;
                ok()
            }
            "PO" | "PD" => {
                l.arity(3, 0)?;
                let port = l.port(0)?;
                let pin = l.req(1, 0, 7)?;
                let v = l.req(2, 0, 1)?;
                if l.name == "PO" {
                    self.pins.insert((port, pin), v);
                }
                ok()
            }
            "R" => {
                l.arity(0, 0)?;
                ok()
            }
            "SP" => {
                l.arity(1, 2)?;
                let up = l.req(0, 0, 1)? == 1;
                let ms = l.int(1, 0, 65_535)?.unwrap_or(0);
                l.int(2, 0, 7)?;
                self.pen(up, ms, &l.name, s)
            }
            "TP" => {
                l.arity(0, 1)?;
                let ms = l.int(0, 0, 65_535)?.unwrap_or(0);
                self.pen(!self.pen_up, ms, &l.name, s)
            }
            "ES" => {
                l.arity(0, 1)?;
                l.int(0, 0, 1)?;
                Ok(Step::Reply(self.estop(s)))
            }
            "SM" | "XM" | "LM" | "LT" | "T3" | "HM" => self.motion(l, s),
            _ => self.query(l, s),
        }
    }

    /// A motion command: its steps and duration, then queued.
    fn motion(&mut self, l: &Line, s: &mut Session) -> Result<Step, EbbError> {
        self.next_accum = None;
        let (d, seconds) = match l.name.as_str() {
            "SM" => {
                l.arity(2, 2)?;
                let ms = l.req(0, 1, U32)?;
                let d = [
                    l.req(1, I32.0, I32.1)?,
                    l.int(2, I32.0, I32.1)?.unwrap_or(0),
                ];
                self.clear(l.int(3, 0, 3)?);
                (d, ms_of(ms, d))
            }
            "XM" => {
                l.arity(3, 1)?;
                let ms = l.req(0, 1, I32.1)?;
                let (a, b) = (l.req(1, I32.0, I32.1)?, l.req(2, I32.0, I32.1)?);
                let d = [a + b, a - b];
                if d.iter().any(|v| *v < I32.0 || *v > I32.1) {
                    return Err(EbbError::Invalid);
                }
                self.clear(l.int(3, 0, 3)?);
                (d, ms_of(ms, d))
            }
            "LM" => {
                l.arity(6, 1)?;
                let v: Vec<i64> = (0..6)
                    .map(|i| l.req(i, I32.0, I32.1))
                    .collect::<Result<_, _>>()?;
                let clear = l.int(6, 0, 3)?.unwrap_or(0);
                let m = [
                    ramp::lm(v[1], v[0], v[2], self.accum(clear, 0)),
                    ramp::lm(v[4], v[3], v[5], self.accum(clear, 1)),
                ];
                if m.iter().all(Option::is_none) {
                    return Err(EbbError::Invalid);
                }
                let m = m.map(|a| a.unwrap_or_default());
                self.ramped(m)?
            }
            "LT" | "T3" => {
                let t3 = l.name == "T3";
                let n = if t3 { 7 } else { 5 };
                l.arity(n, 1)?;
                let ticks = l.req(0, 1, MAX_TICKS)?;
                let v: Vec<i64> = (1..n)
                    .map(|i| l.req(i, I32.0, I32.1))
                    .collect::<Result<_, _>>()?;
                let clear = l.int(n, 0, 3)?.unwrap_or(0);
                let (a1, a2) = (self.accum(clear, 0), self.accum(clear, 1));
                let m = if t3 {
                    [
                        ramp::t3(ticks, v[0], v[1], v[2], a1),
                        ramp::t3(ticks, v[3], v[4], v[5], a2),
                    ]
                } else {
                    [
                        ramp::lt(ticks, v[0], v[1], a1),
                        ramp::lt(ticks, v[2], v[3], a2),
                    ]
                };
                self.ramped(m)?
            }
            _ => {
                l.arity(1, 2)?;
                let rate = l.req(0, 2, MAX_RATE)?;
                if l.params.len() == 2 {
                    return Err(EbbError::Missing);
                }
                let to = [
                    l.int(1, I32.0, I32.1)?.unwrap_or(0),
                    l.int(2, I32.0, I32.1)?.unwrap_or(0),
                ];
                self.steps.home_move(rate, to)
            }
        };
        // Faster than the board steps: `SM` takes longer, as the board
        // does; `XM` is refused, as the board refuses it.
        let fastest = d[0].abs().max(d[1].abs()) as f64 / MAX_RATE as f64;
        let seconds = match l.name.as_str() {
            "XM" if fastest > seconds => return Err(EbbError::StepRate),
            _ => seconds.max(fastest),
        };
        self.queue(&l.name, d, seconds, s)
    }

    /// An axis's accumulator for a move: `None` when `clear` clears it.
    fn accum(&self, clear: i64, k: usize) -> Option<i64> {
        (clear & (1 << k) == 0).then_some(self.steps.accum[k])
    }

    /// A rate move's steps and seconds; its accumulators are kept only
    /// once it is queued (see [`Ebb::queue`]).
    fn ramped(&mut self, m: [AxisMove; 2]) -> Result<([i64; 2], f64), EbbError> {
        self.next_accum = Some([m[0].accum, m[1].accum]);
        let ticks = m[0].ticks.max(m[1].ticks);
        Ok(([m[0].steps, m[1].steps], ticks as f64 / ramp::ISR_HZ))
    }

    /// `SM`/`XM`'s `Clear`: the accumulators it zeroes, kept once queued.
    fn clear(&mut self, c: Option<i64>) {
        let c = c.unwrap_or(0);
        let mut a = self.steps.accum;
        for (k, v) in a.iter_mut().enumerate() {
            if c & (1 << k) != 0 {
                *v = 0;
            }
        }
        self.next_accum = Some(a);
    }

    /// Whether the stream can take a block now: `Ok(false)` to wait.
    fn ready(&mut self, s: &mut Session) -> Result<bool, EbbError> {
        match s.state() {
            State::Stopping => return Ok(false),
            State::Stopped | State::Alarm if self.after_es => return Ok(false),
            State::Stopped | State::Alarm => return Err(EbbError::Invalid),
            State::Running | State::Holding | State::Paused if !s.streaming() => return Ok(false),
            _ => {}
        }
        if s.stream_status().blocks_free == 0 {
            return Ok(false);
        }
        if s.state() == State::Idle && !s.streaming() {
            // At rest with nothing queued: moved by something else (a jog,
            // the page) since the last move, the steps count from here.
            let rest = s.rest();
            let (x, y) = self.steps.point();
            let mut o = rest;
            o[self.x] -= x;
            o[self.y] -= y;
            self.origin = Some(o);
        }
        Ok(true)
    }

    /// Where the step counts put the tool, in machine coordinates.
    fn machine_point(&self, xy: (f64, f64)) -> motet_trajectory::Point {
        let mut p = self.origin.unwrap_or_default();
        p[self.x] += xy.0;
        p[self.y] += xy.1;
        p
    }

    /// Queues `d` steps over `seconds` as one block.
    fn queue(
        &mut self,
        name: &str,
        d: [i64; 2],
        seconds: f64,
        s: &mut Session,
    ) -> Result<Step, EbbError> {
        if !self.ready(s)? {
            return Ok(Step::Wait);
        }
        let from = self.machine_point(self.steps.point());
        let target = self.machine_point(self.steps.point_after(d));
        let dist = (target[self.x] - from[self.x]).hypot(target[self.y] - from[self.y]);
        let item = if d == [0, 0] {
            Command::Dwell {
                seconds: seconds.min(100.0),
            }
        } else {
            Command::Move(Move {
                target,
                feed: (dist / seconds.max(1e-6)).max(MIN_FEED),
                kind: MoveKind::Feed,
            })
        };
        match self.push(vec![item], from, s)? {
            false => Ok(Step::Wait),
            true => {
                self.steps.take(d);
                if let Some(a) = self.next_accum.take() {
                    self.steps.accum = a;
                }
                Ok(Step::Reply(self.syntax.ok(name)))
            }
        }
    }

    /// Pushes one block into the stream: `Ok(false)` when it must wait.
    fn push(
        &mut self,
        items: Vec<Command>,
        from: motet_trajectory::Point,
        s: &mut Session,
    ) -> Result<bool, EbbError> {
        let commands = items
            .into_iter()
            .map(|item| Located {
                loc: Default::default(),
                item,
            })
            .collect();
        match s.stream_push(commands, from) {
            Ok(()) => Ok(true),
            Err(ActionError::OutOfRange { .. }) => Ok(false),
            Err(ActionError::WrongState {
                state: State::Stopping,
                ..
            }) => Ok(false),
            // Beyond the machine's travel, or refused: the board's own
            // error for a value it cannot use; nothing was queued.
            Err(_) => Err(EbbError::Invalid),
        }
    }

    /// The pen up or down, then `ms` before the next motion (the machine's
    /// own settle time comes first).
    fn pen(&mut self, up: bool, ms: i64, name: &str, s: &mut Session) -> Result<Step, EbbError> {
        let Some(tool) = self.pen else {
            self.pen_up = up;
            return Ok(Step::Reply(self.syntax.ok(name)));
        };
        if !self.ready(s)? {
            return Ok(Step::Wait);
        }
        let settle = s
            .machine()
            .tools
            .get(tool as usize)
            .map_or(0.0, |t| t.settle);
        let mut items = vec![Command::Tool {
            tool,
            value: if up { 0.0 } else { 1.0 },
        }];
        let extra = ms as f64 / 1000.0 - settle;
        if extra > 0.0 {
            items.push(Command::Dwell { seconds: extra });
        }
        let from = self.machine_point(self.steps.point());
        if !self.push(items, from, s)? {
            return Ok(Step::Wait);
        }
        self.pen_up = up;
        Ok(Step::Reply(self.syntax.ok(name)))
    }

    /// `ES`: the machine brakes on its path and what was queued is dropped;
    /// the reply says whether anything was interrupted.
    fn estop(&mut self, s: &mut Session) -> String {
        let moving = matches!(s.state(), State::Running | State::Holding | State::Stopping);
        let interrupted = s.streaming() || moving;
        if interrupted {
            s.estop();
            self.after_es = true;
        }
        let v = if interrupted { "1" } else { "0" };
        self.syntax.data("ES", v, Ending::RevOk, false)
    }
}

/// Seconds of an `SM`/`XM`: a pure delay is capped at 100 s, as the board
/// caps it.
fn ms_of(ms: i64, d: [i64; 2]) -> f64 {
    let ms = if d == [0, 0] { ms.min(100_000) } else { ms };
    ms as f64 / 1000.0
}
