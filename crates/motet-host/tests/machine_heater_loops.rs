//! Heaters a node drives (`[nodes.NAME] heaters`): their loops, models and
//! watches as written or derived from the model, what the node is sent,
//! temperatures routed to it as events on the heater's track, targets
//! above a heater's `max` refused at their place, and mistakes in the
//! file reported where they are.

use motet_host::heater_loop::{self, HeaterFaultKind, HEATER_TRACK_BASE};
use motet_host::{check_job, Distributor, Machine};
use motet_planner::{AuxChannel, AuxEvent, Command, Located, Planned, SourceLoc};
use motet_wire::HostMessage;
use std::path::Path;

const AXES: &str = r#"name = "m"
[axes.x]
travel = [0, 100]
max_velocity = 100
max_acceleration = 1000
[actuators.xm]
joint = "x"
chain = [{ leadscrew = { lead = 8.0 } }, { stepper = { step_angle = 1.8 } }]
"#;

const HEATERS: &str = r#"[heaters.hotend]
channel = "hotend"
max = 275
[heaters.bed]
channel = "bed"
max = 110
time_constant = 60
[nodes.board]
actuators = ["xm"]
heaters = ["hotend"]
"#;

fn parse(extra: &str) -> Result<Machine, motet_host::MachineError> {
    Machine::parse(&format!("{AXES}{extra}"), Path::new("m.toml"))
}

#[test]
fn a_node_heater_gets_its_loop_and_the_node_its_configuration() {
    let m = parse(HEATERS).unwrap();
    let hot = m.heaters.iter().position(|h| h.name == "hotend").unwrap();
    let bed = m.heaters.iter().position(|h| h.name == "bed").unwrap();
    assert!(
        m.heaters[bed].node_loop.is_none(),
        "not listed: a first-order lag"
    );
    let l = m.heaters[hot].node_loop.as_ref().unwrap();
    assert_eq!((l.node, l.index, l.rate_hz), (0, 0, 10.0));
    assert_eq!(
        l.gains,
        heater_loop::reaction_curve_gains(&l.plant, 10.0),
        "gains derived from the model"
    );
    let c = heater_loop::config(&m, hot).unwrap();
    assert!(c.is_valid(), "{:?}", c.invalid());
    assert_eq!(
        (c.track, c.drive, c.sensor),
        (HEATER_TRACK_BASE + hot as u8, 8, 0)
    );
    let setup = Distributor::new(&m).setup(&m, 0, &m.start);
    assert!(setup.contains(&HostMessage::ConfigureHeater(c)));
    assert!(setup
        .iter()
        .any(|s| matches!(s, HostMessage::Sampling { every: 5, .. })));
}

#[test]
fn tables_override_the_derived_values() {
    let m = parse(&format!(
        "{HEATERS}[heaters.hotend.pid]\nkp = 0.05\nrate_hz = 4\n\
         [heaters.hotend.model]\npower = 50\nfault = \"sensor-lost\"\nfault_at = 12.5\n\
         [heaters.hotend.runaway]\nmargin = 20\n"
    ))
    .unwrap();
    let l = m.heaters.iter().find_map(|h| h.node_loop.clone()).unwrap();
    assert_eq!((l.gains.kp, l.rate_hz, l.plant.power_w), (0.05, 4.0, 50.0));
    let derived = heater_loop::reaction_curve_gains(&l.plant, 4.0);
    assert_eq!(l.gains.ki, derived.ki, "what is left out stays derived");
    assert_eq!(l.watch.margin_c, 20.0);
    let f = l.fault.unwrap();
    assert_eq!((f.kind, f.at_s), (HeaterFaultKind::SensorLost, 12.5));
}

#[test]
fn temperatures_go_to_the_heaters_node_as_events_on_its_track() {
    let m = parse(HEATERS).unwrap();
    let hot = m.heaters.iter().position(|h| h.name == "hotend").unwrap() as u8;
    let mut d = Distributor::new(&m);
    let aux = |channel, value| {
        Planned::Aux(AuxEvent {
            time: 1500.0,
            channel,
            value,
            wait: true,
        })
    };
    let out = d
        .route_batched(0, &aux(AuxChannel::Hotend(0), 215.0))
        .unwrap();
    assert_eq!(
        out.iter().map(|o| o.message.clone()).collect::<Vec<_>>(),
        vec![HostMessage::Event {
            track: HEATER_TRACK_BASE + hot,
            time: 1500.0,
            value: 215.0
        }]
    );
    assert!(d.takes_event(0, &aux(AuxChannel::Hotend(0), 215.0)));
    // The bed is no node's, the fan neither.
    for c in [AuxChannel::Bed, AuxChannel::Fan(0), AuxChannel::Hotend(1)] {
        assert!(d.route_batched(0, &aux(c, 60.0)).unwrap().is_empty());
        assert!(!d.takes_event(0, &aux(c, 60.0)));
    }
}

