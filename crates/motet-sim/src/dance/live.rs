//! A live [`InputSource`]: input values typed or sent while a dance runs.
//!
//! A background thread reads lines from any [`BufRead`] (stdin, a pipe, or a
//! TCP connection on a listening socket) and hands them to the simulation:
//!
//! ```text
//! pedal=522.5            # one assignment
//! radius_knob 1200       # `name value`
//! t=2.5 pedal=0 lever=1  # several, applied at simulated time 2.5 s
//! ```
//!
//! A line is either `name value`, or one or more `name=value` assignments
//! separated by spaces or commas (spaces around `=` are allowed). `#` starts
//! a comment; blank lines are skipped. Names are the graph's `[inputs]`;
//! values are finite numbers and hold until the next line that sets them
//! (every input starts at 0). An assignment to `t` (or `time_s`, unless the
//! graph has an input of that name) stamps the line with the simulated time,
//! in seconds, at which its values apply; stamps must not decrease.
//!
//! A malformed line (unknown input, not a number, no value, a decreasing
//! stamp, invalid UTF-8, longer than [`MAX_LINE`] bytes) is reported with its
//! line number, on stderr unless [`LiveSource::quiet`], and in
//! [`LiveSource::problems`], and is ignored: it never stops the run.
//!
//! # Wall time and simulated time
//! [`Clock::RealTime`] (the default): the simulation paces itself to the wall
//! clock, simulated time 0 being the first frame. It is never more than
//! [`SLACK_S`] ahead of the wall clock (it sleeps when it is); if it cannot
//! keep up it falls behind, and nothing is lost. A line without a stamp that
//! arrives at wall time `w` after the start applies at the first frame whose
//! simulated time is ≥ `w` (lines that arrive before the start apply at 0); as
//! the simulation may run up to [`SLACK_S`] ahead, it can apply up to that much
//! later in simulated time than its arrival. A stamped line applies at its
//! stamp, or at once if the simulation is already past it.
//!
//! [`Clock::Stamped`]: no pacing; the stream is the clock. Before computing the
//! frame at simulated time `t`, the simulation waits until the stream has
//! delivered a stamp later than `t` or has ended (for [`LiveSource::listen`]:
//! until the first connection has come and gone), so a stamped stream gives
//! the same run however fast it is read. A line without a stamp applies at the
//! latest stamp before it (0 before any).

use super::InputSource;
use std::fmt;
use std::io::{self, BufRead, BufReader, Read};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

/// Longest line read, bytes; longer lines are reported and skipped.
pub const MAX_LINE: usize = 4096;
/// How far a real-time simulation may run ahead of the wall clock, s.
pub const SLACK_S: f64 = 0.001;

/// How wall time maps to simulated time (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Clock {
    /// Paced to the wall clock; unstamped lines apply at their arrival.
    #[default]
    RealTime,
    /// Not paced; the stream's `t=` stamps are the clock.
    Stamped,
}

/// A malformed line, ignored.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveProblem {
    /// `input`, `stdin` or the peer's address.
    pub source: String,
    /// 1-based line number in its stream (every physical line counts).
    pub line: usize,
    /// What is wrong with it.
    pub message: String,
}

impl fmt::Display for LiveProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.source, self.line, self.message)
    }
}

/// When a line's values apply.
#[derive(Clone, Copy, Debug)]
enum At {
    Stamp(f64),
    /// No stamp: the arrival (real time) or the latest stamp (stamped).
    Arrived(Instant),
}

enum Event {
    Opened,
    Set { at: At, sets: Vec<(usize, f64)> },
    Closed,
}

struct Shared {
    problems: Mutex<Vec<LiveProblem>>,
    quiet: AtomicBool,
    stop: AtomicBool,
    /// The open connection (listen), to shut down on drop.
    conn: Mutex<Option<TcpStream>>,
}

impl Shared {
    fn report(&self, p: LiveProblem) {
        if !self.quiet.load(Ordering::Relaxed) {
            eprintln!("live input: {p} (line ignored)");
        }
        if let Ok(mut v) = self.problems.lock() {
            v.push(p);
        }
    }
}

/// Input values fed while the simulation runs; see the module documentation.
pub struct LiveSource {
    names: Vec<String>,
    clock: Clock,
    rx: Receiver<Event>,
    shared: Arc<Shared>,
    local: Option<SocketAddr>,
    current: Vec<f64>,
    /// (time s, sequence, input, value), sorted by time then sequence.
    pending: Vec<(f64, u64, usize, f64)>,
    seq: u64,
    start: Option<Instant>,
    /// Latest stamp received (stamped clock).
    stamp: f64,
    open: bool,
    ever_opened: bool,
    ended: bool,
}

