//! Machines from modules: the mill's description files composed into a
//! machine file that reads back, the viability rule case by case, what a
//! job needs of the machine, and the bus against a file's records.

use motet_host::module::{
    self, bus_check, compose, description_toml, fits, load_description, machine_toml, offers,
    parse_description, viability, Composition, Difference, Expected, FoundModule, JobNeeds,
    ModuleAt, Place, Reason, Role,
};
use motet_host::Machine;
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_wire::describe::Description;
use std::path::{Path, PathBuf};

const MILL: [&str; 5] = ["spindle", "z", "y", "x", "a"];

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../examples/modules/{name}.toml"))
}

fn desc(name: &str) -> Description {
    load_description(&example(name)).unwrap_or_else(|e| panic!("{e}"))
}

fn module(name: &str, uid: u64) -> ModuleAt {
    ModuleAt {
        uid,
        firmware: None,
        description: desc(name),
    }
}

fn mill_modules() -> Vec<ModuleAt> {
    MILL.iter()
        .enumerate()
        .map(|(k, n)| module(n, 0x100 + k as u64))
        .collect()
}

fn mill() -> (Composition, Machine) {
    let c = compose(&mill_modules());
    viability::check(&c).unwrap_or_else(|e| panic!("{e}"));
    let text = machine_toml(&c, "mill");
    let m = Machine::parse(&text, Path::new("mill.toml")).unwrap_or_else(|e| panic!("{e}\n{text}"));
    (c, m)
}

#[test]
fn the_mill_composes_into_a_machine_file_that_reads_back() {
    let (c, m) = mill();
    let roles: Vec<(&str, Role)> = c
        .modules
        .iter()
        .map(|m| (m.name(), m.role.clone()))
        .collect();
    let axis = |axis| Role::Axis {
        axis,
        inverted: false,
    };
    assert_eq!(
        roles,
        [
            ("spindle", Role::Tool),
            ("z", axis("z")),
            ("y", axis("y")),
            ("x", axis("x")),
            ("a", axis("a")),
        ]
    );
    // The tool point with every joint at 0: the offsets added up.
    let p = c.tool_point();
    for (got, want) in p.iter().zip([-129.5, 0.0, -284.5]) {
        assert!((got - want).abs() < 1e-4, "{p:?}");
    }
    let names: Vec<&str> = m.axes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["x", "y", "z", "a"]);
    let z = &m.axes[m.axis("z").unwrap()];
    assert_eq!(
        (z.travel, z.max_velocity, z.max_acceleration),
        ([0.0, 120.0], 20.0, 200.0)
    );
    assert_eq!(m.start[m.axis("z").unwrap()], 120.0, "z starts at its home");
    // 200 steps × 8 microsteps per 5 mm; the rotary's 36:1 gear per 360°.
    let spu = |name: &str| {
        m.actuators
            .iter()
            .find(|a| a.name == name)
            .unwrap()
            .steps_per_unit
    };
    assert_eq!(spu("x"), 320.0);
    assert_eq!(spu("z"), 400.0);
    assert!((spu("a") - 160.0).abs() < 1e-9, "{}", spu("a"));
    assert_eq!(m.tools[0].name, "spindle");
    assert_eq!(m.tools[0].kind, motet_planner::ToolKind::Spindle);
    assert_eq!(m.nodes.len(), 5);
    assert_eq!(m.modules.len(), 5);
    assert_eq!(module::recorded(&m), mill_modules());
    let again = module::check_file(&m).unwrap().expect("a composed machine");
    assert_eq!(again, c);
    let offered = offers(&c);
    assert!(
        offered[0].starts_with("motion on x y z a (4 axes"),
        "{offered:?}"
    );
    assert!(offered[1].starts_with("spindle spindle"), "{offered:?}");
}

#[test]
fn a_description_written_out_reads_back_the_same() {
    for n in MILL.iter().chain(&["x-short", "b"]) {
        let d = desc(n);
        let text = description_toml(&d, "");
        assert_eq!(parse_description(&text, "again.toml").unwrap(), d, "{text}");
    }
}