#[test]
fn a_target_above_a_node_heaters_max_is_refused_at_its_place() {
    let m = parse(HEATERS).unwrap();
    let at = |line| SourceLoc { line, column: 1 };
    let aux = |channel, value, line| Located {
        item: Command::Aux {
            channel,
            value,
            wait: false,
        },
        loc: at(line),
    };
    let mut ok = vec![
        aux(AuxChannel::Hotend(0), 275.0, 1),
        aux(AuxChannel::Bed, 500.0, 2),
    ];
    assert!(
        check_job(&m, &mut ok).is_ok(),
        "the bed is a first-order lag: unchecked"
    );
    let mut bad = vec![aux(AuxChannel::Hotend(0), 290.0, 7)];
    let e = check_job(&m, &mut bad).unwrap_err();
    assert_eq!(e.loc.line, 7);
    assert!(
        e.message.contains("heater hotend: target 290 °C"),
        "{}",
        e.message
    );
}

#[test]
fn mistakes_are_reported_where_they_are() {
    let base = "[heaters.h]\nchannel = \"hotend\"\nmax = 250\n";
    // (machine file after the axes, line, column, words of the message)
    let cases = [
        (
            format!("{base}[nodes.n]\nactuators = [\"xm\"]\nheaters = [\"g\"]\n"),
            14,
            12,
            "unknown heater `g`",
        ),
        (
            format!("{base}[nodes.n]\nactuators = [\"xm\"]\nheaters = [\"h\", \"h\"]\n"),
            14,
            17,
            "already on a node",
        ),
        (
            format!("{base}[heaters.h.pid]\nkp = -1\n[nodes.n]\nactuators = [\"xm\"]\nheaters = [\"h\"]\n"),
            13,
            6,
            "heater h: pid kp must be from 0 to 100",
        ),
        (
            format!("{base}[heaters.h.model]\nfault = \"melted\"\n[nodes.n]\nactuators = [\"xm\"]\nheaters = [\"h\"]\n"),
            13,
            9,
            "unknown fault `melted`",
        ),
        (
            format!("{base}[heaters.h.model]\nloss = 1\n[nodes.n]\nactuators = [\"xm\"]\nheaters = [\"h\"]\n"),
            11,
            7,
            "beyond what its model reaches at full power (65 °C)",
        ),
        (
            format!("{base}[heaters.h.model]\npwer = 40\n"),
            13,
            1,
            "unknown field `pwer`",
        ),
        (
            format!("{base}time_constant = 5\n[heaters.h.pid]\nkp = 0.1\n"),
            13,
            1,
            "[heaters.h.pid] is for a heater a node drives",
        ),
        (base.to_string(), 9, 1, "time_constant is needed"),
        (
            format!("{base}residency = -1\n[nodes.n]\nactuators = [\"xm\"]\nheaters = [\"h\"]\n"),
            12,
            13,
            "heater h: residency",
        ),
    ];
    for (extra, line, column, words) in &cases {
        let e = parse(extra).unwrap_err();
        assert!(e.message.contains(words), "{extra}: {e}");
        assert_eq!((e.line, e.column), (*line, *column), "{extra}: {e}");
    }
}

/// The heated printer's hot end and bed are its mainboard's heaters, with
/// the models its file gives.
#[test]
fn the_heated_printer_drives_its_hot_end_and_bed() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let m = Machine::load(&root.join("printer-heated.toml")).unwrap();
    let on: Vec<&str> = heater_loop::on_node(&m, 0)
        .into_iter()
        .map(|h| m.heaters[h].name.as_str())
        .collect();
    assert_eq!(on, ["hotend", "bed"]);
    let hot = &m.heaters[heater_loop::by_channel(&m, AuxChannel::Hotend(0)).unwrap()];
    let l = hot.node_loop.as_ref().unwrap();
    assert_eq!((l.plant.power_w, l.plant.capacity_j_per_k), (40.0, 13.0));
    assert_eq!((l.ready.window_c, l.ready.residency_s), (1.0, 10.0));
    let bed = &m.heaters[heater_loop::by_channel(&m, AuxChannel::Bed).unwrap()];
    assert_eq!(bed.node_loop.as_ref().unwrap().plant.power_w, 220.0);
}
