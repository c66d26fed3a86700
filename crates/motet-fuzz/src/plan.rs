//! Planning and running a bounded prefix of a checked job, with the
//! invariants every plan and every simulated run keeps.

use motet_host::Machine;
use motet_planner::{Command, Located, Planned, Planner};
use motet_sim::{SimError, SimMachine};
use motet_trajectory::Point;

/// Planned items (segments and events) looked at per job: enough for every
/// kind of junction, arc and event, and quick.
const MAX_ITEMS: usize = 256;
/// A prefix is run on simulated nodes up to this many steps (estimated from
/// the commands), so a fine machine does not spend the fuzzer's time on one
/// input...
const MAX_SIM_STEPS: f64 = 30_000.0;
/// ...and only when it lasts no longer than this, µs (idle time costs the
/// simulator little, but not nothing).
const MAX_SIM_US: f64 = 600e6;

/// Whether `v` lies within the axis range `[lo, hi]`, as `check_job` judges it.
fn within(v: f64, [lo, hi]: [f64; 2]) -> bool {
    let eps = 1e-6 * (1.0 + v.abs());
    v.is_finite() && v >= lo - eps && v <= hi + eps
}

/// Plans the first commands of `commands` (already checked with
/// `check_job`) to rest and checks the plan; then runs a shorter prefix on
/// simulated nodes. Panics on a broken invariant.
pub fn plan_and_run(machine: &Machine, commands: &[Located<Command>]) {
    let items = plan(machine, commands, f64::INFINITY);
    check_plan(machine, &items);
    let short = plan(machine, commands, MAX_SIM_STEPS);
    let end = check_plan(machine, &short);
    if end <= MAX_SIM_US {
        run(machine, &short, end);
    }
}

/// Plans commands to rest until [`MAX_ITEMS`] items are out or the moves
/// would take about `max_steps` steps.
fn plan(machine: &Machine, commands: &[Located<Command>], max_steps: f64) -> Vec<Planned> {
    let mut planner = Planner::new(machine.limits(), machine.start, 0.0);
    let mut items = Vec::new();
    let mut at = machine.start;
    let mut steps = 0.0;
    for c in commands {
        if let Command::Move(m) = &c.item {
            steps += move_steps(machine, &at, &m.target);
            if steps > max_steps {
                break;
            }
            at = m.target;
        }
        if planner.push(&c.item).is_err() {
            // Refused with the command's place (the CLI prints `c.loc`):
            // nothing is planned from here on.
            break;
        }
        items.extend(std::iter::from_fn(|| planner.pop()));
        if items.len() >= MAX_ITEMS {
            break;
        }
    }
    planner.finish();
    items.extend(std::iter::from_fn(|| planner.pop()));
    items
}

/// Steps a straight move takes, about: each actuator's joint change (a
/// straight line turns a polar angle by at most half a turn).
fn move_steps(machine: &Machine, from: &Point, to: &Point) -> f64 {
    machine
        .actuators
        .iter()
        .map(|a| {
            let map = &machine.joints[a.joint].map;
            let mut d = (map.value(to, 0.0) - map.value(from, 0.0)).abs();
            if map.is_angle() {
                d = d.min(180.0);
            }
            d * a.steps_per_unit.abs()
        })
        .sum()
}

/// Checks the plan: finite times that never go back, segments joined end to
/// start, every point within travel, finite event values. Returns its end, µs.
fn check_plan(machine: &Machine, items: &[Planned]) -> f64 {
    let mut pos = machine.start;
    let mut clock = 0.0f64;
    for (i, item) in items.iter().enumerate() {
        match item {
            Planned::Segment(s) => {
                let d = s.duration_us();
                assert!(
                    s.t0.is_finite() && d.is_finite() && d >= 0.0,
                    "item {i}: segment at {} µs lasting {d} µs",
                    s.t0
                );
                assert!(
                    s.t0 >= clock - 1e-6 * (1.0 + clock.abs()),
                    "item {i}: segment starts at {} µs, before the previous end {clock} µs",
                    s.t0
                );
                assert_eq!(
                    s.start, pos,
                    "item {i}: segment does not start where the last ended"
                );
                for (a, axis) in machine.axes.iter().enumerate() {
                    assert!(
                        within(s.end[a], axis.travel),
                        "item {i}: segment ends at {}={} beyond travel {:?}",
                        axis.name,
                        s.end[a],
                        axis.travel
                    );
                }
                let p = &s.profile;
                for v in [p.length(), p.v0(), p.vc(), p.v1(), p.peak_accel()] {
                    assert!(v.is_finite() && v >= 0.0, "item {i}: profile {p:?}");
                }
                pos = s.end;
                clock = clock.max(s.t1());
            }
            Planned::Event(e) => {
                assert!(e.time.is_finite() && e.value.is_finite(), "item {i}: {e:?}");
            }
            Planned::Aux(a) => {
                assert!(a.time.is_finite() && a.value.is_finite(), "item {i}: {a:?}");
            }
            Planned::Pause { time, .. } => assert!(time.is_finite(), "item {i}: pause at {time}"),
        }
    }
    clock
}

/// Runs the plan on simulated nodes: a checked job must never be refused by
/// a node, and every step must land within half a step of the trajectory.
fn run(machine: &Machine, items: &[Planned], end: f64) {
    let mut sim = match SimMachine::new(machine) {
        Ok(s) => s,
        Err(e) => panic!("a valid machine's nodes refused their configuration: {e}"),
    };
    for item in items {
        match sim.submit(*item) {
            Ok(()) => {}
            Err(e @ (SimError::Refused { .. } | SimError::Stream(_))) => {
                panic!("a checked, planned job was refused on its way to the nodes: {e}")
            }
            Err(SimError::Plan { .. } | SimError::Source(_)) => {
                unreachable!("submit neither plans nor reads a job")
            }
            // A servo's gains are the file's: a loop that cannot follow
            // stops the run, named, which is what it must do.
            Err(SimError::Fault(e)) => {
                assert!(e.contains("node "), "a fault names its node: {e}");
                return;
            }
            // A heater the machine's model says runs away stops the run:
            // what a real machine does, not a fault of the plan.
            Err(SimError::Heater { .. }) => return,
        }
    }
    sim.run_until(end);
    sim.run_to_rest();
    let report = sim.report("fuzz", items.len(), end, 0.0);
    for a in &report.actuators {
        assert!(
            a.max_deviation_steps <= 0.5 + 1e-6,
            "actuator {} strayed {} steps from the trajectory",
            a.name,
            a.max_deviation_steps
        );
        assert!(
            a.max_step_time_error_us.is_finite(),
            "actuator {}: step time error {}",
            a.name,
            a.max_step_time_error_us
        );
    }
    assert!(
        report.duration_s.is_finite(),
        "duration {}",
        report.duration_s
    );
}
