//! The game-controller dance: a joystick's velocity generators and the
//! Step-a-Sketch knobs drive one CoreXY plotter (fan-in, incremental).

use motet_graph::GraphFile;
use motet_host::Machine;
use motet_sim::dance::{run_dance, CsvTrace, InputSource};
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dance/game-controller")
}

/// The joystick's mapping (graph.toml): raw 12..1012 → −40..40 mm/s, a
/// deadband of ±6 around 512.
fn speed(raw: f64) -> f64 {
    let raw = if (raw - 512.0).abs() <= 6.0 {
        512.0
    } else {
        raw
    };
    (-40.0 + (raw - 12.0) * 80.0 / 1000.0).clamp(-40.0, 40.0)
}

#[test]
fn game_controller_sums_joystick_and_knobs() {
    let m = Machine::load(&dir().join("machine.toml")).unwrap();
    let g = GraphFile::load(&dir().join("graph.toml")).unwrap();
    let mut t = CsvTrace::load(&dir().join("inputs.csv"), &g).unwrap();
    let end = t.end();
    let r = run_dance(&m, &g, &mut t.clone(), end, &mut |_| {}).unwrap();

    // Player one on its own: the velocity generators integrate the stick's
    // speed, frame by frame, as the node reads it (f32).
    let frame_s = g.frame_us * 1e-6;
    let n = (end / frame_s).round() as u64;
    let mut v = vec![0.0; g.inputs.len()];
    let (mut jx, mut jy) = (0.0, 0.0);
    for f in 0..n {
        t.values(f as f64 * frame_s, &mut v);
        jx += speed(v[0] as f32 as f64) * frame_s;
        jy += speed(v[1] as f32 as f64) * frame_s;
    }
    // Player two on its own: the knobs' last counts.
    t.values(end, &mut v);
    let (kx, ky) = (v[2].round() * 0.02, v[3].round() * 0.02);
    assert_eq!((kx, ky), (-80.0, -20.0));
    assert!((r.report.ports["vel_x.out"] - jx).abs() < 1e-6, "{jx}");
    assert!((r.report.ports["vel_y.out"] - jy).abs() < 1e-6, "{jy}");
    // The stick's circles close; its last push moves the pen up 36 mm.
    assert!(jx.abs() < 0.01 && (jy - 36.0).abs() < 0.01, "{jx} {jy}");

    // Each belt sits at the exact sum of both players, within half a step.
    let (x, y) = (kx + jx, ky + jy);
    let per_mm = 3200.0 / (std::f64::consts::PI * 9.0);
    for (name, want) in [("ch_a", x + y), ("ch_b", x - y)] {
        let c = r.report.channels.iter().find(|c| c.name == name).unwrap();
        assert!(
            (c.position_steps - want * per_mm).abs() <= 0.5,
            "{name}: {} vs {}",
            c.position_steps,
            want * per_mm
        );
        assert!(c.error_steps.abs() <= 0.5, "{c:?}");
        assert!(c.steps_forward > 5000 && c.steps_reverse > 5000, "{c:?}");
    }
    let [fx, fy] = r.report.final_xy;
    assert!((fx - x).abs() < 0.01 && (fy - y).abs() < 0.01, "{fx} {fy}");
}
