//! A Unix socket port: several programs may connect at once (a printer
//! host keeps one connection and opens others for a moment), each with a
//! device of its own on a thread of its own, all on the same session.

use super::port::{pump, READ_WAIT};
use super::Device;
use crate::server::Shared;
use std::io;
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// Binds `path`, readable and writable by this user only. A socket file
/// nobody listens on (left by a server that was killed) is replaced; a
/// live one, or a file that is not a socket, is an error.
pub(super) fn bind(path: &Path) -> io::Result<UnixListener> {
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        if !meta.file_type().is_socket() {
            return Err(io::Error::new(
                io::ErrorKind::AlreadyExists,
                format!("{} exists and is not a socket", path.display()),
            ));
        }
        if UnixStream::connect(path).is_ok() {
            return Err(io::Error::new(
                io::ErrorKind::AddrInUse,
                format!("another program listens on {}", path.display()),
            ));
        }
        std::fs::remove_file(path)?;
    }
    let listener = UnixListener::bind(path)?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600))?;
    listener.set_nonblocking(true)?;
    Ok(listener)
}

/// Accepts connections until the server stops; the socket file goes then.
pub(super) fn serve<D, F>(shared: &Arc<Shared>, listener: &UnixListener, name: &str, make: F)
where
    D: Device,
    F: Fn() -> D + Send + 'static,
{
    let mut n = 0u64;
    while !shared.stopped() {
        match listener.accept() {
            Ok((stream, _)) => {
                let ready = stream
                    .set_nonblocking(false)
                    .and_then(|()| stream.set_read_timeout(Some(READ_WAIT)));
                if ready.is_err() {
                    continue;
                }
                n += 1;
                let mut g = make();
                let sh = shared.clone();
                let spawned = std::thread::Builder::new()
                    .name(format!("motet-{name}-unix-{n}"))
                    .spawn(move || {
                        let mut stream = stream;
                        g.open();
                        let _ = pump(&sh, &mut stream, &mut g);
                    });
                // No thread for it (the process is out of threads): the
                // connection closes as `stream` goes.
                drop(spawned);
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20))
            }
            Err(_) => std::thread::sleep(Duration::from_millis(100)),
        }
    }
    if let Ok(addr) = listener.local_addr() {
        if let Some(p) = addr.as_pathname() {
            let _ = std::fs::remove_file(p);
        }
    }
}
