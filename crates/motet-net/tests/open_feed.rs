//! A run kept open for commands streamed while it moves (a grbl sender's
//! lines): fed in time, it runs the same steps as the whole job planned at
//! once; starved, it plans what it holds to rest and ends there.

mod common;

use common::*;
use motet_net::loopback::Loopback;
use motet_net::{NetConfig, Phase};

/// (steps, net position) per actuator.
type Steps = Vec<(u64, i64)>;

/// Streams `cmds` into an open run `chunk` commands per simulated step,
/// pushing only the first `fed` of them, then closes it if all were fed.
fn stream(machine: &str, job: &str, chunk: usize, fed: usize) -> (Steps, Steps, Phase, Loopback) {
    let (m, cmds) = load(machine, job);
    let fed = fed.min(cmds.len());
    let want = simulated(&m, &cmds[..fed]);
    let mut lb = Loopback::new(
        &m,
        Vec::new(),
        m.start,
        clean_links(m.nodes.len()),
        &clocks(m.nodes.len()),
        NetConfig::default(),
    );
    lb.run.keep_feed_open();
    let mut next = 0;
    let end = lb.now + 3_600_000_000;
    while lb.now < end {
        if next < fed {
            let to = (next + chunk).min(fed);
            assert!(
                lb.run.push_commands(cmds[next..to].to_vec()),
                "the open run took no commands at {next}"
            );
            next = to;
            if next == cmds.len() {
                lb.run.close_feed();
            }
        }
        lb.step().unwrap();
        if matches!(lb.run.phase(), Phase::Done | Phase::Stopped(_)) {
            break;
        }
    }
    let got = executed(&m, &lb);
    let phase = lb.run.phase().clone();
    (want, got, phase, lb)
}

#[test]
fn a_run_fed_in_time_steps_like_the_whole_job() {
    for (machine, job, chunk) in [
        ("examples/laser.toml", "examples/jobs/laser-badge.gcode", 8),
        ("examples/plotter.toml", "examples/jobs/drawing.svg", 3),
    ] {
        let (want, got, phase, _) = stream(machine, job, chunk, usize::MAX);
        assert_eq!(phase, Phase::Done, "{job}");
        assert_eq!(got, want, "{job}");
    }
}

#[test]
fn a_starved_run_comes_to_rest_at_the_last_command_and_ends() {
    let (want, got, phase, mut lb) = stream(
        "examples/laser.toml",
        "examples/jobs/laser-badge.gcode",
        8,
        40,
    );
    assert_eq!(phase, Phase::Done);
    // Step counts: the simulator and the nodes' boards sign an inverted
    // motor's position differently, and this job does not end at its start.
    let steps = |v: &[(u64, i64)]| v.iter().map(|s| s.0).collect::<Vec<_>>();
    assert_eq!(
        steps(&got),
        steps(&want),
        "the steps of the 40 commands fed"
    );
    let (m, cmds) = load("examples/laser.toml", "examples/jobs/laser-badge.gcode");
    let last = cmds[..40]
        .iter()
        .rev()
        .find_map(|c| match c.item {
            motet_planner::Command::Move(mv) => Some(mv.target),
            _ => None,
        })
        .unwrap();
    let rest = lb.run.position_at(f64::INFINITY).unwrap();
    assert_eq!(
        steps_at(&m, &rest),
        steps_at(&m, &last),
        "at rest at the last move's end"
    );
    assert!(!lb.run.feed_open());
    assert!(
        !lb.run.push_commands(Vec::new()),
        "a closed run takes nothing more"
    );
}
