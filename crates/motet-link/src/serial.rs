//! Serial transport: the COBS-stuffed stream over a serial port (USB CDC,
//! UART, a pseudo-terminal), frames ending at 0x00.

use crate::{Clock, Inbox, LinkStats, Stamp, StreamSplitter, Transport, WallClock};
use serialport::SerialPort;
use std::io::{self, Write};
use std::time::Duration;

/// Opens the device at `path` in raw mode, 8N1, no flow control, reads not
/// blocking.
pub fn open_raw(path: &str, baud: u32) -> io::Result<Box<dyn SerialPort>> {
    serialport::new(path, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(Duration::ZERO)
        .open()
        .map_err(io::Error::from)
}

/// Reads once from `port` into `buf`, waiting at most `wait`; 0 when nothing
/// arrived in time.
pub(crate) fn read_port(
    port: &mut dyn SerialPort,
    wait: Duration,
    buf: &mut [u8],
) -> io::Result<usize> {
    port.set_timeout(wait).map_err(io::Error::from)?;
    match port.read(buf) {
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
            ) =>
        {
            Ok(0)
        }
        r => r,
    }
}

/// A serial port carrying motet frames.
pub struct SerialTransport {
    name: String,
    port: Box<dyn SerialPort>,
    splitter: StreamSplitter,
    inbox: Inbox,
    stats: LinkStats,
    /// The clock frames are stamped on as they are handed out, once asked
    /// ([`Transport::stamp_arrivals`]).
    stamps: Option<WallClock>,
    last_stamp: Option<Stamp>,
}

impl std::fmt::Debug for SerialTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialTransport")
            .field("name", &self.name)
            .field("pending", &self.splitter.pending())
            .field("ready", &self.inbox.len())
            .field("stats", &self.stats)
            .finish()
    }
}

impl SerialTransport {
    /// Opens the device at `path` in raw mode, 8N1, no flow control.
    pub fn open(path: &str, baud: u32) -> io::Result<SerialTransport> {
        let port = open_raw(path, baud)?;
        Ok(Self::from_port(format!("serial:{path}"), port))
    }

    /// Uses a port opened elsewhere (already in raw mode).
    pub fn from_port(name: String, port: Box<dyn SerialPort>) -> SerialTransport {
        SerialTransport {
            name,
            port,
            splitter: StreamSplitter::default(),
            inbox: Inbox::new(),
            stats: LinkStats::default(),
            stamps: None,
            last_stamp: None,
        }
    }

    /// Writes bytes as they are, with no delimiter added (tests, line
    /// flushing). Not counted as frames.
    pub fn write_raw(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }
}

impl Transport for SerialTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let mut buf = Vec::with_capacity(frame.len() + 1);
        buf.extend_from_slice(frame);
        if buf.last() != Some(&0) {
            buf.push(0);
        }
        self.port.write_all(&buf)?;
        self.stats.sent(buf.len());
        Ok(())
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let (port, splitter) = (&mut self.port, &mut self.splitter);
        let frame = self.inbox.recv(timeout, &mut self.stats, |inbox, wait| {
            let mut buf = [0u8; 512];
            let n = read_port(port.as_mut(), wait, &mut buf)?;
            inbox.take_stream(splitter, &buf[..n]);
            Ok(n > 0)
        })?;
        // A byte stream tells no arrival: the moment a frame is handed
        // out is after it came, which is all a clock exchange needs (late
        // only widens what it tells), and later than the caller's own
        // time, read before it got to the frame.
        self.last_stamp = match (&frame, &self.stamps) {
            (Some(_), Some(c)) => Some(Stamp {
                at_us: c.now_us(),
                own: false,
            }),
            _ => None,
        };
        Ok(frame)
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }

    fn last_stamp(&self) -> Option<Stamp> {
        self.last_stamp
    }

    fn stamp_arrivals(&mut self, clock: WallClock) -> bool {
        self.stamps = Some(clock);
        true
    }
}

/// Pseudo-terminal pairs for tests and simulations (Unix).
#[cfg(all(test, unix))]
pub(crate) mod pty {
    use super::SerialTransport;
    use serialport::TTYPort;
    use std::os::fd::FromRawFd;

    /// A pty pair: the slave opened by its path through `serialport` (raw
    /// mode), the master wrapped directly. Returns (master, slave).
    pub fn pair() -> (SerialTransport, SerialTransport) {
        let (m, s) = open_with(|path| SerialTransport::open(path, 115_200).unwrap());
        (
            SerialTransport::from_port("pty-master".into(), Box::new(m)),
            s,
        )
    }