impl LiveSource {
    /// Reads `reader` on a background thread; `names` are the graph's inputs
    /// in order (see [`input_names`]).
    pub fn from_reader<R: BufRead + Send + 'static>(reader: R, names: Vec<String>) -> LiveSource {
        LiveSource::spawn(reader, "input", names)
    }

    /// Reads the process's standard input.
    pub fn stdin(names: Vec<String>) -> LiveSource {
        LiveSource::spawn(BufReader::new(io::stdin()), "stdin", names)
    }

    fn spawn<R: BufRead + Send + 'static>(
        reader: R,
        label: &str,
        names: Vec<String>,
    ) -> LiveSource {
        let (tx, rx) = mpsc::channel();
        let s = LiveSource::new(names, rx, None);
        let (names, shared, label) = (s.names.clone(), s.shared.clone(), label.to_string());
        thread::spawn(move || {
            if tx.send(Event::Opened).is_ok() {
                read_lines(reader, &label, &names, &shared, &tx);
            }
            let _ = tx.send(Event::Closed);
        });
        s
    }

    /// Listens on `addr` (e.g. `127.0.0.1:7878`; port 0 picks a free one, see
    /// [`LiveSource::local_addr`]) and reads the connections one after another.
    pub fn listen<A: ToSocketAddrs>(addr: A, names: Vec<String>) -> io::Result<LiveSource> {
        let listener = TcpListener::bind(addr)?;
        let local = listener.local_addr()?;
        let (tx, rx) = mpsc::channel();
        let s = LiveSource::new(names, rx, Some(local));
        let (names, shared) = (s.names.clone(), s.shared.clone());
        thread::spawn(move || serve(listener, &names, &shared, &tx));
        Ok(s)
    }

    fn new(names: Vec<String>, rx: Receiver<Event>, local: Option<SocketAddr>) -> LiveSource {
        LiveSource {
            current: vec![0.0; names.len()],
            names,
            clock: Clock::RealTime,
            rx,
            shared: Arc::new(Shared {
                problems: Mutex::new(Vec::new()),
                quiet: AtomicBool::new(false),
                stop: AtomicBool::new(false),
                conn: Mutex::new(None),
            }),
            local,
            pending: Vec::new(),
            seq: 0,
            start: None,
            stamp: 0.0,
            open: false,
            ever_opened: false,
            ended: false,
        }
    }

    /// Uses `clock` instead of [`Clock::RealTime`].
    pub fn clock(mut self, clock: Clock) -> LiveSource {
        self.clock = clock;
        self
    }

    /// Problems are not printed on stderr (still kept in `problems`).
    pub fn quiet(self) -> LiveSource {
        self.shared.quiet.store(true, Ordering::Relaxed);
        self
    }

    /// The listening address ([`LiveSource::listen`]).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.local
    }

    /// The malformed lines so far.
    pub fn problems(&self) -> Vec<LiveProblem> {
        self.shared
            .problems
            .lock()
            .map(|v| v.clone())
            .unwrap_or_default()
    }

    /// Whether the stream has ended (the reader reached its end; for `listen`,
    /// the listener stopped).
    pub fn ended(&self) -> bool {
        self.ended
    }

    fn take(&mut self, e: Event) {
        match e {
            Event::Opened => {
                self.open = true;
                self.ever_opened = true;
            }
            Event::Closed => {
                self.open = false;
                // A reader is read once: its close is its end (without
                // waiting for the thread to let go of the channel).
                if self.local.is_none() {
                    self.ended = true;
                }
            }
            Event::Set { at, sets } => {
                let at = match at {
                    At::Stamp(s) => {
                        self.stamp = self.stamp.max(s);
                        s
                    }
                    At::Arrived(_) if self.clock == Clock::Stamped => self.stamp,
                    At::Arrived(i) => self
                        .start
                        .map_or(0.0, |s| i.saturating_duration_since(s).as_secs_f64()),
                };
                let pos = self.pending.partition_point(|p| p.0 <= at);
                for (k, (i, v)) in sets.into_iter().enumerate() {
                    self.pending.insert(pos + k, (at, self.seq, i, v));
                    self.seq += 1;
                }
            }
        }
    }

    /// Takes what has arrived, without waiting.
    fn drain(&mut self) {
        loop {
            match self.rx.try_recv() {
                Ok(e) => self.take(e),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    self.open = false;
                    self.ended = true;
                    break;
                }
            }
        }
    }
}

