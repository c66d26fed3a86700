//! Bad input of every kind through the command line: the process fails with
//! an error that says where, and says each thing once.

use std::collections::HashSet;
use tempfile::TempDir;

mod common;
use common::motet;

fn scratch() -> TempDir {
    common::scratch("errors", "cases")
}

/// One bad input: files to write into the scratch folder, the command (`%`
/// stands for the scratch folder), and what the error must contain to say
/// where the problem is.
struct Case {
    files: &'static [(&'static str, &'static [u8])],
    args: &'static [&'static str],
    place: &'static str,
}

const PLOTTER: &[u8] = include_bytes!("../../../examples/plotter.toml");

/// A pairing file for `%/p.toml` (a copy of the plotter) with this body.
macro_rules! pairing {
    ($body:expr) => {
        &[("p.toml", PLOTTER), ("p.nodes.toml", $body)]
    };
}

const CASES: &[Case] = &[
    // Machine files.
    Case { files: &[], args: &["check", "%/none.toml"], place: "none.toml" },
    Case { files: &[("m.toml", b"name = \n")], args: &["check", "%/m.toml"], place: "m.toml:1:" },
    Case {
        files: &[("m.toml", b"name = \"m\"\n[axes.x]\ntravel = [0, 10]\nmax_velocity = \"fast\"\n")],
        args: &["check", "%/m.toml"],
        place: "m.toml:4:",
    },
    Case {
        files: &[("m.toml", b"name = \"m\"\n[axes.x]\ntravel = [0, 10]\nmax_velocty = 3\n")],
        args: &["check", "%/m.toml"],
        place: "m.toml:",
    },
    Case { files: &[("m.toml", b"name = \"\xff\xfe\"\n")], args: &["check", "%/m.toml"], place: "m.toml" },
    Case { files: &[], args: &["check", "%"], place: "motet-errors-" },
    // G-code.
    Case {
        files: &[("j.gcode", b"G1 X1..2 F100\n")],
        args: &["check", "examples/plotter.toml", "%/j.gcode"],
        place: "j.gcode:1:4",
    },
    Case {
        files: &[("j.gcode", b"G1 X1 F100\nG38.2 X5\n")],
        args: &["check", "examples/plotter.toml", "%/j.gcode"],
        place: "j.gcode:2:1",
    },
    Case {
        files: &[("j.gcode", b"G21\nG1 X10 F600\nG1 X900 F600\n")],
        args: &["run", "examples/plotter.toml", "%/j.gcode", "-q", "--out", "%/out"],
        place: "j.gcode:3",
    },
    Case {
        files: &[("j.gcode", b"G21\nG90\nG1 X10 Y10\n")],
        args: &["check", "examples/plotter.toml", "%/j.gcode"],
        place: "j.gcode:3:1",
    },
    Case {
        files: &[("j.gcode", b"G1 X1 F100\nG1 X\xff2\n")],
        args: &["check", "examples/plotter.toml", "%/j.gcode"],
        place: "j.gcode:2",
    },
    Case {
        files: &[("j.gcode.gz", b"not gzip at all")],
        args: &["check", "examples/plotter.toml", "%/j.gcode.gz"],
        place: "j.gcode.gz",
    },
    Case { files: &[], args: &["check", "examples/plotter.toml", "%/none.gcode"], place: "none.gcode" },
    Case {
        files: &[("j.docx", b"hello")],
        args: &["check", "examples/plotter.toml", "%/j.docx"],
        place: "j.docx",
    },
    // SVG and photos.
    Case {
        files: &[("j.svg", b"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">\n<path d=\"M0 0 L5 5\"\n")],
        args: &["check", "examples/plotter.toml", "%/j.svg"],
        place: "j.svg:",
    },
    Case { files: &[("j.svg", b"")], args: &["check", "examples/plotter.toml", "%/j.svg"], place: "j.svg" },
    Case { files: &[("j.png", b"\x89PNG garbage")], args: &["check", "examples/plotter.toml", "%/j.png"], place: "j.png" },
    Case { files: &[("j.jpg", b"")], args: &["check", "examples/plotter.toml", "%/j.jpg"], place: "j.jpg" },
    // Pairing files.
    Case { files: pairing!(b"[nodes.ebb]\nlink = 3\n"), args: &["nodes", "status", "%/p.toml"], place: "p.nodes.toml:2:8" },
    Case {
        files: pairing!(b"[nodes.ebb]\nlink = \"udp:127.0.0.1:9\"\naddress = 1\nuid = \"1\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n"),
        args: &["nodes", "status", "%/p.toml"],
        place: "p.nodes.toml: node ebb",
    },
    Case {
        files: pairing!(b"[nodes.ebb]\nlink = \"udp:127.0.0.1:9\"\naddress = 2\nuid = \"1\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n[nodes.pen]\nlink = \"udp:127.0.0.1:8\"\naddress = 3\nuid = \"01\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n"),
        args: &["run", "%/p.toml", "examples/jobs/drawing.svg", "--nodes", "paired"],
        place: "p.nodes.toml: nodes ebb and pen",
    },
    Case { files: &[("p.toml", PLOTTER)], args: &["nodes", "status", "%/p.toml"], place: "p.nodes.toml" },
    // Paired devices that cannot be reached (nothing answers on port 9).
    Case {
        files: pairing!(b"[nodes.ebb]\nlink = \"serial:/nonexistent/tty\"\naddress = 2\nuid = \"1\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n"),
        args: &["run", "%/p.toml", "examples/jobs/drawing.svg", "--nodes", "paired"],
        place: "node ebb",
    },
    Case {
        files: pairing!(b"[nodes.ebb]\nlink = \"udp:127.0.0.1:9\"\naddress = 2\nuid = \"1\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n"),
        args: &["run", "%/p.toml", "examples/jobs/drawing.svg", "--nodes", "paired"],
        place: "node ebb",
    },
    // Link specs.
    Case { files: &[], args: &["nodes", "scan", "--link", "carrier-pigeon:1"], place: "carrier-pigeon:1" },
    Case { files: &[], args: &["nodes", "scan", "--link", "udp:1.2.3"], place: "udp:1.2.3" },
    Case { files: &[], args: &["nodes", "scan", "--link", "serial:/nonexistent/tty"], place: "serial:/nonexistent/tty" },
    Case { files: &[], args: &["nodes", "scan", "--link", "slcan:/dev/null@7"], place: "slcan:/dev/null@7" },
    Case { files: &[], args: &["nodes", "pair", "examples/plotter.toml", "--link", "ebb"], place: "--link \"ebb\"" },
    Case {
        files: &[("p.toml", PLOTTER)],
        args: &["nodes", "pair", "%/p.toml", "--link", "ebb=serial:/nonexistent/tty"],
        place: "serial:/nonexistent/tty",
    },
    Case { files: &[], args: &["node", "--sim", "--listen", "tcp:1"], place: "tcp:1" },
    // Graph files, runs, firmware.
    Case { files: &[], args: &["dance", "examples/plotter.toml", "%/none.toml"], place: "none.toml" },
    Case {
        files: &[("g.toml", b"[[component]]\nkind = 7\n")],
        args: &["dance", "examples/plotter.toml", "%/g.toml"],
        place: "g.toml:",
    },
    Case { files: &[], args: &["resume", "%"], place: "resume.toml" },
    Case {
        files: &[],
        args: &["nodes", "image", "--kind", "stepper", "--version", "1.0.0", "%/none.bin", "-o", "%/x.img"],
        place: "none.bin",
    },
    Case {
        files: &[("fw.bin", b"payload")],
        args: &["nodes", "image", "--kind", "stepper", "--version", "1.x", "%/fw.bin", "-o", "%/x.img"],
        place: "--version",
    },
    Case {
        files: pairing!(b"[nodes.ebb]\nlink = \"udp:127.0.0.1:9\"\naddress = 2\nuid = \"1\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n"),
        args: &["nodes", "flash", "%/p.toml", "ebb", "%/none.img"],
        place: "none.img",
    },
    Case {
        files: &[
            ("p.toml", PLOTTER),
            ("p.nodes.toml", b"[nodes.ebb]\nlink = \"udp:127.0.0.1:9\"\naddress = 2\nuid = \"1\"\nkind = \"stepper\"\nfirmware = \"0.1.0\"\n"),
            ("bad.img", b"not a firmware image"),
        ],
        args: &["nodes", "flash", "%/p.toml", "ebb", "%/bad.img"],
        place: "bad.img",
    },
    Case {
        files: &[("file", b"")],
        args: &["run", "examples/plotter.toml", "examples/jobs/drawing.svg", "-q", "--out", "%/file/out"],
        place: "file/out",
    },    // The grbl device's port.
    Case { files: &[], args: &["serve", "examples/plotter.toml", "--grbl", "tcp:nowhere"], place: "--grbl" },
    Case { files: &[], args: &["serve", "examples/plotter.toml", "--grbl", "serial"], place: "--grbl" },
    Case {
        files: &[],
        args: &["serve", "examples/plotter.toml", "--listen", "127.0.0.1:0", "--dir", "%/srv", "--grbl", "tcp:192.0.2.1:1"],
        place: "--grbl tcp:192.0.2.1:1",
    },
];

