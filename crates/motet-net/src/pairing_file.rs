//! The pairing file: which device on which link is each node of a machine.
//!
//! `motet nodes pair` writes it beside the machine file (`printer.toml` →
//! `printer.nodes.toml`); later runs read it and need no pairing:
//!
//! ```toml
//! [nodes.mainboard]
//! link = "udp:127.0.0.1:47001"
//! address = 2
//! uid = "00c0ffee12345678"
//! kind = "stepper"
//! firmware = "0.1.0"
//! ```

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One paired node.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairedNode {
    /// Link spec the node is reached on (see `motet_link::open`).
    pub link: String,
    /// Node address assigned at pairing.
    pub address: u16,
    /// The device's unique id, hex.
    pub uid: String,
    /// Node type reported by the device.
    pub kind: String,
    /// Firmware version at pairing.
    pub firmware: String,
}

/// All paired nodes of a machine, by machine node name.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairingFile {
    /// Each paired node, keyed by its machine node's name.
    #[serde(default)]
    pub nodes: BTreeMap<String, PairedNode>,
}

/// Why a pairing file was refused; pairing again (`motet nodes pair`)
/// writes a good one.
#[derive(Debug, thiserror::Error)]
pub enum PairingFileError {
    /// The file could not be read.
    #[error("{path}: {error}")]
    Io {
        /// The pairing file's path.
        path: String,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// The file is not valid TOML or has unknown keys; the message starts with
    /// line and column.
    #[error("{path}:{message}")]
    Parse {
        /// The pairing file's path.
        path: String,
        /// `line:column: ` and what TOML or serde found wrong.
        message: String,
    },
    /// A node's address or uid is not valid.
    #[error("{path}: node {node}: {message}")]
    Invalid {
        /// The pairing file's path.
        path: String,
        /// The machine node's name (its table key).
        node: String,
        /// What is wrong with its address or uid.
        message: String,
    },
    /// Two machine nodes are paired with one device.
    #[error("{path}: nodes {first} and {second} are both {device}: each machine node needs its own device; pair again with `motet nodes pair`")]
    SameDevice {
        /// The pairing file's path.
        path: String,
        /// One machine node.
        first: String,
        /// The other.
        second: String,
        /// How the device is named in both: "uid …" or "address … on LINK".
        device: String,
    },
}

/// Where the pairing file of `machine` lives: beside it, `NAME.nodes.toml`.
pub fn pairing_path(machine: &Path) -> PathBuf {
    let stem = machine
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "machine".into());
    machine.with_file_name(format!("{stem}.nodes.toml"))
}

/// Parses the uid written as hex.
pub fn parse_uid(s: &str) -> Option<u64> {
    u64::from_str_radix(s.trim_start_matches("0x"), 16).ok()
}

/// The uid as written in the file.
pub fn format_uid(uid: u64) -> String {
    format!("{uid:016x}")
}

impl PairingFile {
    /// Reads and checks a pairing file. Errors name the file and, for syntax
    /// errors, line and column.
    pub fn load(path: &Path) -> Result<PairingFile, PairingFileError> {
        let text = std::fs::read_to_string(path).map_err(|error| PairingFileError::Io {
            path: path.display().to_string(),
            error,
        })?;
        PairingFile::parse(&text, &path.display().to_string())
    }

    /// Parses and checks pairing file text (`path` names it in errors):
    /// addresses in 2..=65519, uids in hex, no device paired twice.
    pub fn parse(text: &str, path: &str) -> Result<PairingFile, PairingFileError> {
        let file: PairingFile = toml::from_str(text).map_err(|e| PairingFileError::Parse {
            path: path.to_string(),
            message: toml_location(text, &e),
        })?;
        for (name, n) in &file.nodes {
            let bad = |message: String| PairingFileError::Invalid {
                path: path.to_string(),
                node: name.clone(),
                message,
            };
            if !(2..=0xFFEF).contains(&n.address) {
                return Err(bad(format!("address {} is not in 2..=65519", n.address)));
            }
            if parse_uid(&n.uid).is_none() {
                return Err(bad(format!("uid {:?} is not a hex number", n.uid)));
            }
        }
        file.check_devices(path)?;
        Ok(file)
    }

