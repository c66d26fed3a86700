//! The host driver: motet plans the job, and the bot runs the plan as
//! queued points with durations (142), delays (133), heater and fan tool
//! actions (136) and heater waits (135, 141), with flow control on its
//! action buffer and the temperatures polled while the host waits.

use crate::command::Command;
use crate::link::{Link, LinkConfig, LinkError, LinkStats};
use crate::points::{AxisMap, Emitter, MapError};
use crate::reply::ReplyCode;
use crate::tool::Heater;
use motet_host::Machine;
use motet_planner::{AuxChannel, Planned, Planner};
use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// Why a run on a bot stopped.
#[derive(Debug, thiserror::Error)]
pub enum DriverError {
    /// The machine cannot be an S3G bot.
    #[error(transparent)]
    Map(#[from] MapError),
    /// The line to the bot failed.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The planner refused a command (the caller adds where it came from).
    #[error(transparent)]
    Plan(#[from] motet_planner::PlanError),
}

/// A heater's last reading, °C.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reading {
    /// Temperature.
    pub temp: i16,
    /// Target.
    pub target: i16,
    /// The highest temperature read during the run.
    pub peak: i16,
}

/// What a run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Summary {
    /// Points queued on the bot.
    pub points: u64,
    /// Actions queued (points, delays, tool actions, waits).
    pub actions: u64,
    /// The plan's duration, s.
    pub planned_s: f64,
    /// The bot's motion clock at the end (sum of durations sent), s.
    pub bot_s: f64,
    /// What the line saw.
    pub link: LinkStats,
    /// The last reading of each heater the job used.
    pub temperatures: BTreeMap<String, Reading>,
}

/// Timing of a run.
#[derive(Debug, Clone, Copy)]
pub struct DriverConfig {
    /// The line's timing; its poll interval also paces the wait for the
    /// bot to finish.
    pub link: LinkConfig,
    /// How often the heaters are read while the host waits.
    pub temperature_every: Duration,
}

impl Default for DriverConfig {
    fn default() -> DriverConfig {
        DriverConfig {
            link: LinkConfig::default(),
            temperature_every: Duration::from_millis(500),
        }
    }
}

/// Drives one bot through one job.
pub struct Driver<P> {
    link: Link<P>,
    planner: Planner,
    emitter: Emitter,
    heaters: Vec<Heater>,
    readings: BTreeMap<Heater, Reading>,
    last_poll: Option<Instant>,
    poll_every: Duration,
    idle_sleep: Duration,
    on_pause: Box<dyn FnMut(bool)>,
    points: u64,
    scratch: Vec<Command>,
}

fn heater_name(h: Heater) -> String {
    match h {
        Heater::Tool(i) => format!("tool{i}"),
        Heater::Platform => "platform".into(),
    }
}

impl<P: Read + Write> Driver<P> {
    /// Checks the machine, then greets the bot on `port`: version, its
    /// own acceleration off (motet plans the speeds), and the position set
    /// to the machine's start.
    pub fn connect(
        port: P,
        machine: &Machine,
        config: DriverConfig,
    ) -> Result<Driver<P>, DriverError> {
        let map = AxisMap::of(machine)?;
        let emitter = Emitter::new(map, &machine.start);
        let mut link = Link::new(port, config.link);
        link.query(&Command::Version(100))?;
        match link.action(&Command::SetAcceleration(false), &mut |_| Ok(())) {
            // Firmware without acceleration runs points as they come.
            Err(LinkError::Refused {
                reply: ReplyCode::NotSupported,
                ..
            }) => {}
            r => r?,
        }
        link.action(&Command::SetPositionExt(emitter.start_steps()), &mut |_| {
            Ok(())
        })?;
        Ok(Driver {
            link,
            planner: Planner::new(machine.limits(), machine.start, 0.0),
            emitter,
            heaters: Vec::new(),
            readings: BTreeMap::new(),
            last_poll: None,
            poll_every: config.temperature_every,
            idle_sleep: config.link.poll_interval,
            on_pause: Box::new(|_| {}),
            points: 0,
            scratch: Vec::new(),
        })
    }

    /// What to do at a pause, once the bot has run everything before it
    /// (the argument: whether the pause is optional). By default the job
    /// goes on.
    pub fn on_pause(&mut self, f: Box<dyn FnMut(bool)>) {
        self.on_pause = f;
    }