impl InputSource for LiveSource {
    fn values(&mut self, t_s: f64, out: &mut [f64]) {
        match self.clock {
            Clock::RealTime => {
                let start = *self.start.get_or_insert_with(Instant::now);
                let ahead = t_s - start.elapsed().as_secs_f64();
                if ahead > SLACK_S {
                    thread::sleep(Duration::from_secs_f64(ahead));
                }
                self.drain();
            }
            Clock::Stamped => {
                self.drain();
                // Wait for a stamp beyond t, or the end of the stream.
                while !(self.stamp > t_s || self.ended || (self.ever_opened && !self.open)) {
                    match self.rx.recv() {
                        Ok(e) => self.take(e),
                        Err(_) => self.ended = true,
                    }
                }
            }
        }
        let n = self.pending.partition_point(|p| p.0 <= t_s);
        for (_, _, i, v) in self.pending.drain(..n) {
            self.current[i] = v;
        }
        for (o, v) in out
            .iter_mut()
            .zip(self.current.iter().chain(std::iter::repeat(&0.0)))
        {
            *o = *v;
        }
    }
}

impl Drop for LiveSource {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Ok(mut c) = self.shared.conn.lock() {
            if let Some(c) = c.take() {
                let _ = c.shutdown(std::net::Shutdown::Both);
            }
        }
        // Wake the listener's accept.
        if let Some(a) = self.local {
            let _ = TcpStream::connect_timeout(&a, Duration::from_millis(200));
        }
    }
}

/// The graph's input names, in order (the `names` of [`LiveSource`]).
pub fn input_names(graph: &motet_graph::GraphFile) -> Vec<String> {
    graph.inputs.iter().map(|d| d.name.clone()).collect()
}

fn serve(listener: TcpListener, names: &[String], shared: &Shared, tx: &Sender<Event>) {
    for conn in listener.incoming() {
        if shared.stop.load(Ordering::SeqCst) {
            break;
        }
        let Ok(conn) = conn else { continue };
        let label = conn
            .peer_addr()
            .map_or("connection".to_string(), |a| a.to_string());
        if let Ok(mut c) = shared.conn.lock() {
            *c = conn.try_clone().ok();
        }
        // Dropped meanwhile (the flag is set before the drop takes `conn`).
        if shared.stop.load(Ordering::SeqCst) {
            break;
        }
        if tx.send(Event::Opened).is_err() {
            break;
        }
        read_lines(BufReader::new(conn), &label, names, shared, tx);
        if let Ok(mut c) = shared.conn.lock() {
            *c = None;
        }
        if tx.send(Event::Closed).is_err() {
            break;
        }
    }
}

/// Reads lines until the end of `reader` (or a read error, reported), sending
/// the good ones.
fn read_lines<R: BufRead>(
    mut reader: R,
    label: &str,
    names: &[String],
    shared: &Shared,
    tx: &Sender<Event>,
) {
    let problem = |line: usize, message: String| {
        shared.report(LiveProblem {
            source: label.to_string(),
            line,
            message,
        })
    };
    let mut buf = Vec::new();
    let mut line = 0;
    let mut last_stamp = f64::NEG_INFINITY;
    loop {
        buf.clear();
        let n = match (&mut reader)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
        {
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => {
                if !shared.stop.load(Ordering::SeqCst) {
                    problem(line + 1, format!("read error, input closed: {e}"));
                }
                return;
            }
        };
        if n == 0 {
            return;
        }
        line += 1;
        if buf.last() != Some(&b'\n') && buf.len() > MAX_LINE {
            problem(line, format!("longer than {MAX_LINE} bytes"));
            // Skip the rest of the line.
            loop {
                buf.clear();
                match (&mut reader)
                    .take(MAX_LINE as u64)
                    .read_until(b'\n', &mut buf)
                {
                    Ok(0) => return,
                    Ok(_) if buf.last() == Some(&b'\n') => break,
                    Ok(_) => {}
                    Err(_) => return,
                }
            }
            continue;
        }
        let Ok(text) = std::str::from_utf8(&buf) else {
            problem(line, "not UTF-8".into());
            continue;
        };
        match parse_line(text, names) {
            Ok(None) => {}
            Ok(Some((stamp, sets))) => {
                if let Some(s) = stamp {
                    if s < last_stamp {
                        problem(
                            line,
                            format!("time {s} is before the previous {last_stamp}"),
                        );
                        continue;
                    }
                    last_stamp = s;
                }
                let at = match stamp {
                    Some(s) => At::Stamp(s),
                    None => At::Arrived(Instant::now()),
                };
                if tx.send(Event::Set { at, sets }).is_err() {
                    return;
                }
            }
            Err(m) => problem(line, m),
        }
    }
}

