//! The driver runs a job on the simulated bot in this process, through a
//! line that costs serial time per byte, with the bot misbehaving in each
//! of the ways it can: every point arrives once, runs once, and lies
//! within half a step of the plan; a bot that stops answering or whose
//! acknowledgement is lost stops the run with a clear error.

use motet_host::Machine;
use motet_s3g::bot::faults::Faults;
use motet_s3g::bot::serve::Served;
use motet_s3g::bot::{Bot, Executed, BUFFER_BYTES};
use motet_s3g::check::PlannedPath;
use motet_s3g::driver::{Driver, DriverConfig, DriverError, Summary};
use motet_s3g::link::{LinkConfig, LinkError};
use std::io::{ErrorKind, Read, Write};
use std::path::PathBuf;
use std::time::Duration;

/// Serial time per byte at 115200 baud, µs.
const BYTE_US: f64 = 87.0;

/// The bot at the far end of a simulated line; time is the bot's and
/// moves with the bytes and with the host's waiting.
struct SimPort {
    served: Served,
    now: f64,
    rx: Vec<u8>,
    executed: Vec<Executed>,
}

impl SimPort {
    fn tick(&mut self, us: f64) {
        self.now += us;
        self.served.bot.advance(self.now);
        self.executed.append(&mut self.served.bot.executed);
    }
}

impl Write for SimPort {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.tick(BYTE_US * buf.len() as f64);
        let mut out = Vec::new();
        self.served.on_bytes(buf, self.now, &mut out);
        self.rx.extend(out);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for SimPort {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.rx.is_empty() {
            self.tick(1000.0);
            return Err(ErrorKind::TimedOut.into());
        }
        let n = buf.len().min(self.rx.len());
        buf[..n].copy_from_slice(&self.rx[..n]);
        self.rx.drain(..n);
        self.tick(BYTE_US * n as f64);
        Ok(n)
    }
}

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

struct Outcome {
    result: Result<Summary, DriverError>,
    port_executed: Vec<Executed>,
    bot: Bot,
    plan: PlannedPath,
}

/// Runs the example job on the example Replicator with `faults`.
fn run(faults: &str) -> Outcome {
    let machine = Machine::load(&examples().join("replicator.toml")).unwrap();
    let job = examples().join("jobs/replicator-square.gcode");
    let text = std::fs::read_to_string(&job).unwrap();
    let commands = parse_job(&machine, &text);
    let plan = PlannedPath::plan(&machine, &commands).unwrap();
    let served = Served::new(Bot::new(BUFFER_BYTES, 0.5), Faults::parse(faults).unwrap());
    let mut port = SimPort {
        served,
        now: 0.0,
        rx: Vec::new(),
        executed: Vec::new(),
    };
    let config = DriverConfig {
        link: LinkConfig {
            reply_timeout: Duration::from_millis(30),
            tries: 5,
            silent_tries: 2,
            poll_interval: Duration::ZERO,
        },
        temperature_every: Duration::ZERO,
    };
    let result = (|| {
        let mut d = Driver::connect(&mut port, &machine, config)?;
        for c in &commands {
            d.push(c)?;
        }
        d.finish()
    })();
    // Let the bot run what it was sent, as a real one would.
    for _ in 0..20_000 {
        if port.served.bot.finished() {
            break;
        }
        port.tick(1000.0);
    }
    let bot = std::mem::replace(&mut port.served.bot, Bot::new(1, 1.0));
    Outcome {
        result,
        port_executed: port.executed,
        bot,
        plan,
    }
}

/// The job's commands through motet's G-code interpreter.
fn parse_job(machine: &Machine, text: &str) -> Vec<motet_planner::Command> {
    let parsed = motet_gcode::parse(text, &machine.job_target(), &Default::default()).unwrap();
    parsed.commands.into_iter().map(|c| c.item).collect()
}

