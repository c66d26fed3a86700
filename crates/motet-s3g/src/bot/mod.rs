//! A simulated S3G bot: answers queries, queues actions in a bounded
//! buffer (0x82 when it is full), and runs them in time: points at
//! constant rate over their duration, delays, heaters approaching their
//! targets and waits for them. It keeps every point it ran, in steps, for
//! tests to compare with the plan.

pub mod faults;
pub mod heater;
mod queries;
pub mod serve;

use crate::command::{Command, PointNew};
use crate::reply::{Reply, ReplyCode};
use crate::tool::{sub, Heater as HeaterId};
use heater::Heater;
use std::collections::{HashMap, VecDeque};

/// The bot's action buffer, bytes (a Replicator's).
pub const BUFFER_BYTES: usize = 512;

/// A point the bot has run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Executed {
    /// Which point, from 1, in the order received.
    pub n: u64,
    /// The bot's motion clock at its end: µs of points and delays run.
    pub clock_us: i64,
    /// Where it ended, steps X Y Z A B.
    pub steps: [i32; 5],
}

/// What the bot is doing.
#[derive(Debug, Clone, PartialEq)]
enum Doing {
    Moving {
        from: [i32; 5],
        to: [i32; 5],
        start: f64,
        end: f64,
        us: i64,
    },
    Waiting {
        until: f64,
        us: i64,
    },
    Heating(HeaterId),
}

/// The simulated bot's state; time is µs on its own clock.
#[derive(Debug)]
pub struct Bot {
    buffer: usize,
    /// Queued actions with their size and arrival time.
    queue: VecDeque<(Command, usize, f64)>,
    used: usize,
    doing: Option<Doing>,
    /// When the last activity ended.
    free_at: f64,
    now: f64,
    /// Position, steps.
    pub position: [i32; 5],
    /// The motion clock (µs of points and delays run).
    pub clock_us: i64,
    heaters: HashMap<HeaterId, Heater>,
    heat_tau_s: f64,
    /// Points received.
    pub points_received: u64,
    /// Points run so far.
    pub points_run: u64,
    /// Points run, in order (taken by the caller as they come).
    pub executed: Vec<Executed>,
    /// Actions received, by command number.
    pub actions: HashMap<u8, u64>,
    /// Points after which the queue was empty (the job's last point is one;
    /// any other is the host not keeping up).
    pub underruns: u64,
}

impl Bot {
    /// A bot at rest at steps 0, with a buffer of `buffer` bytes and heaters
    /// of time constant `heat_tau_s` seconds.
    pub fn new(buffer: usize, heat_tau_s: f64) -> Bot {
        Bot {
            buffer,
            queue: VecDeque::new(),
            used: 0,
            doing: None,
            free_at: 0.0,
            now: 0.0,
            position: [0; 5],
            clock_us: 0,
            heaters: HashMap::new(),
            heat_tau_s,
            points_received: 0,
            points_run: 0,
            executed: Vec::new(),
            actions: HashMap::new(),
            underruns: 0,
        }
    }

    /// Free bytes in the action buffer.
    pub fn free(&self) -> usize {
        self.buffer - self.used
    }

    /// Whether everything queued has run.
    pub fn finished(&self) -> bool {
        self.queue.is_empty() && self.doing.is_none()
    }

    fn heater(&mut self, h: HeaterId) -> &mut Heater {
        let tau = self.heat_tau_s;
        self.heaters.entry(h).or_insert_with(|| Heater::new(tau))
    }

    /// A heater's (temperature, target), °C.
    pub fn temperature(&mut self, h: HeaterId) -> (f64, f64) {
        let x = self.heater(h);
        (x.temp, x.target)
    }

    /// Answers a packet that arrived at `now` (its payload, CRC checked).
    pub fn on_packet(&mut self, payload: &[u8], now: f64) -> Reply {
        self.advance(now);
        let cmd = match Command::decode(payload) {
            Ok(c) => c,
            Err(_) => return Reply::new(ReplyCode::NotSupported, vec![]),
        };
        if !cmd.is_action() {
            return self.answer(&cmd);
        }
        if payload.len() > self.free() {
            return Reply::new(ReplyCode::BufferFull, vec![]);
        }
        *self.actions.entry(cmd.code()).or_default() += 1;
        if matches!(cmd, Command::PointNew(_) | Command::PointAccel(_)) {
            self.points_received += 1;
        }
        self.used += payload.len();
        self.queue.push_back((cmd, payload.len(), now));
        self.advance(now);
        Reply::new(ReplyCode::Success, vec![])
    }

