//! Where a grbl sender connects: a pseudo-terminal (its path is printed;
//! senders open it as a serial port) or a TCP port (loopback unless told
//! otherwise; one sender at a time). A thread per port moves bytes between
//! the sender and its [`Grbl`], which acts on the server's session.

use super::Grbl;
use crate::server::{Server, Shared};
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;
use std::time::Duration;

/// How long a read waits for bytes: the latency of a `?` or `!`.
const READ_WAIT: Duration = Duration::from_millis(2);

/// Where senders connect.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Port {
    /// A new pseudo-terminal.
    Pty,
    /// TCP on this address.
    Tcp(SocketAddr),
}

impl std::fmt::Display for Port {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Port::Pty => f.write_str("pty"),
            Port::Tcp(a) => write!(f, "tcp:{a}"),
        }
    }
}

impl std::str::FromStr for Port {
    type Err = String;

    fn from_str(s: &str) -> Result<Port, String> {
        if s == "pty" {
            return Ok(Port::Pty);
        }
        let Some(addr) = s.strip_prefix("tcp:") else {
            return Err(format!(
                "{s:?}: expected `pty` or `tcp:ADDRESS:PORT` (e.g. tcp:127.0.0.1:23)"
            ));
        };
        addr.parse().map(Port::Tcp).map_err(|e| {
            format!("{s:?}: {e}: expected `pty` or `tcp:ADDRESS:PORT` (e.g. tcp:127.0.0.1:23)")
        })
    }
}

impl Server {
    /// Opens a grbl device on `port` for this server's session; returns
    /// where senders connect (the pty's path, or `tcp:ADDRESS:PORT`).
    pub fn grbl(&self, port: &Port) -> io::Result<String> {
        let shared = self.shared.clone();
        let machine = shared.machine.as_ref().clone();
        match port {
            Port::Pty => {
                let (master, path) = pty::open()?;
                std::thread::Builder::new()
                    .name("motet-grbl-pty".into())
                    .spawn(move || {
                        let mut io = master;
                        let mut g = Grbl::new(&machine);
                        g.open();
                        // A sender closing the pty is no error: the slave
                        // stays open here, so the next one finds it.
                        while !shared.stopped() {
                            if pump(&shared, &mut io, &mut g).is_err() {
                                std::thread::sleep(Duration::from_millis(20));
                            }
                        }
                    })?;
                Ok(path)
            }
            Port::Tcp(addr) => {
                let listener = TcpListener::bind(addr)?;
                let local = listener.local_addr()?;
                listener.set_nonblocking(true)?;
                std::thread::Builder::new()
                    .name("motet-grbl-tcp".into())
                    .spawn(move || serve_tcp(&shared, &listener, &machine))?;
                Ok(format!("tcp:{local}"))
            }
        }
    }
}

fn serve_tcp(shared: &Arc<Shared>, listener: &TcpListener, machine: &motet_host::Machine) {
    while !shared.stopped() {
        match listener.accept() {
            Ok((mut stream, _)) => {
                let ready = stream
                    .set_nonblocking(false)
                    .and_then(|()| stream.set_read_timeout(Some(READ_WAIT)))
                    .and_then(|()| stream.set_nodelay(true));
                if ready.is_err() {
                    continue;
                }
                let mut g = Grbl::new(machine);
                g.open();
                let _ = pump(shared, &mut stream, &mut g);
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20))
            }
            Err(_) => std::thread::sleep(Duration::from_millis(100)),
        }
    }
}

