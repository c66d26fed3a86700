//! Simulated node processes started by the host (`motet run --nodes spawn`).

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

/// A node process; killed when dropped, unless let go
/// ([`SpawnedNode::detach`]).
pub struct SpawnedNode {
    child: Child,
    /// Left running when dropped.
    detached: bool,
    /// Link spec to reach it, e.g. `udp:127.0.0.1:40123`.
    pub link: String,
    /// Its unique id.
    pub uid: u64,
}

/// Why a simulated node process could not be started.
#[derive(Debug, thiserror::Error)]
pub enum SpawnError {
    /// The executable could not be run.
    #[error("cannot start {exe}: {error}")]
    Start {
        /// The executable's path.
        exe: String,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// Its log file could not be created.
    #[error("cannot create the node's log {path}: {error}")]
    Log {
        /// The log's path.
        path: String,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// Its first line on stdout was not the announcement (what it printed;
    /// empty if it exited first). The process is killed.
    #[error("node process did not announce its link (it printed {0:?})")]
    NoAnnounce(String),
}

/// The line a node started with `--announce` prints first on stdout.
pub fn announce_line(link: &str, uid: u64) -> String {
    format!("motet-node listening {link} uid {uid:016x}")
}

/// Parses [`announce_line`].
pub fn parse_announce(line: &str) -> Option<(String, u64)> {
    let rest = line.trim().strip_prefix("motet-node listening ")?;
    let (link, uid) = rest.split_once(" uid ")?;
    Some((link.to_string(), u64::from_str_radix(uid, 16).ok()?))
}

/// Starts `exe node --sim --type KIND --listen udp:127.0.0.1:0 --announce`
/// plus `extra` arguments, and waits for its announcement.
pub fn spawn_sim_node(exe: &Path, kind: &str, extra: &[String]) -> Result<SpawnedNode, SpawnError> {
    spawn_sim_node_on(exe, kind, "udp:127.0.0.1:0", extra)
}

/// [`spawn_sim_node`] listening on `listen` (a port of its own, to be
/// started again where it was).
pub fn spawn_sim_node_on(
    exe: &Path,
    kind: &str,
    listen: &str,
    extra: &[String],
) -> Result<SpawnedNode, SpawnError> {
    spawn_sim_node_logged(exe, kind, listen, extra, None)
}

/// [`spawn_sim_node_on`] with what the node says on stderr written to
/// `log` (created or emptied), else to this process's stderr. A node that
/// outlives this process (detached) then holds none of its pipes.
pub fn spawn_sim_node_logged(
    exe: &Path,
    kind: &str,
    listen: &str,
    extra: &[String],
    log: Option<&Path>,
) -> Result<SpawnedNode, SpawnError> {
    let stderr = match log {
        None => Stdio::inherit(),
        Some(p) => Stdio::from(std::fs::File::create(p).map_err(|error| SpawnError::Log {
            path: p.display().to_string(),
            error,
        })?),
    };
    let mut child = Command::new(exe)
        .args([
            "node",
            "--sim",
            "--type",
            kind,
            "--listen",
            listen,
            "--announce",
        ])
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(stderr)
        .spawn()
        .map_err(|error| SpawnError::Start {
            exe: exe.display().to_string(),
            error,
        })?;
    let stdout = child.stdout.take().expect("stdout is piped");
    let mut line = String::new();
    let _ = BufReader::new(stdout).read_line(&mut line);
    match parse_announce(&line) {
        Some((link, uid)) => Ok(SpawnedNode {
            child,
            detached: false,
            link,
            uid,
        }),
        None => {
            let _ = child.kill();
            let _ = child.wait();
            Err(SpawnError::NoAnnounce(line))
        }
    }
}

impl SpawnedNode {
    /// The process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Kills the process (a node crash, for tests).
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Lets the process run on after this (a stopped run's node, waiting
    /// for `motet resume` until its `--idle-exit`).
    pub fn detach(mut self) {
        self.detached = true;
    }
}

impl Drop for SpawnedNode {
    fn drop(&mut self) {
        if !self.detached {
            self.kill();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn announce_round_trip() {
        let l = announce_line("udp:127.0.0.1:4000", 0xabc);
        assert_eq!(
            parse_announce(&l),
            Some(("udp:127.0.0.1:4000".into(), 0xabc))
        );
        for bad in [
            "",
            "motet-node listening",
            "motet-node listening x uid zz",
            "hello",
        ] {
            assert_eq!(parse_announce(bad), None, "{bad:?}");
        }
    }
}