    /// Opens a pty, hands the slave's path to `open` (which must open it)
    /// and returns the raw master with what `open` made.
    pub fn open_with<T>(open: impl FnOnce(&str) -> T) -> (TTYPort, T) {
        let (mut master, mut slave) = (-1, -1);
        // SAFETY: openpty fills the two descriptors; null name/termios/winsize
        // are allowed.
        let r = unsafe {
            libc::openpty(
                &mut master,
                &mut slave,
                std::ptr::null_mut(),
                std::ptr::null(),
                std::ptr::null(),
            )
        };
        assert_eq!(r, 0, "openpty failed: {}", std::io::Error::last_os_error());
        let mut name = [0 as libc::c_char; 256];
        // SAFETY: `name` is a writable buffer of the given length.
        let r = unsafe { libc::ttyname_r(slave, name.as_mut_ptr(), name.len()) };
        assert_eq!(r, 0, "ttyname_r failed");
        // SAFETY: ttyname_r wrote a NUL-terminated string.
        let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) }
            .to_str()
            .unwrap()
            .to_owned();
        let s = open(&path);
        // SAFETY: `slave` is our descriptor; the port opened by path keeps the
        // device open.
        unsafe { libc::close(slave) };
        // SAFETY: `master` is an open descriptor we own from here on.
        let m = unsafe { TTYPort::from_raw_fd(master) };
        (m, s)
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use crate::testutil::link_exchange;
    use motet_wire::frame::{decode, encode, Flags, Header, MAX_FRAME};

    const WAIT: Option<Duration> = Some(Duration::from_secs(5));

    fn frame(seq: u16, payload: &[u8]) -> Vec<u8> {
        let h = Header {
            dst: 2,
            src: 1,
            port: 10,
            flags: Flags::DATA,
            seq,
            ack: 0,
        };
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&h, payload, &mut out).unwrap();
        out[..n].to_vec()
    }

    fn check(f: &[u8], seq: u16, payload: &[u8]) {
        let mut raw = [0u8; MAX_FRAME];
        let d = decode(f, &mut raw).unwrap();
        assert_eq!(d.header.seq, seq);
        assert_eq!(d.payload, payload);
    }

    #[test]
    fn frames_across_pty_both_ways() {
        let (mut m, mut s) = pty::pair();
        assert!(s.name().starts_with("serial:/dev/"));
        assert_eq!(s.recv(None).unwrap(), None);
        for (i, len) in [0usize, 1, 14, 100, 192].iter().enumerate() {
            let p: Vec<u8> = (0..*len).map(|k| (k * 7 + i) as u8).collect();
            m.send(&frame(i as u16, &p)).unwrap();
            check(&s.recv(WAIT).unwrap().unwrap(), i as u16, &p);
            s.send(&frame(100 + i as u16, &p)).unwrap();
            check(&m.recv(WAIT).unwrap().unwrap(), 100 + i as u16, &p);
        }
        assert_eq!(m.stats().frames_out, 5);
        assert_eq!(s.stats().frames_in, 5);
        assert_eq!(s.stats().bytes_in, m.stats().bytes_out);
    }

    #[test]
    fn many_frames_in_one_write() {
        let (mut m, mut s) = pty::pair();
        let payloads: Vec<Vec<u8>> = (0..10u8).map(|i| vec![i; 3 * i as usize]).collect();
        let mut blob = vec![0u8]; // a leading delimiter flushes line noise
        for (i, p) in payloads.iter().enumerate() {
            blob.extend(frame(i as u16, p));
        }
        m.write_raw(&blob).unwrap();
        for (i, p) in payloads.iter().enumerate() {
            check(&s.recv(WAIT).unwrap().unwrap(), i as u16, p);
        }
        assert_eq!(s.recv(None).unwrap(), None);
    }

    #[test]
    fn frame_split_across_writes() {
        let (mut m, mut s) = pty::pair();
        let p: Vec<u8> = (0..150u8).collect();
        let f = frame(42, &p);
        // Split points, data-driven: single bytes, ragged pieces, the
        // delimiter alone.
        let splits: &[&[usize]] = &[&[1], &[10, 50, 90], &[f.len() - 1]];
        for cuts in splits {
            let mut at = 0;
            for &c in cuts.iter() {
                m.write_raw(&f[at..c]).unwrap();
                // Nothing complete yet.
                assert_eq!(s.recv(Some(Duration::from_millis(10))).unwrap(), None);
                at = c;
            }
            m.write_raw(&f[at..]).unwrap();
            check(&s.recv(WAIT).unwrap().unwrap(), 42, &p);
        }
    }

    #[test]
    fn garbage_then_resync() {
        let (mut m, mut s) = pty::pair();
        let mut blob = vec![0x55, 0x13, 0x77, 0];
        blob.extend(frame(5, b"ok"));
        m.write_raw(&blob).unwrap();
        let bad = s.recv(WAIT).unwrap().unwrap();
        let mut raw = [0u8; MAX_FRAME];
        assert!(decode(&bad, &mut raw).is_err());
        check(&s.recv(WAIT).unwrap().unwrap(), 5, b"ok");
    }

    #[test]
    fn link_over_pty_delivers_in_order() {
        let (mut m, mut s) = pty::pair();
        let got = link_exchange(&mut m, &mut s, 300, Some(Duration::from_millis(20))).got;
        assert_eq!(got, (0..300).collect::<Vec<u32>>());
    }
}
