//! The stencil dance: the hand traces a layer while the recorder listens;
//! the stage machine returns, then replays the layer four times, raising z
//! a layer after each pass.

use motet_graph::GraphFile;
use motet_host::Machine;
use motet_sim::dance::{run_dance, CsvTrace, DanceReport};
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dance/stencil")
}

fn index(r: &DanceReport, name: &str) -> usize {
    r.channels.iter().position(|c| c.name == name).unwrap()
}

/// Steps (forward, reverse) of channel `k` between stage mark `i` and the
/// next (or the end), and its net position at mark `i`.
fn span(r: &DanceReport, i: usize, k: usize) -> (u64, u64, i64) {
    let a = &r.stage_marks[i];
    let (f1, r1) = match r.stage_marks.get(i + 1) {
        Some(b) => (b.steps_forward[k], b.steps_reverse[k]),
        None => (r.channels[k].steps_forward, r.channels[k].steps_reverse),
    };
    let net = a.steps_forward[k] as i64 - a.steps_reverse[k] as i64;
    (f1 - a.steps_forward[k], r1 - a.steps_reverse[k], net)
}

#[test]
fn stencil_replays_the_recorded_layer_layer_after_layer() {
    let m = Machine::load(&dir().join("machine.toml")).unwrap();
    let g = GraphFile::load(&dir().join("graph.toml")).unwrap();
    let mut t = CsvTrace::load(&dir().join("inputs.csv"), &g).unwrap();
    let end = t.end();
    let r = run_dance(&m, &g, &mut t, end, &mut |_| {}).unwrap().report;

    let names: Vec<&str> = r.stage_marks.iter().map(|s| s.stage.as_str()).collect();
    assert_eq!(
        names,
        [
            "position#1",
            "record#1",
            "return#1",
            "replay#1",
            "replay#2",
            "replay#3",
            "replay#4",
            "end"
        ]
    );
    // One layer up after the recorded one, then one after each of the four
    // passes: five layers of 0.5 mm at 400 steps/mm.
    let z = &r.channels[index(&r, "ch_z")];
    assert!((z.position_steps - 5.0 * 0.5 * 400.0).abs() <= 0.5, "{z:?}");
    assert_eq!(z.steps_reverse, 0);
    assert!((z.joint.unwrap() - 2.5).abs() < 1e-9, "{z:?}");

    for ch in ["ch_x", "ch_y"] {
        let k = index(&r, ch);
        let (fwd, rev, start) = span(&r, 1, k);
        // The star is some 100 mm round: thousands of steps each way.
        assert!(fwd > 2000 && rev > 2000, "{ch}: {fwd} {rev}");
        for pass in 3..7 {
            let (f, b, at) = span(&r, pass, k);
            assert_eq!((f, b), (fwd, rev), "{ch}: {}", r.stage_marks[pass].stage);
            // Each pass starts where the layer began (the star closes).
            assert_eq!(at, start, "{ch}: {}", r.stage_marks[pass].stage);
        }
        // The last mark ("end") comes after the fourth pass: nothing moves.
        let (f, b, at) = span(&r, 7, k);
        assert_eq!((f, b, at), (0, 0, start), "{ch}");
        let c = &r.channels[k];
        assert!(c.error_steps.abs() <= 0.5, "{c:?}");
    }
}