/// A description file with one line replaced, and the error it gives.
fn bad(file: &str, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(example(file)).unwrap();
    assert!(text.contains(from), "{file} has no {from:?}");
    let text = text.replacen(from, to, 1);
    match parse_description(&text, "bad.toml") {
        Ok(d) => panic!("{file} with {to:?} was accepted: {d:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_descriptions_are_refused_at_their_place_naming_the_module_and_field() {
    let cases: &[(&str, &str, &str, &str)] = &[
        ("x", "kind = \"stepper-axis\"", "kind = \"conveyor\"", "bad.toml:3:8: module x: kind: unknown module kind `conveyor`"),
        ("x", "[0, 0, 1, -111]", "[0, 0, 2, -111]", "bad.toml:9:7: module x: placement.htm: not a rigid transform"),
        ("x", "[0, 0, 0, 1],\n]", "[0, 0, 1, 1],\n]", "module x: placement.htm: the bottom row must be 0 0 0 1"),
        ("x", "[0, 1, 0, 0],", "[0, 1, 0],", "module x: placement.htm: must be 4 rows of 4 numbers"),
        ("y", "[1, 0, 0, 0],", "[-1, 0, 0, 0],", "module y: placement.htm: not a rigid transform"),
        ("x", "travel = [0, 400]", "travel = [400, 0]", "bad.toml:17:10: module x: limits.travel: must be [min, max] with min < max"),
        ("z", "home = 120", "home = 130", "bad.toml:23:8: module z: limits.home: 130 mm is beyond the travel [0, 120]"),
        ("x", "resolution = 0.01", "resolution = 0.001", "module x: limits.resolution: 0.001 is finer than one step of its mechanics (0.003125)"),
        ("x", "accuracy = 0.05", "accuracy = 0.005", "module x: limits.accuracy: 0.005 mm is finer than the module's resolution"),
        ("x", "max_velocity = 50", "max_velocity = 5000", "module x: channels[0].step.max_step_hz: its top speed 5000 needs 1600000 steps/s"),
        ("x", "step = { lead = 5,", "step = {", "module x: channels[0].step.lead: a translational module needs its lead"),
        ("a", "step = { ratio = 36,", "step = { lead = 2, ratio = 36,", "module a: channels[0].step.lead: a rotary module turns its output"),
        ("x", "drives = \"joint\"", "drives = \"other\"", "module x: channels: no channel drives the joint"),
        ("x", "step = { lead", "tool = { kind = \"pen\" }\nstep = { lead", "module x: channels[0]: a channel is one of step, servo, tool, heater, sensor or input; this one gives 2"),
        ("spindle", "tool = { kind = \"spindle\"", "x = { kind = \"spindle\"", "bad.toml:18:1: unknown field `x`"),
        ("spindle", "tool = { kind = \"spindle\", max = 24000, settle = 1 }", "step = { lead = 1, microstep = 1 }", "module spindle: channels[0]: a step channel on a tool module"),
        ("spindle", "kind = \"spindle\"", "kind = \"drill\"", "module spindle: channels[0].tool.kind: unknown tool `drill`"),
        ("x", "name = \"x\"", "name = \"X axis\"", "module X axis: name: must be a lower-case letter"),
        ("x", "joint = \"x\"", "joint = \"w\"", "module x: placement.joint: unknown axis `w`"),
        ("x", "microstep = 8", "microstep = 1000", "module x: channels[0].step.microstep: must be from 1 to 256, got 1000"),
        ("spindle", "[placement]", "[limits]\ntravel = [0, 1]\nmax_velocity = 1\nmax_acceleration = 1\n[placement]", "module spindle: limits: a tool module has no joint"),
    ];
    for (file, from, to, want) in cases {
        let got = bad(file, from, to);
        assert!(
            got.contains(want),
            "{file}: {to:?}\n got: {got}\nwant: {want}"
        );
    }
}

fn reasons(c: &Composition) -> Vec<String> {
    viability::check(c).err().map_or(Vec::new(), |e| {
        e.reasons.iter().map(|r| r.to_string()).collect()
    })
}

#[test]
fn the_viability_rule_case_by_case() {
    // A second X module: one degree of freedom, two modules.
    let mut two = mill_modules();
    let mut x2 = module("x-short", 0x999);
    x2.description.identity.name = "x2".try_into().unwrap();
    two.insert(3, x2);
    let r = reasons(&compose(&two));
    assert_eq!(
        r,
        ["modules x2 (uid 0000000000000999) and x (uid 0000000000000103) both drive x: one degree of freedom, two modules"]
    );
    let mut turned = mill_modules();
    // The X module turned 45° about z: its joint no longer along an axis.
    let h = &mut turned[3].description.placement.htm;
    let c = std::f32::consts::FRAC_1_SQRT_2;
    h[0] = c;
    h[1] = -c;
    h[4] = c;
    h[5] = c;
    // It turns the modules on its tool side with it: y too.
    let r = reasons(&compose(&turned));
    assert_eq!(r.len(), 2, "{r:?}");
    assert!(r[0].starts_with("module y (uid 0000000000000102): its joint moves along (-0.707107, 0.707107, 0) in the workpiece frame, along none of its axes"), "{r:?}");
    assert!(r[1].starts_with("module x (uid 0000000000000103): its joint moves along (0.707107, 0.707107, 0) in the workpiece frame, along none of its axes"), "{r:?}");
    // Turned 180° about z: along -x, an inverted chain and travel.
    let mut flipped = mill_modules();
    let h = &mut flipped[3].description.placement.htm;
    h[0] = -1.0;
    h[5] = -1.0;
    let fc = compose(&flipped);
    assert_eq!(reasons(&fc), Vec::<String>::new());
    let m = Machine::parse(&machine_toml(&fc, "flipped"), Path::new("f.toml")).unwrap();
    let x = &m.axes[m.axis("x").unwrap()];
    assert_eq!(x.travel, [-400.0, 0.0]);
    let act = m.actuators.iter().find(|a| a.name == "x").unwrap();
    assert_eq!(act.steps_per_unit, -320.0);
    // The same device twice, two names alike, nothing that moves.
    let mut same = mill_modules();
    same[4].uid = same[3].uid;
    assert!(reasons(&compose(&same))[0]
        .starts_with("modules x and a are one device (uid 0000000000000103)"));
    let mut named = mill_modules();
    named[4].description.identity.name = "x".try_into().unwrap();
    assert!(reasons(&compose(&named))[0].starts_with("two modules are named x"));
    let r = reasons(&compose(&mill_modules()[..1]));
    assert_eq!(
        r,
        ["no module moves anything: a machine needs at least one axis module"]
    );
    // A board that was never described.
    let mut raw = mill_modules();
    raw[1].description = Description::default_for("stepper", "teensy41", 1, 0, 0);
    let r = reasons(&compose(&raw));
    assert!(
        r[0].contains(
            "module node (uid 0000000000000101): kind: the module has not been described"
        ),
        "{r:?}"
    );
}

fn mv(
    machine: &Machine,
    line: u32,
    coords: &[(&str, f64)],
    at: &mut motet_trajectory::Point,
) -> Located<Command> {
    for (a, v) in coords {
        at[machine.axis(a).unwrap()] = *v;
    }
    Located {
        loc: SourceLoc { line, column: 1 },
        item: Command::Move(Move {
            target: *at,
            feed: 10.0,
            kind: MoveKind::Feed,
        }),
    }
}

#[test]
fn a_job_fits_the_machine_its_modules_make_or_says_why_not() {
    let (c, m) = mill();
    let mut at = m.start;
    let mut needs = JobNeeds::default();
    for cmd in [
        Located {
            loc: SourceLoc { line: 2, column: 1 },
            item: Command::Tool {
                tool: 0,
                value: 1.0,
            },
        },
        mv(&m, 3, &[("x", 20.0), ("a", 90.0)], &mut at),
        mv(&m, 4, &[("x", 200.0)], &mut at),
        mv(&m, 5, &[("x", 20.0), ("a", -90.0)], &mut at),
    ] {
        needs.take(&m, &cmd);
    }
    assert_eq!(needs.axes.len(), 2);
    assert_eq!(needs.axes[0].max, (200.0, SourceLoc { line: 4, column: 1 }));
    fits(&c, &needs).unwrap();
    // The X module replaced by the short one, the A module by B, no spindle.
    let mut other = mill_modules();
    other[3] = module("x-short", 0x200);
    other[4] = module("b", 0x201);
    other.remove(0);
    let c2 = compose(&other);
    viability::check(&c2).unwrap();
    let r: Vec<String> = fits(&c2, &needs)
        .unwrap_err()
        .reasons
        .iter()
        .map(|r| r.to_string())
        .collect();
    assert_eq!(
        r,
        [
            "job 4:1: moves x to 200, beyond module x (uid 0000000000000200)'s travel [0, 150]",
            "job 3:1: moves a, which no module drives (the machine's axes: x, y, z, b)",
            "job 2:1: turns on the spindle (spindle), and no module of the machine is a spindle",
        ]
    );
}

#[test]
fn a_machine_file_that_disagrees_with_its_modules_is_not_viable() {
    let (c, _) = mill();
    let text = machine_toml(&c, "mill");
    let cases: &[(&str, &str, &str)] = &[
        (
            "max_velocity = 50\n",
            "max_velocity = 80\n",
            "axis x: max_velocity 80 in the machine file, beyond module x's 50",
        ),
        (
            "travel = [0, 400]\n",
            "travel = [0, 500]\n",
            "axis x: travel [0, 500] in the machine file goes beyond module x's [0, 400]",
        ),
        (
            "[nodes.x]\nactuators = [\"x\"]",
            "[nodes.x]\n[nodes.w]\nactuators = [\"x\"]",
            "axis x: node x (module x) drives none of its actuators",
        ),
    ];
    for (from, to, want) in cases {
        assert!(text.contains(from), "{from}");
        let edited = text.replacen(from, to, 1);
        let m = Machine::parse(&edited, Path::new("m.toml")).unwrap_or_else(|e| panic!("{e}"));
        let e = module::check_file(&m).unwrap_err().to_string();
        assert!(e.contains(want), "{to}\n got: {e}\nwant: {want}");
    }
    // Records that do not hold are refused as the file is read.
    let edits: &[(&str, &str, &str)] = &[
        (
            "order = 4\n",
            "order = 9\n",
            "modules.x: order must be from 1 to 5",
        ),
        ("order = 4\n", "order = 3\n", "modules.y: order 3 is module"),
        (
            "uid = \"0000000000000103\"",
            "uid = \"0000000000000102\"",
            "uid 0000000000000102 is module",
        ),
        (
            "[modules.x.description.limits]\ntravel = [0, 400]",
            "[modules.x.description.limits]\ntravel = [0, 410]",
            "modules.x: the recorded description gives digest",
        ),
        (
            "[modules.x.description.limits]\ntravel = [0, 400]",
            "[modules.x.description.limits]\ntravel = [400, 0]",
            "modules.x: description.limits.travel: must be [min, max]",
        ),
    ];
    for (from, to, want) in edits {
        assert!(text.contains(from), "{from}");
        let e = Machine::parse(&text.replacen(from, to, 1), Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{to}\n got: {e}\nwant: {want}");
        assert!(e.starts_with("m.toml:"), "{e}");
    }
}

fn place(k: usize) -> Place {
    Place {
        link: format!("udp:127.0.0.1:{}", 47000 + k),
        address: 2 + k as u16,
    }
}

fn expected(m: &Machine) -> Vec<Expected> {
    m.modules
        .iter()
        .enumerate()
        .map(|(k, r)| Expected {
            record: r.clone(),
            place: place(k),
        })
        .collect()
}

fn found(m: &Machine) -> Vec<FoundModule> {
    m.modules
        .iter()
        .enumerate()
        .map(|(k, r)| FoundModule {
            place: place(k),
            uid: r.uid,
            firmware: None,
            description: Ok(r.description.clone()),
        })
        .collect()
}

fn differences(m: &Machine, bus: &[FoundModule]) -> (Vec<String>, bool) {
    let b = bus_check(&expected(m), bus);
    (
        b.differences.iter().map(|d| d.to_string()).collect(),
        b.same_machine,
    )
}

#[test]
fn the_bus_against_the_records() {
    let (_, m) = mill();
    assert_eq!(differences(&m, &found(&m)), (vec![], true));
    // x (order 4, place 3) and y (order 3, place 2) traded links.
    let mut swapped = found(&m);
    let (p2, p3) = (swapped[2].place.clone(), swapped[3].place.clone());
    swapped[2].place = p3;
    swapped[3].place = p2;
    let (d, same) = differences(&m, &swapped);
    assert_eq!(d, ["y and x are swapped: y now answers at address 5 on udp:127.0.0.1:47003, where x was, and x at address 4 on udp:127.0.0.1:47002, where y was"]);
    assert!(same, "the chain is mechanical: the same machine");
    // On links of their own they keep their addresses: still a swap.
    let mut relinked = found(&m);
    relinked[2].place.link = place(3).link;
    relinked[3].place.link = place(2).link;
    let (d, same) = differences(&m, &relinked);
    assert_eq!(d, ["y and x are swapped: y now answers at address 4 on udp:127.0.0.1:47003, where x was, and x at address 5 on udp:127.0.0.1:47002, where y was"]);
    assert!(same);
    let b = bus_check(&expected(&m), &swapped);
    assert_eq!(b.places[3], ("x".into(), Some((place(2), 0x103))));
    // A spare board with the same description where x was: the same machine.
    let mut spare = found(&m);
    spare[3].uid = 0xfeed;
    let (d, same) = differences(&m, &spare);
    assert_eq!(d, ["x (uid 0000000000000103) was replaced by x (uid 000000000000feed) at address 5 on udp:127.0.0.1:47003, which describes itself the same"]);
    assert!(same);
    // The short rail in x's place: another machine, each change named.
    let mut short = found(&m);
    short[3].uid = 0xfeed;
    short[3].description = Ok(desc("x-short"));
    let (d, same) = differences(&m, &short);
    assert_eq!(
        d,
        [
            "x (uid 0000000000000103) was replaced by x (uid 000000000000feed) at address 5 on udp:127.0.0.1:47003",
            "x: model changed: MRMT base module → MRMT base module, short rail",
            "x: limits.travel changed: [0, 400] → [0, 150]",
        ]
    );
    assert!(!same);
    // The same module describing itself otherwise; one gone; one new.
    let mut changed = found(&m);
    if let Ok(d) = &mut changed[1].description {
        d.limits.max_velocity = 10.0;
    }
    changed.remove(4);
    let mut probe = desc("x");
    probe.kind = motet_wire::describe::ModuleKind::Sensor;
    probe.identity.name = "probe".try_into().unwrap();
    changed.push(FoundModule {
        place: place(9),
        uid: 0xabc,
        firmware: None,
        description: Ok(probe),
    });
    let b = bus_check(&expected(&m), &changed);
    let d: Vec<String> = b.differences.iter().map(|d| d.to_string()).collect();
    assert_eq!(
        d,
        [
            "z: limits.max_velocity changed: 20 → 10",
            "a (uid 0000000000000104) is missing: nothing answers as it, and nothing new at address 6 on udp:127.0.0.1:47004",
            "extra module probe (sensor, uid 0000000000000abc) at address 11 on udp:127.0.0.1:47009: the machine file does not know it",
        ]
    );
    assert!(matches!(
        b.differences[2],
        Difference::Extra { passive: true, .. }
    ));
    assert!(!b.same_machine);
    assert_eq!(b.places[4], ("a".into(), None));
    // The machine the bus makes now: no a; and the sensor, not described
    // as one, is not viable.
    assert!(b.now.axis_module("a").is_none());
    let why = b.viability.unwrap_err();
    assert!(
        why.reasons
            .iter()
            .all(|r| matches!(r, Reason::Described { .. })),
        "{why}"
    );
}

#[test]
fn servo_and_heater_modules_are_written_with_the_closed_loop_keys() {
    // A servo X on an encoder of 1000 lines, and a hot end module, in the
    // mill's place of the X module and the spindle.
    let servo = parse_description(
        r#"kind = "servo-axis"
name = "x"
[placement]
joint = "x"
[limits]
travel = [0, 200]
max_velocity = 100
max_acceleration = 1000
[[channels]]
drives = "joint"
servo = { lead = 5, encoder_lines = 1000, rate_hz = 10000, kp = 0.02, ki = 0.5, following_limit = 40 }
"#,
        "servo.toml",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let heater = parse_description(
        r#"kind = "heater"
name = "hotend"
[[channels]]
drives = "hotend"
heater = { channel = "hotend", max = 275, time_constant = 20 }
"#,
        "hotend.toml",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut mods = mill_modules();
    mods[0].description = heater;
    mods[3].description = servo;
    let c = compose(&mods);
    viability::check(&c).unwrap_or_else(|e| panic!("{e}"));
    let text = machine_toml(&c, "servo mill");
    for want in [
        "[actuators.x]\njoint = \"x\"\nchain = [{ leadscrew = { lead = 5 } }, { encoder = { lines = 1000 } }]\n",
        "[actuators.x.servo]\nrate_hz = 10000\nkp = 0.02\nki = 0.5\nkd = 0\nkv = 0\nka = 0\nintegral_limit = 0.3\noutput_limit = 1\nfollowing_limit = 40\n",
        "[heaters.hotend]\nchannel = \"hotend\"\nindex = 0\nmax = 275\ntime_constant = 20\n",
        "[nodes.hotend]\nheaters = [\"hotend\"]\n",
        "[nodes.x]\nactuators = [\"x\"]\n",
    ] {
        assert!(text.contains(want), "missing:\n{want}\nin:\n{text}");
    }
    assert!(offers(&c)
        .iter()
        .any(|o| o == "heater hotend (hotend 0: up to 275 °C)"));
}