    /// Plans a command and sends what the plan has ready.
    pub fn push(&mut self, cmd: &motet_planner::Command) -> Result<(), DriverError> {
        self.planner.push(cmd)?;
        self.drain()
    }

    /// Ends the job: the rest of the plan is sent and run to its end.
    pub fn finish(mut self) -> Result<Summary, DriverError> {
        self.planner.finish();
        self.drain()?;
        self.wait_finished()?;
        self.poll_temperatures(true)?;
        Ok(Summary {
            points: self.points,
            actions: self.link.stats().actions,
            planned_s: self.planner.clock() * 1e-6,
            bot_s: self.emitter.clock_us() as f64 * 1e-6,
            link: self.link.stats(),
            temperatures: self
                .readings
                .iter()
                .map(|(h, r)| (heater_name(*h), *r))
                .collect(),
        })
    }

    fn drain(&mut self) -> Result<(), DriverError> {
        while let Some(p) = self.planner.pop() {
            if let Planned::Pause { optional, .. } = p {
                self.wait_finished()?;
                (self.on_pause)(optional);
                continue;
            }
            if let Planned::Aux(a) = &p {
                let h = match a.channel {
                    AuxChannel::Hotend(i) => Some(Heater::Tool(i)),
                    AuxChannel::Bed => Some(Heater::Platform),
                    _ => None,
                };
                if let Some(h) = h.filter(|h| !self.heaters.contains(h)) {
                    self.heaters.push(h);
                }
            }
            let mut cmds = std::mem::take(&mut self.scratch);
            self.emitter.planned(&p, &mut cmds);
            for c in cmds.drain(..) {
                self.send(&c)?;
            }
            self.scratch = cmds;
        }
        Ok(())
    }

    fn send(&mut self, c: &Command) -> Result<(), DriverError> {
        let heaters = self.heaters.clone();
        let mut readings = std::mem::take(&mut self.readings);
        let (every, mut last) = (self.poll_every, self.last_poll);
        let r = self.link.action(c, &mut |link| {
            if last.is_none_or(|t| t.elapsed() >= every) {
                last = Some(Instant::now());
                read_heaters(link, &heaters, &mut readings)?;
            }
            Ok(())
        });
        self.readings = readings;
        self.last_poll = last;
        r?;
        if matches!(c, Command::PointNew(_)) {
            self.points += 1;
        }
        Ok(())
    }

    fn poll_temperatures(&mut self, now: bool) -> Result<(), DriverError> {
        if now
            || self
                .last_poll
                .is_none_or(|t| t.elapsed() >= self.poll_every)
        {
            self.last_poll = Some(Instant::now());
            read_heaters(&mut self.link, &self.heaters, &mut self.readings)?;
        }
        Ok(())
    }

    /// Polls until the bot has run everything queued.
    fn wait_finished(&mut self) -> Result<(), DriverError> {
        loop {
            let r = self.link.query(&Command::IsFinished)?;
            if r.u8().is_ok_and(|f| f != 0) {
                return Ok(());
            }
            self.poll_temperatures(false)?;
            std::thread::sleep(self.idle_sleep);
        }
    }
}

/// Reads each heater's temperature and target.
fn read_heaters<P: Read + Write>(
    link: &mut Link<P>,
    heaters: &[Heater],
    out: &mut BTreeMap<Heater, Reading>,
) -> Result<(), LinkError> {
    use crate::tool::sub;
    for &h in heaters {
        let mut ask = |s: u8| -> Result<i16, LinkError> {
            let r = link.query(&Command::ToolQuery {
                tool: h.tool(),
                sub: s,
                data: vec![],
            })?;
            r.i16().map_err(|error| LinkError::Short {
                code: crate::command::code::TOOL_QUERY,
                name: "tool query",
                error,
            })
        };
        let temp = ask(h.get_temp())?;
        let target = ask(match h {
            Heater::Tool(_) => sub::GET_SP,
            Heater::Platform => sub::GET_PLATFORM_SP,
        })?;
        let peak = out.get(&h).map_or(temp, |r| r.peak.max(temp));
        out.insert(h, Reading { temp, target, peak });
    }
    Ok(())
}
