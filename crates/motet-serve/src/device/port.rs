//! Where a program connects to a [`Device`]: a pseudo-terminal (its path is
//! printed; programs open it as a serial port), a TCP port (loopback
//! unless told otherwise; one program at a time) or a Unix socket (several
//! programs at once, a device each). A thread per port (and per Unix
//! connection) moves bytes between the program and its device, which acts
//! on the server's session.

use super::{pty, Device};
use crate::server::{Server, Shared};
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// How long a read waits for bytes: the latency of a `?` or `!`.
pub(super) const READ_WAIT: Duration = Duration::from_millis(2);

/// Where programs connect.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Port {
    /// A new pseudo-terminal.
    Pty,
    /// TCP on this address.
    Tcp(SocketAddr),
    /// A Unix socket at this path (made with mode 0600; a stale socket file
    /// left by a server that went is replaced).
    Unix(PathBuf),
}

impl std::fmt::Display for Port {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Port::Pty => f.write_str("pty"),
            Port::Tcp(a) => write!(f, "tcp:{a}"),
            Port::Unix(p) => write!(f, "unix:{}", p.display()),
        }
    }
}

impl std::str::FromStr for Port {
    type Err = String;

    fn from_str(s: &str) -> Result<Port, String> {
        if s == "pty" {
            return Ok(Port::Pty);
        }
        if let Some(p) = s.strip_prefix("unix:").filter(|p| !p.is_empty()) {
            return Ok(Port::Unix(PathBuf::from(p)));
        }
        let Some(addr) = s.strip_prefix("tcp:") else {
            return Err(format!(
                "{s:?}: expected `pty`, `tcp:ADDRESS:PORT` (e.g. tcp:127.0.0.1:23) or `unix:PATH`"
            ));
        };
        addr.parse().map(Port::Tcp).map_err(|e| {
            format!("{s:?}: {e}: expected `pty`, `tcp:ADDRESS:PORT` (e.g. tcp:127.0.0.1:23) or `unix:PATH`")
        })
    }
}

impl Server {
    /// Opens a device on `port` for this server's session, one made by
    /// `make` for each program that connects (a pty has one for its
    /// lifetime); returns where programs connect (the pty's path, or
    /// `tcp:ADDRESS:PORT`). `name` names the port's thread.
    pub fn device<D, F>(&self, name: &str, port: &Port, make: F) -> io::Result<String>
    where
        D: Device,
        F: Fn() -> D + Send + 'static,
    {
        let shared = self.shared.clone();
        match port {
            Port::Pty => {
                let (master, path) = pty::open()?;
                std::thread::Builder::new()
                    .name(format!("motet-{name}-pty"))
                    .spawn(move || {
                        let mut io = master;
                        let mut g = make();
                        g.open();
                        // A program closing the pty is no error: the slave
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
                only_loopback(addr)?;
                let listener = TcpListener::bind(addr)?;
                let local = listener.local_addr()?;
                listener.set_nonblocking(true)?;
                std::thread::Builder::new()
                    .name(format!("motet-{name}-tcp"))
                    .spawn(move || serve_tcp(&shared, &listener, &make))?;
                Ok(format!("tcp:{local}"))
            }
            Port::Unix(path) => {
                let listener = super::unix::bind(path)?;
                let name = name.to_string();
                std::thread::Builder::new()
                    .name(format!("motet-{name}-unix"))
                    .spawn(move || super::unix::serve(&shared, &listener, &name, make))?;
                Ok(format!("unix:{}", path.display()))
            }
        }
    }
}

fn serve_tcp<D: Device>(shared: &Arc<Shared>, listener: &TcpListener, make: &dyn Fn() -> D) {
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
                let mut g = make();
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

/// Moves bytes until the program goes (`Ok`) or the link fails.
pub(super) fn pump<T: Read + Write, D: Device>(
    shared: &Shared,
    io: &mut T,
    g: &mut D,
) -> io::Result<()> {
    let mut buf = [0u8; 1024];
    let mut out: Vec<u8> = Vec::new();
    while !shared.stopped() {
        // A program that has filled the device's buffer (a grbl sender
        // that does not count characters) waits, its writes blocking,
        // until lines are taken.
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
                // A program that does not read: keep it for later.
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(())
}

/// A device's TCP port is for programs on this computer: the protocols
/// carry no token, so one reachable from the network would let anyone there
/// move the machine.
fn only_loopback(addr: &SocketAddr) -> io::Result<()> {
    if addr.ip().is_loopback() {
        return Ok(());
    }
    Err(io::Error::new(
        io::ErrorKind::PermissionDenied,
        format!(
            "{addr} is reachable from other computers, and the protocol carries no token: \
             listen on 127.0.0.1 and reach it over an SSH tunnel"
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_ports_stay_on_this_computer() {
        for (addr, ok) in [
            ("127.0.0.1:23", true),
            ("[::1]:23", true),
            ("0.0.0.0:23", false),
            ("192.168.1.5:23", false),
            ("[::]:23", false),
        ] {
            let a: SocketAddr = addr.parse().unwrap();
            assert_eq!(only_loopback(&a).is_ok(), ok, "{addr}");
        }
    }
}