/// Moves bytes until the sender goes (`Ok`) or the link fails.
fn pump<T: Read + Write>(shared: &Shared, io: &mut T, g: &mut Grbl) -> io::Result<()> {
    let mut buf = [0u8; 1024];
    let mut out: Vec<u8> = Vec::new();
    while !shared.stopped() {
        // A sender that does not count characters and has filled the
        // buffer waits (its writes block) until lines are taken.
        let n = if !g.wants_input() {
            std::thread::sleep(READ_WAIT);
            0
        } else {
            match io.read(&mut buf) {
                Ok(0) => return Ok(()),
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock
                            | io::ErrorKind::TimedOut
                            | io::ErrorKind::Interrupted
                    ) =>
                {
                    0
                }
                Err(e) => return Err(e),
            }
        };
        {
            let mut s = shared.session();
            if n > 0 {
                g.receive(&buf[..n], &mut s);
            }
            g.poll(&mut s);
        }
        shared.wake();
        out.extend(g.take_output());
        while !out.is_empty() {
            match io.write(&out) {
                Ok(0) => return Ok(()),
                Ok(k) => {
                    out.drain(..k);
                }
                // A sender that does not read: keep it for later.
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(())
}

/// The pseudo-terminal: its master end, read with a short wait.
mod pty {
    use std::io::{self, Read, Write};
    use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};

    pub struct Master {
        fd: OwnedFd,
        /// The slave end, kept open so the master reads nothing but data
        /// when no sender has the pty open.
        _slave: OwnedFd,
    }

    /// A new pty in raw mode; returns its master and the slave's path.
    pub fn open() -> io::Result<(Master, String)> {
        let (mut m, mut s) = (-1, -1);
        // SAFETY: openpty fills the two descriptors; null name, termios and
        // winsize are allowed.
        let r = unsafe {
            libc::openpty(
                &mut m,
                &mut s,
                std::ptr::null_mut(),
                std::ptr::null(),
                std::ptr::null(),
            )
        };
        if r != 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: both are open descriptors we own from here on.
        let (fd, slave) = unsafe { (OwnedFd::from_raw_fd(m), OwnedFd::from_raw_fd(s)) };
        // Raw mode: no echo, no line editing, no CR/LF translation, so the
        // bytes a sender writes are the bytes read here.
        // SAFETY: termios is plain data filled by tcgetattr.
        unsafe {
            let mut t: libc::termios = std::mem::zeroed();
            if libc::tcgetattr(slave.as_raw_fd(), &mut t) != 0 {
                return Err(io::Error::last_os_error());
            }
            libc::cfmakeraw(&mut t);
            if libc::tcsetattr(slave.as_raw_fd(), libc::TCSANOW, &t) != 0 {
                return Err(io::Error::last_os_error());
            }
            let flags = libc::fcntl(fd.as_raw_fd(), libc::F_GETFL);
            libc::fcntl(fd.as_raw_fd(), libc::F_SETFL, flags | libc::O_NONBLOCK);
        }
        let mut name = [0 as libc::c_char; 256];
        // SAFETY: `name` is a writable buffer of the given length.
        let r = unsafe { libc::ttyname_r(slave.as_raw_fd(), name.as_mut_ptr(), name.len()) };
        if r != 0 {
            return Err(io::Error::from_raw_os_error(r));
        }
        // SAFETY: ttyname_r wrote a NUL-terminated string.
        let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) }
            .to_string_lossy()
            .into_owned();
        Ok((Master { fd, _slave: slave }, path))
    }

    impl Read for Master {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let mut p = libc::pollfd {
                fd: self.fd.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            let wait = super::READ_WAIT.as_millis() as libc::c_int;
            // SAFETY: one valid pollfd.
            let r = unsafe { libc::poll(&mut p, 1, wait) };
            if r <= 0 {
                return Err(io::ErrorKind::WouldBlock.into());
            }
            // SAFETY: `buf` is writable for its length.
            let n = unsafe { libc::read(self.fd.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
            if n < 0 {
                return Err(io::Error::last_os_error());
            }
            // Nothing read although poll said so: no sender has it open.
            if n == 0 {
                return Err(io::ErrorKind::WouldBlock.into());
            }
            Ok(n as usize)
        }
    }

    impl Write for Master {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            // SAFETY: `buf` is readable for its length.
            let n = unsafe { libc::write(self.fd.as_raw_fd(), buf.as_ptr().cast(), buf.len()) };
            if n < 0 {
                return Err(io::Error::last_os_error());
            }
            Ok(n as usize)
        }

        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }
}