fn check_clean(faults: &str) {
    let o = run(faults);
    let s = o.result.unwrap_or_else(|e| panic!("{faults}: {e}"));
    let bot = &o.bot;
    assert!(s.points > 100, "{faults}: {} points", s.points);
    // Every point sent arrived once and ran once.
    assert_eq!(bot.points_received, s.points, "{faults}: received");
    assert_eq!(bot.points_run, s.points, "{faults}: run");
    assert_eq!(o.port_executed.len() as u64, s.points, "{faults}: reported");
    let dev = o.plan.max_deviation(&o.port_executed);
    assert!(dev <= 0.5, "{faults}: {dev} steps from the plan");
    eprintln!(
        "{faults:?}: {} points, at most {dev:.3} steps from the plan; {:?}",
        s.points, s.link
    );
    // The bot's clock ends where the plan ends.
    let end = o.port_executed.last().unwrap().clock_us as f64;
    assert!(
        (o.plan.duration_us() - end).abs() < 1000.0,
        "{faults}: ends at {end} µs, plan {}",
        o.plan.duration_us()
    );
    // Heaters were waited for and read back near their targets.
    assert_eq!(bot.actions.get(&135), Some(&1), "{faults}: wait for tool");
    assert_eq!(
        bot.actions.get(&141),
        Some(&1),
        "{faults}: wait for platform"
    );
    let t = &s.temperatures["tool0"];
    assert_eq!(t.target, 0, "{faults}: switched off at the end");
    assert!(
        t.peak >= 208,
        "{faults}: the extruder reached 210 °C: {t:?}"
    );
    let p = &s.temperatures["platform"];
    assert!(
        p.peak >= 58 && p.target == 0,
        "{faults}: the platform reached 60 °C: {p:?}"
    );
    let seen = s.link;
    if faults.contains("crc=") || faults.contains("generic=") || faults.contains("reply-crc=") {
        assert!(seen.resends > 0, "{faults}: {seen:?}");
    }
    if faults.contains("full=") {
        assert!(seen.buffer_full > 0, "{faults}: {seen:?}");
    }
    if faults.contains("garbage=") {
        assert!(seen.noise_bytes > 0, "{faults}: {seen:?}");
    }
}

#[test]
fn prints_through_every_recoverable_fault() {
    for faults in [
        "",
        "garbage=3",
        "crc=5",
        "generic=7",
        "full=4",
        "reply-crc=3",
        "garbage=5,crc=7,generic=11,full=13,reply-crc=17",
    ] {
        check_clean(faults);
    }
}

/// What an unrecoverable fault leaves: an error naming it, and no point
/// run twice.
fn check_stop(faults: &str, expect: fn(&LinkError) -> bool, words: &str) {
    let o = run(faults);
    let e = match o.result {
        Err(DriverError::Link(e)) => e,
        Err(e) => panic!("{faults}: unexpected {e}"),
        Ok(_) => panic!("{faults}: the run went on"),
    };
    assert!(expect(&e), "{faults}: {e:?}");
    assert!(e.to_string().contains(words), "{faults}: {e}");
    let mut last = 0;
    for x in &o.port_executed {
        assert_eq!(x.n, last + 1, "{faults}: points run in order, once");
        last = x.n;
    }
    assert_eq!(o.bot.points_run, o.bot.points_received, "{faults}");
    assert!(o.plan.max_deviation(&o.port_executed) <= 0.5, "{faults}");
}

#[test]
fn stops_clearly_when_the_bot_cannot_be_trusted() {
    check_stop(
        "silent-after=60",
        |e| matches!(e, LinkError::Silent { .. }),
        "stopped answering",
    );
    check_stop(
        "cancel-after=100",
        |e| {
            matches!(
                e,
                LinkError::Refused {
                    reply: motet_s3g::ReplyCode::Cancelled,
                    ..
                }
            )
        },
        "0x89 (build cancelled on the bot)",
    );
    check_stop(
        "ack-crc=10",
        |e| matches!(e, LinkError::LostActionReply { .. }),
        "cannot tell whether the bot queued it",
    );
}
