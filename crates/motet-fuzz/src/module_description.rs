//! Module description files (`motet node --sim --describe FILE`, and the
//! `[modules.NAME.description]` of a machine file composed from modules):
//! parsed as the node and the host read them. One that parses writes back
//! to the same description, travels the wire in parts to the same
//! description, and composes without a panic; one that does not is refused
//! at a line of the file.

use crate::text;
use motet_host::module::{compose, description_toml, parse_description, viability, ModuleAt};
use motet_wire::describe::Assembler;

/// Runs description-file bytes through the parser and, when they parse,
/// the round trips and a composition of the module alone.
pub fn module_description(data: &[u8]) {
    let Some(text) = text(data) else { return };
    match parse_description(text, "fuzz.toml") {
        Ok(d) => {
            let written = description_toml(&d, "");
            match parse_description(&written, "written.toml") {
                Ok(again) => assert_eq!(again, d, "the round trip changed the description"),
                Err(e) => panic!("a description that parsed does not read back: {e}\n{written}"),
            }
            let mut a = Assembler::new(d.head(7)).expect("a head the node makes");
            for i in 1..d.parts() {
                a.take(i, d.part(7, i).expect("a part it has"))
                    .expect("its own part in its place");
            }
            assert_eq!(
                a.finish().as_ref(),
                Ok(&d),
                "the wire changed the description"
            );
            let c = compose(&[ModuleAt {
                uid: 7,
                firmware: None,
                description: d,
            }]);
            let _ = viability::check(&c);
        }
        Err(e) => {
            assert!(e.line >= 1, "an error without its line: {e}");
            assert!(e.to_string().starts_with("fuzz.toml:"), "{e}");
            assert!(!e.message.trim().is_empty(), "an empty error: {e}");
        }
    }
}