    /// Two machine nodes on one device would get each other's motion: the
    /// same uid, or the same address on the same link, is refused.
    fn check_devices(&self, path: &str) -> Result<(), PairingFileError> {
        let nodes: Vec<_> = self.nodes.iter().collect();
        for (k, (first, a)) in nodes.iter().enumerate() {
            for (second, b) in &nodes[k + 1..] {
                let device = if parse_uid(&a.uid) == parse_uid(&b.uid) {
                    format!("uid {}", a.uid)
                } else if a.link == b.link && a.address == b.address {
                    format!("address {} on {}", a.address, a.link)
                } else {
                    continue;
                };
                return Err(PairingFileError::SameDevice {
                    path: path.to_string(),
                    first: first.to_string(),
                    second: second.to_string(),
                    device,
                });
            }
        }
        Ok(())
    }

    /// Writes the file (creating or replacing it).
    pub fn save(&self, path: &Path) -> Result<(), PairingFileError> {
        let body = toml::to_string_pretty(self).expect("pairing file serialises");
        let text = format!(
            "# Written by `motet nodes pair` (or `motet machine from-scan`): the device behind each node of the machine.\n{body}"
        );
        std::fs::write(path, text).map_err(|error| PairingFileError::Io {
            path: path.display().to_string(),
            error,
        })
    }
}

/// "line:column: message" for a TOML error.
fn toml_location(text: &str, e: &toml::de::Error) -> String {
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("{line}:{col}: {}", e.message())
        }
        None => format!(" {}", e.message()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let mut f = PairingFile::default();
        f.nodes.insert(
            "mainboard".into(),
            PairedNode {
                link: "udp:127.0.0.1:47001".into(),
                address: 2,
                uid: format_uid(0xc0ffee),
                kind: "stepper".into(),
                firmware: "0.1.0".into(),
            },
        );
        let dir = tempfile::Builder::new()
            .prefix("motet-pairing-")
            .tempdir()
            .unwrap();
        let path = dir.path().join("m.nodes.toml");
        f.save(&path).unwrap();
        assert_eq!(PairingFile::load(&path).unwrap(), f);
    }

    #[test]
    fn bad_files_say_where() {
        // (text, expected part of the error)
        let cases = [
            ("[nodes.a]\nlink = 3\n", "2:8"),
            (
                "[nodes.a]\nlink='x'\naddress=1\nuid='1'\nkind='k'\nfirmware='1'\n",
                "node a: address 1",
            ),
            (
                "[nodes.a]\nlink='x'\naddress=2\nuid='zz'\nkind='k'\nfirmware='1'\n",
                "uid \"zz\"",
            ),
            (
                "[nodes.a]\nlink='x'\naddress=2\nuid='1'\nkind='k'\nfirmware='1'\ncolour=1\n",
                "7:1",
            ),
            (
                "[nodes.a]\nlink='x'\naddress=2\nuid='0a'\nkind='k'\nfirmware='1'\n\
                 [nodes.b]\nlink='y'\naddress=3\nuid='000000000000000A'\nkind='k'\nfirmware='1'\n",
                "nodes a and b are both uid 0a",
            ),
            (
                "[nodes.a]\nlink='x'\naddress=2\nuid='1'\nkind='k'\nfirmware='1'\n\
                 [nodes.b]\nlink='x'\naddress=3\nuid='2'\nkind='k'\nfirmware='1'\n\
                 [nodes.c]\nlink='x'\naddress=2\nuid='3'\nkind='k'\nfirmware='1'\n",
                "nodes a and c are both address 2 on x",
            ),
        ];
        for (text, want) in cases {
            let e = PairingFile::parse(text, "p.toml").unwrap_err().to_string();
            assert!(
                e.contains(want) && e.starts_with("p.toml"),
                "{text:?} gave {e}"
            );
        }
    }

    #[test]
    fn distinct_devices_are_accepted() {
        // (the same link with other addresses, the same address on other links)
        let text = "[nodes.a]\nlink='x'\naddress=2\nuid='1'\nkind='k'\nfirmware='1'\n\
                    [nodes.b]\nlink='x'\naddress=3\nuid='2'\nkind='k'\nfirmware='1'\n\
                    [nodes.c]\nlink='y'\naddress=2\nuid='3'\nkind='k'\nfirmware='1'\n";
        assert_eq!(PairingFile::parse(text, "p.toml").unwrap().nodes.len(), 3);
    }

    #[test]
    fn path_beside_machine() {
        assert_eq!(
            pairing_path(Path::new("examples/printer.toml")),
            PathBuf::from("examples/printer.nodes.toml")
        );
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_text_never_panics(s in ".{0,200}") {
            let _ = PairingFile::parse(&s, "p.toml");
        }
    }
}
