//! Pairing files (`MACHINE.nodes.toml`): parsed as every networked run reads
//! them; one that parses writes back to the same nodes.

use crate::text;
use motet_net::pairing_file::{PairingFile, PairingFileError};

/// Runs pairing-file bytes through the parser and, when they parse, a round
/// trip through the text `motet nodes pair` writes.
pub fn pairing_file(data: &[u8]) {
    let Some(text) = text(data) else { return };
    match PairingFile::parse(text, "fuzz.nodes.toml") {
        Ok(file) => {
            let written = toml::to_string_pretty(&file).expect("a pairing file serialises");
            match PairingFile::parse(&written, "written.nodes.toml") {
                Ok(again) => assert_eq!(again, file, "round trip changed the pairing file"),
                Err(e) => panic!("a pairing file that parsed does not read back: {e}\n{written}"),
            }
        }
        Err(PairingFileError::Parse { message, .. }) => {
            assert!(!message.trim().is_empty(), "an empty pairing file error")
        }
        Err(PairingFileError::Invalid { message, .. }) => {
            assert!(!message.trim().is_empty(), "an empty pairing file error")
        }
        Err(e @ PairingFileError::SameDevice { .. }) => {
            assert!(e.to_string().contains("fuzz.nodes.toml"), "{e}")
        }
        Err(e @ PairingFileError::Io { .. }) => panic!("parsing text gave an I/O error: {e}"),
    }
}
