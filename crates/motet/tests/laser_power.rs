//! M4: laser power that follows the actual speed, end to end from G-code to the
//! node's tool output.

use motet_api::job::{parse_job, JobKind, JobOptions};
use motet_host::Machine;
use motet_planner::{Planned, Planner};
use motet_sim::SimMachine;
use motet_trajectory::Segment;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Plans and runs `gcode` on the laser cutter; returns the planned segments and
/// the tool values the plant saw, with their times (µs).
fn run(gcode: &str) -> (Vec<Segment>, Vec<(f64, f32)>) {
    let m = Machine::load(&root().join("examples/laser.toml")).unwrap();
    let job = parse_job(
        &m,
        Path::new("m4.gcode"),
        JobKind::Gcode,
        gcode.as_bytes(),
        &JobOptions::default(),
    )
    .unwrap();
    let mut sim = SimMachine::new(&m).unwrap();
    sim.watch_tools(true);
    let mut planner = Planner::new(m.limits(), m.start, 0.0);
    let mut segs = vec![];
    let feed = |planner: &mut Planner, sim: &mut SimMachine, segs: &mut Vec<Segment>| {
        while let Some(p) = planner.pop() {
            if let Planned::Segment(s) = p {
                segs.push(s);
            }
            sim.submit(p).unwrap();
        }
    };
    for c in &job.commands {
        planner.push(&c.item).unwrap();
        feed(&mut planner, &mut sim, &mut segs);
    }
    planner.finish();
    feed(&mut planner, &mut sim, &mut segs);
    sim.run_until(planner.clock());
    sim.run_to_rest();
    let changes = sim
        .take_tool_changes()
        .into_iter()
        .map(|(t, _, v)| (t, v))
        .collect();
    (segs, changes)
}

fn speed_at(segs: &[Segment], t: f64) -> f64 {
    segs.iter()
        .find(|s| s.t0 <= t && t < s.t1())
        .map_or(0.0, |s| s.profile.state((t - s.t0) * 1e-6).1)
}

#[test]
fn m4_power_follows_speed_and_m3_does_not() {
    // (program, power scale S/1000, feed mm/s, follows speed)
    let cases = [
        (
            "G21 G90\nG0 X10 Y10\nM4 S1000\nG1 X200 Y10 F6000\nG1 X200 Y150\nM5\n",
            1.0f32,
            100.0,
            true,
        ),
        (
            "G21 G90\nG0 X10 Y10\nM4 S500\nG1 X200 Y10 F3000\nM5\n",
            0.5,
            50.0,
            true,
        ),
        (
            "G21 G90\nG0 X10 Y10\nM3 S800\nG1 X200 Y10 F6000\nM5\n",
            0.8,
            100.0,
            false,
        ),
    ];
    for (program, scale, feed, follows) in cases {
        let (segs, changes) = run(program);
        let on: Vec<(f64, f32)> = changes.iter().copied().filter(|(_, v)| *v > 0.0).collect();
        assert!(!on.is_empty(), "{program}: laser never came on");
        if follows {
            // Many refreshes during the ramps, each matching the speed then.
            assert!(on.len() > 20, "{program}: only {} power changes", on.len());
            for (t, v) in &on {
                let want = scale * (speed_at(&segs, *t) / feed).min(1.0) as f32;
                assert!(
                    (v - want).abs() <= 2.0 / 1024.0,
                    "{program}: at {t} µs power {v}, want {want}"
                );
            }
            let top = on.iter().map(|(_, v)| *v).fold(0.0, f32::max);
            assert!(
                (top - scale).abs() <= 2.0 / 1024.0,
                "{program}: cruise power {top}"
            );
        } else {
            assert_eq!(on.len(), 1, "{program}: M3 power is fixed");
            assert_eq!(on[0].1, scale);
        }
        assert_eq!(changes.last().unwrap().1, 0.0, "{program}: M5 turns it off");
    }
}