/// Phrases of an error text: pieces between `: `, `; `, `. ` and line
/// breaks, of more than one word (a path or a number alone may recur).
fn phrases(text: &str) -> Vec<String> {
    text.lines()
        .flat_map(|l| {
            l.split(": ")
                .flat_map(|p| p.split("; "))
                .flat_map(|p| p.split(". "))
        })
        .map(|p| p.trim().trim_end_matches('.').to_string())
        .filter(|p| p.contains(' '))
        .collect()
}

/// A phrase said twice, or said again with more after it (`cannot open X`
/// then `cannot open X@115200`).
fn repeated(text: &str) -> Option<String> {
    let phrases = phrases(text);
    let mut seen = HashSet::new();
    if let Some(p) = phrases.iter().find(|p| !seen.insert(p.as_str())) {
        return Some(p.clone());
    }
    phrases
        .iter()
        .find(|p| phrases.iter().any(|q| q != *p && q.starts_with(p.as_str())))
        .cloned()
}

#[test]
fn every_bad_input_fails_with_a_located_error_said_once() {
    let tmp = scratch();
    let dir = tmp.path();
    let at = |s: &str| s.replace('%', dir.to_str().unwrap());
    let mut failures = Vec::new();
    for case in CASES {
        for (name, bytes) in case.files {
            std::fs::write(dir.join(name), bytes).unwrap();
        }
        let args: Vec<String> = case.args.iter().map(|a| at(a)).collect();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (ok, _, stderr) = motet(&args);
        let error = stderr
            .lines()
            .filter(|l| l.starts_with("error: "))
            .collect::<Vec<_>>();
        let problem = if ok {
            Some("succeeded".to_string())
        } else if stderr.contains("panicked") {
            Some("panicked".to_string())
        } else if error.len() != 1 {
            Some(format!("{} error lines", error.len()))
        } else if !error[0].contains(case.place) {
            Some(format!("does not name `{}`", case.place))
        } else if error[0].contains(":0:0:") || error[0].contains(":0: ") {
            Some("gives line 0 as a place".to_string())
        } else {
            repeated(&stderr).map(|p| format!("says `{p}` twice"))
        };
        if std::env::var("SHOW").is_ok() {
            eprintln!("{args:?}\n{stderr}");
        }
        if let Some(p) = problem {
            failures.push(format!("{args:?}: {p}:\n{stderr}"));
        }
        for (name, _) in case.files {
            let _ = std::fs::remove_file(dir.join(name));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_repeat_finder_finds_repeats() {
    // (text, repeated phrase)
    let cases = [
        (
            "error: a: cannot open x: no such file: no such file",
            Some("no such file"),
        ),
        ("error: cannot read a.toml: is a.toml a file?", None),
        ("error: m.toml:3:1: bad value; bad value", Some("bad value")),
        ("error: x: y: x: y", None),
        ("w: one thing. one thing.\nerror: other", Some("one thing")),
        (
            "error: cannot open a b: cannot open a b@9: gone",
            Some("cannot open a b"),
        ),
    ];
    for (text, want) in cases {
        assert_eq!(repeated(text).as_deref(), want, "{text}");
    }
}