/// One line: its stamp and `(input, value)` assignments, or `None` for a
/// blank or comment line.
#[allow(clippy::type_complexity)]
fn parse_line(
    text: &str,
    names: &[String],
) -> Result<Option<(Option<f64>, Vec<(usize, f64)>)>, String> {
    let text = text.split('#').next().unwrap_or("").replace(',', " ");
    let text = text.trim();
    if text.is_empty() {
        return Ok(None);
    }
    let mut pairs: Vec<(&str, &str)> = Vec::new();
    if text.contains('=') {
        let parts: Vec<Vec<&str>> = text
            .split('=')
            .map(|p| p.split_whitespace().collect())
            .collect();
        let last = parts.len() - 1;
        for (k, p) in parts.iter().enumerate() {
            let want = if k == 0 || k == last { 1 } else { 2 };
            if p.len() != want {
                return Err(format!(
                    "expected `name=value ...` or `name value`, found `{text}`"
                ));
            }
        }
        for k in 0..last {
            pairs.push((parts[k][parts[k].len() - 1], parts[k + 1][0]));
        }
    } else {
        let p: Vec<&str> = text.split_whitespace().collect();
        if p.len() != 2 {
            return Err(format!(
                "expected `name=value ...` or `name value`, found `{text}`"
            ));
        }
        pairs.push((p[0], p[1]));
    }
    let mut stamp = None;
    let mut sets = Vec::new();
    for (name, v) in pairs {
        let x: f64 = v
            .parse()
            .ok()
            .filter(|x: &f64| x.is_finite())
            .ok_or_else(|| format!("`{v}` is not a number"))?;
        match names.iter().position(|n| n == name) {
            Some(i) => sets.push((i, x)),
            None if name == "t" || name == "time_s" => {
                if x < 0.0 {
                    return Err(format!("time {x} is negative"));
                }
                stamp = Some(x);
            }
            None => {
                return Err(format!(
                    "`{name}` is not an input of the graph; its inputs: {}",
                    names.join(", ")
                ))
            }
        }
    }
    Ok(Some((stamp, sets)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Cursor, Write};

    fn names() -> Vec<String> {
        vec!["pedal".into(), "knob".into()]
    }

    /// Values at each time of `ts`.
    fn sample(s: &mut LiveSource, ts: &[f64]) -> Vec<[f64; 2]> {
        ts.iter()
            .map(|&t| {
                let mut v = [0.0; 2];
                s.values(t, &mut v);
                v
            })
            .collect()
    }

    #[test]
    fn parses_both_forms_and_reports_bad_lines() {
        let n = names();
        assert_eq!(parse_line("pedal=3", &n), Ok(Some((None, vec![(0, 3.0)]))));
        assert_eq!(
            parse_line("  knob  -2.5 # c", &n),
            Ok(Some((None, vec![(1, -2.5)])))
        );
        assert_eq!(
            parse_line("t=1.5, pedal = 3 knob=4", &n),
            Ok(Some((Some(1.5), vec![(0, 3.0), (1, 4.0)])))
        );
        assert_eq!(parse_line("   # only a comment", &n), Ok(None));
        for bad in [
            "pedal",
            "pedal=",
            "=3",
            "pedal=3 4",
            "pedal==3",
            "a b c",
            "pedal=x",
            "pedal nan",
            "nope=1",
            "t=-1",
        ] {
            assert!(parse_line(bad, &n).is_err(), "{bad}");
        }
    }

    #[test]
    fn stamped_reader_applies_values_at_their_times() {
        let text = "\
# a scripted session
pedal=100
t=0.5 pedal=200
knob 7
oops
t=1.0 knob=x
t=0.25 pedal=1
t=1.5 pedal=300, knob=-3
\u{ff}\n";
        let mut bytes = text.as_bytes().to_vec();
        // `ÿ` alone on line 9; invalid UTF-8 on line 10; too long on line 11.
        bytes.extend_from_slice(&[0xff, 0xfe, b'\n']);
        bytes.extend(std::iter::repeat_n(b'x', MAX_LINE + 10));
        bytes.extend_from_slice(b"\nt=2 knob=9\n");
        let mut s = LiveSource::from_reader(Cursor::new(bytes), names())
            .clock(Clock::Stamped)
            .quiet();
        let got = sample(&mut s, &[0.0, 0.49, 0.5, 1.0, 1.49, 1.5, 1.99, 2.0, 10.0]);
        assert_eq!(
            got,
            [
                [100.0, 0.0],
                [100.0, 0.0],
                [200.0, 7.0],
                [200.0, 7.0],
                [200.0, 7.0],
                [300.0, -3.0],
                [300.0, -3.0],
                [300.0, 9.0],
                [300.0, 9.0],
            ]
        );
        let lines: Vec<usize> = s.problems().iter().map(|p| p.line).collect();
        assert_eq!(lines, [5, 6, 7, 9, 10, 11]);
        assert!(s.problems()[1]
            .to_string()
            .starts_with("input:6: `x` is not a number"));
        assert!(s.ended());
    }

    #[test]
    fn real_time_paces_and_applies_at_arrival() {
        // A pipe: the writer sends a value 100 ms into the run.
        let (tx, rx) = mpsc::channel::<Vec<u8>>();
        struct Pipe(Receiver<Vec<u8>>, Cursor<Vec<u8>>);
        impl Read for Pipe {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                loop {
                    let n = self.1.read(buf)?;
                    if n > 0 {
                        return Ok(n);
                    }
                    match self.0.recv() {
                        Ok(b) => self.1 = Cursor::new(b),
                        Err(_) => return Ok(0),
                    }
                }
            }
        }
        // Before the source: its real-time clock starts when it is made.
        let t0 = Instant::now();
        let mut s =
            LiveSource::from_reader(BufReader::new(Pipe(rx, Cursor::new(Vec::new()))), names())
                .quiet();
        let mut applied = None;
        let mut v = [0.0; 2];
        let mut sent = None;
        for f in 0..7500 {
            let t = f as f64 * 40e-6;
            if sent.is_none() && t0.elapsed() >= Duration::from_millis(100) {
                tx.send(b"pedal=5\n".to_vec()).unwrap();
                sent = Some(t0.elapsed().as_secs_f64());
            }
            s.values(t, &mut v);
            if applied.is_none() && v[0] == 5.0 {
                applied = Some(t);
            }
        }
        let wall = t0.elapsed().as_secs_f64();
        // 0.3 s simulated took at least 0.3 s of wall time: paced, not run
        // ahead (pacing allows a few ms of slack; how much longer it takes
        // depends on the machine's load).
        assert!(wall >= 0.29, "{wall}");
        let (a, w) = (applied.unwrap(), sent.unwrap());
        // Applied at about the simulated time it was sent.
        assert!(
            a >= w - 0.005 && a <= w + 0.25,
            "applied at {a}, sent at {w}"
        );
    }

    #[test]
    fn tcp_connection_feeds_a_stamped_run() {
        let mut s = LiveSource::listen("127.0.0.1:0", names())
            .unwrap()
            .clock(Clock::Stamped)
            .quiet();
        let addr = s.local_addr().unwrap();
        let client = thread::spawn(move || {
            let mut c = TcpStream::connect(addr).unwrap();
            c.set_write_timeout(Some(Duration::from_secs(5))).unwrap();
            for k in 1..=100 {
                writeln!(c, "t={} pedal={k}", k as f64 * 0.01).unwrap();
                if k == 50 {
                    writeln!(c, "pedal=").unwrap();
                }
            }
            writeln!(c, "knob 42").unwrap();
        });
        let mut v = [0.0; 2];
        let mut seen = Vec::new();
        for f in 0..=30_000 {
            s.values(f as f64 * 40e-6, &mut v);
            if seen.last() != Some(&v[0]) {
                seen.push(v[0]);
            }
        }
        client.join().unwrap();
        assert_eq!(seen, (0..=100).map(f64::from).collect::<Vec<_>>());
        assert_eq!(v, [100.0, 42.0]);
        let p = s.problems();
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!(p[0].line, 51);
        assert!(p[0].source.starts_with("127.0.0.1:"));
    }

    #[test]
    fn dropping_a_listener_ends_its_threads() {
        let s = LiveSource::listen("127.0.0.1:0", names()).unwrap().quiet();
        let addr = s.local_addr().unwrap();
        let mut c = TcpStream::connect(addr).unwrap();
        writeln!(c, "pedal=1").unwrap();
        drop(s);
        // The connection is shut down from the other side: reads end.
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut b = [0u8; 8];
        assert_eq!(c.read(&mut b).unwrap_or(0), 0);
    }
}
