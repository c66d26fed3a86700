//! Recordings as files in the paper's format: the stencil's recorded layer
//! saved as `PATH` (one byte per frame) and `PATH.len` (the sample count),
//! decoded, and loaded into a graph whose player replays it.

use motet_graph::GraphFile;
use motet_host::Machine;
use motet_sim::dance::{
    run_dance, run_dance_with, CsvTrace, DanceOptions, DanceReport, InputSource, Recording,
    DANCE_TAPE,
};
use std::path::{Path, PathBuf};
use tempfile::TempDir;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dance/stencil")
}

/// A path `name` in an empty scratch folder, which is removed when the
/// returned guard is dropped.
fn scratch(name: &str) -> (TempDir, PathBuf) {
    let d = tempfile::Builder::new()
        .prefix("motet-dance-recording-")
        .tempdir()
        .unwrap();
    let path = d.path().join(name);
    (d, path)
}

fn index(r: &DanceReport, name: &str) -> usize {
    r.channels.iter().position(|c| c.name == name).unwrap()
}

/// Forward and reverse steps of channel `k` between stage marks `i` and
/// `i + 1`.
fn span(r: &DanceReport, i: usize, k: usize) -> (u64, u64) {
    let (a, b) = (&r.stage_marks[i], &r.stage_marks[i + 1]);
    (
        b.steps_forward[k] - a.steps_forward[k],
        b.steps_reverse[k] - a.steps_reverse[k],
    )
}

/// A player replaying the tape into the stencil printer's x/y channels, from
/// the first frame until it finishes.
const PLAYER: &str = r#"
frame_us = 40

[components.player]
kind = "player"
ratios = { track0 = [40.0, 3200.0], track1 = [40.0, 3200.0] }

[components.ch_x]
kind = "channel"
units = 40
steps = 3200
actuator = "x_motor"

[components.ch_y]
kind = "channel"
units = 40
steps = 3200
actuator = "y_motor"

[[map]]
from = "player.track0"
to = "ch_x.target"

[[map]]
from = "player.track1"
to = "ch_y.target"

[[stage]]
name = "replay"
set = { "player.play" = 1 }
until = { finished = "player" }
next = "end"
"#;

struct NoInputs;

impl InputSource for NoInputs {
    fn values(&mut self, _t_s: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
    }
}

#[test]
fn stencil_recording_saves_decodes_and_replays() {
    let m = Machine::load(&dir().join("machine.toml")).unwrap();
    let g = GraphFile::load(&dir().join("graph.toml")).unwrap();
    let mut t = CsvTrace::load(&dir().join("inputs.csv"), &g).unwrap();
    let end = t.end();
    let run = run_dance(&m, &g, &mut t, end, &mut |_| {}).unwrap();
    let r = &run.report;
    assert_eq!(r.stage_marks[1].stage, "record#1");

    // The tape: one byte per frame of the `record` stage.
    let (_tmp, path) = scratch("stencil.rec");
    run.recording.save(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let len_text = std::fs::read_to_string(Recording::len_path(&path)).unwrap();
    assert_eq!(len_text, format!("{}\n", bytes.len()));
    assert_eq!(bytes.len(), run.recording.len());
    let record_frames =
        ((r.stage_marks[2].t_s - r.stage_marks[1].t_s) * 1e6 / g.frame_us).round() as usize;
    assert!(
        bytes.len().abs_diff(record_frames) <= 1,
        "{} samples, {record_frames} frames recording",
        bytes.len()
    );

    // Decoding the bytes gives the steps the channels made while recording
    // (one recorded step per motor step); tracks 2 and 3 are silent.
    let loaded = Recording::load(&path).unwrap();
    assert_eq!(loaded, run.recording);
    let counts = loaded.counts();
    let (kx, ky) = (index(r, "ch_x"), index(r, "ch_y"));
    assert_eq!(counts[0], span(r, 1, kx));
    assert_eq!(counts[1], span(r, 1, ky));
    assert_eq!(counts[2..], [(0, 0), (0, 0)]);
    assert!(counts[0].0 > 2000 && counts[1].1 > 2000, "{counts:?}");
    // Bits: 11 forward, 10 reverse, 00 none; never 01.
    for b in &bytes {
        for i in 0..4 {
            assert_ne!((b >> (2 * i)) & 0b11, 0b01, "{b:#010b}");
        }
    }

    // Loaded into a graph with a player, the same steps come out.
    let pg = GraphFile::parse(PLAYER, "player.toml").unwrap();
    let options = DanceOptions {
        job: None,
        recording: Some(&loaded),
    };
    let seconds = (loaded.len() as f64 + 100.0) * g.frame_us * 1e-6;
    let played = run_dance_with(&m, &pg, &mut NoInputs, options, seconds, &mut |_| {})
        .unwrap()
        .report;
    let names: Vec<&str> = played
        .stage_marks
        .iter()
        .map(|s| s.stage.as_str())
        .collect();
    assert_eq!(names, ["replay#1", "end"]);
    for (k, name) in [(0, "ch_x"), (1, "ch_y")] {
        let c = &played.channels[index(&played, name)];
        assert_eq!((c.steps_forward, c.steps_reverse), counts[k], "{name}");
        assert!(c.error_steps.abs() <= 0.5, "{c:?}");
    }
    // The player's steps land where the recording's do: the net of the
    // recorded layer.
    let net = |(f, b): (u64, u64)| f as f64 - b as f64;
    assert_eq!(
        played.channels[index(&played, "ch_x")].position_steps,
        net(counts[0])
    );
    assert_eq!(
        played.channels[index(&played, "ch_y")].position_steps,
        net(counts[1])
    );
}

#[test]
fn malformed_recordings_name_the_file() {
    let (_tmp, path) = scratch("bad.rec");
    std::fs::write(&path, [0b1111u8, 0b1010, 0]).unwrap();
    let lp = Recording::len_path(&path);
    let lps = lp.display().to_string();

    let e = Recording::load(&path).unwrap_err().to_string();
    assert!(e.starts_with(&lps) && e.contains("cannot read"), "{e}");

    for (text, says) in [
        ("", "found ``"),
        ("three\n", "found `three`"),
        ("-1\n", "found `-1`"),
        ("3 4\n", "found `3 4`"),
        ("4\n", "says 4 samples"),
    ] {
        std::fs::write(&lp, text).unwrap();
        let e = Recording::load(&path).unwrap_err().to_string();
        assert!(e.starts_with(&lps) && e.contains(says), "{text:?}: {e}");
    }

    // Fewer samples than bytes: the first ones.
    std::fs::write(&lp, " 2 \n").unwrap();
    let r = Recording::load(&path).unwrap();
    assert_eq!(r.bytes, [0b1111, 0b1010]);
    assert_eq!(r.counts()[0], (1, 1));
    assert_eq!(r.counts()[1], (1, 1));

    // Too long for the node's tape.
    let m = Machine::load(&dir().join("machine.toml")).unwrap();
    let pg = GraphFile::parse(PLAYER, "player.toml").unwrap();
    let big = Recording {
        bytes: vec![0; DANCE_TAPE + 1],
    };
    let options = DanceOptions {
        job: None,
        recording: Some(&big),
    };
    let e = run_dance_with(&m, &pg, &mut NoInputs, options, 0.01, &mut |_| {})
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("tape only"), "{e}");
}