    /// Lets time run to `now`: heaters, the current activity, the queue.
    pub fn advance(&mut self, now: f64) {
        let now = now.max(self.now);
        let dt_s = (now - self.now) * 1e-6;
        for h in self.heaters.values_mut() {
            h.advance(dt_s);
        }
        self.now = now;
        loop {
            match self.doing.clone() {
                Some(Doing::Moving { to, end, us, .. }) if end <= now => {
                    self.position = to;
                    self.clock_us += us;
                    self.free_at = end;
                    self.points_run += 1;
                    self.executed.push(Executed {
                        n: self.points_run,
                        clock_us: self.clock_us,
                        steps: to,
                    });
                    self.doing = None;
                    if self.queue.is_empty() {
                        self.underruns += 1;
                    }
                }
                Some(Doing::Waiting { until, us }) if until <= now => {
                    self.clock_us += us;
                    self.free_at = until;
                    self.doing = None;
                }
                Some(Doing::Heating(h)) if self.heater(h).ready() => {
                    self.free_at = now;
                    self.doing = None;
                }
                Some(_) => return,
                None => {
                    let Some((cmd, len, arrived)) = self.queue.pop_front() else {
                        return;
                    };
                    self.used -= len;
                    let start = self.free_at.max(arrived);
                    self.start(cmd, start);
                }
            }
        }
    }

    /// Starts an action at `t`.
    fn start(&mut self, cmd: Command, t: f64) {
        self.free_at = t;
        match cmd {
            Command::PointNew(p) => self.move_to(&p, t),
            Command::PointAccel(p) => {
                // Sailfish plans these with its own acceleration; the
                // simulation runs them at the dominant axis's rate.
                let mut to = p.steps;
                let most = (0..5)
                    .map(|i| {
                        if p.relative & (1 << i) != 0 {
                            to[i] += self.position[i];
                        }
                        (to[i] - self.position[i]).unsigned_abs()
                    })
                    .max()
                    .unwrap_or(0);
                let us = (most as f64 / p.dda_rate.max(1) as f64 * 1e6).round() as u32;
                self.move_to(
                    &PointNew {
                        steps: to,
                        us,
                        relative: 0,
                    },
                    t,
                );
            }
            Command::Delay(ms) => {
                self.doing = Some(Doing::Waiting {
                    until: t + ms as f64 * 1000.0,
                    us: ms as i64 * 1000,
                })
            }
            Command::WaitForTool { tool, .. } => {
                self.doing = Some(Doing::Heating(HeaterId::Tool(tool)))
            }
            Command::WaitForPlatform { .. } => {
                self.doing = Some(Doing::Heating(HeaterId::Platform))
            }
            Command::SetPositionExt(s) => self.position = s,
            Command::ToolAction { tool, sub, data } => self.tool_action(tool, sub, &data),
            _ => {}
        }
    }

    fn move_to(&mut self, p: &PointNew, t: f64) {
        let mut to = p.steps;
        for (i, v) in to.iter_mut().enumerate() {
            if p.relative & (1 << i) != 0 {
                *v += self.position[i];
            }
        }
        self.doing = Some(Doing::Moving {
            from: self.position,
            to,
            start: t,
            end: t + p.us as f64,
            us: p.us as i64,
        });
    }

    fn tool_action(&mut self, tool: u8, s: u8, data: &[u8]) {
        let temp = || {
            data.get(..2)
                .map(|b| i16::from_le_bytes([b[0], b[1]]) as f64)
        };
        match (s, temp()) {
            (sub::SET_TEMP, Some(c)) => self.heater(HeaterId::Tool(tool)).target = c,
            (sub::SET_PLATFORM_TEMP, Some(c)) => self.heater(HeaterId::Platform).target = c,
            _ => {}
        }
    }

    /// Where the axes are now, steps (between two points, on the line).
    pub fn position_now(&self) -> [i32; 5] {
        match &self.doing {
            Some(Doing::Moving {
                from,
                to,
                start,
                end,
                ..
            }) => {
                let f = ((self.now - start) / (end - start).max(1.0)).clamp(0.0, 1.0);
                std::array::from_fn(|i| from[i] + ((to[i] - from[i]) as f64 * f).round() as i32)
            }
            _ => self.position,
        }
    }

    /// Empties the queue and stops (abort, clear buffer).
    fn stop(&mut self) {
        self.position = self.position_now();
        self.queue.clear();
        self.used = 0;
        self.doing = None;
        self.free_at = self.now;
    }
}
