//! The node's tape as a file: what a `recorder` component recorded, or what
//! a `player` component plays back.

use super::DanceError;
use std::path::{Path, PathBuf};

/// A four-track recording in the paper's format: the bytes (one per frame,
/// track `i` in bits `2i..2i+1`: `11` forward, `10` reverse, `00` none) and
/// the sample count, kept apart (a file `PATH` with the bytes and `PATH.len`
/// with the count as decimal text and a newline).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Recording {
    /// The samples, exactly `len` of them.
    pub bytes: Vec<u8>,
}

impl Recording {
    /// Sample count.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Whether it holds no sample.
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// The companion file of `path`: `path` with `.len` appended.
    pub fn len_path(path: &Path) -> PathBuf {
        let mut s = path.as_os_str().to_owned();
        s.push(".len");
        s.into()
    }

    /// Each sample's steps, tracks 0..3 (−1, 0, +1).
    pub fn steps(&self) -> impl Iterator<Item = [i8; 4]> + '_ {
        self.bytes
            .iter()
            .map(|&b| motet_node::graph::record::unpack(b))
    }

    /// Forward and reverse steps of each track.
    pub fn counts(&self) -> [(u64, u64); 4] {
        let mut out = [(0u64, 0u64); 4];
        for s in self.steps() {
            for (o, x) in out.iter_mut().zip(s) {
                match x {
                    1 => o.0 += 1,
                    -1 => o.1 += 1,
                    _ => {}
                }
            }
        }
        out
    }

    /// Writes `path` (the bytes) and `path.len` (the sample count).
    pub fn save(&self, path: &Path) -> Result<(), DanceError> {
        let err = |p: &Path, e: std::io::Error| DanceError::Recording {
            file: p.display().to_string(),
            message: format!("cannot write: {e}"),
        };
        std::fs::write(path, &self.bytes).map_err(|e| err(path, e))?;
        let lp = Recording::len_path(path);
        std::fs::write(&lp, format!("{}\n", self.len())).map_err(|e| err(&lp, e))
    }

    /// Reads `path` and `path.len`: the count must be a decimal number (blank
    /// space around it is allowed) no larger than the bytes `path` holds;
    /// bytes past the count are ignored.
    pub fn load(path: &Path) -> Result<Recording, DanceError> {
        let lp = Recording::len_path(path);
        let err = |p: &Path, message: String| DanceError::Recording {
            file: p.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(&lp).map_err(|e| {
            err(
                &lp,
                format!("cannot read the sample count of {}: {e}", path.display()),
            )
        })?;
        let t = text.trim();
        let len: usize = t
            .parse()
            .ok()
            .filter(|_| t.bytes().all(|b| b.is_ascii_digit()))
            .ok_or_else(|| {
                err(
                    &lp,
                    format!("expected the sample count as a decimal number, found `{t}`"),
                )
            })?;
        let mut bytes = std::fs::read(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
        if len > bytes.len() {
            return Err(err(
                &lp,
                format!(
                    "says {len} samples, but {} holds only {} bytes",
                    path.display(),
                    bytes.len()
                ),
            ));
        }
        bytes.truncate(len);
        Ok(Recording { bytes })
    }
}
