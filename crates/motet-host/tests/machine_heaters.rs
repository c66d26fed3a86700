//! `[heaters.NAME]` in the machine file: read as written, the printer's
//! defaults without it, and mistakes reported where they are.

use motet_host::{Heater, Machine};
use motet_planner::AuxChannel;
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

fn parse(extra: &str) -> Result<Machine, motet_host::MachineError> {
    Machine::parse(&format!("{AXES}{extra}"), Path::new("m.toml"))
}

#[test]
fn heaters_are_read_as_written() {
    let m = parse(
        "[heaters.nozzle]\nchannel = \"hotend\"\nindex = 1\nmax = 300\ntime_constant = 5\n\
         [heaters.box]\nchannel = \"chamber\"\nmax = 70\ntime_constant = 300\n",
    )
    .unwrap();
    assert_eq!(
        m.heaters,
        vec![
            Heater {
                name: "box".into(),
                channel: AuxChannel::Chamber,
                max_c: 70.0,
                tau_s: 300.0,
                node_loop: None,
            },
            Heater {
                name: "nozzle".into(),
                channel: AuxChannel::Hotend(1),
                max_c: 300.0,
                tau_s: 5.0,
                node_loop: None,
            },
        ]
    );
}

#[test]
fn without_the_section_a_printer_has_a_hot_end_and_a_bed_and_others_none() {
    assert!(parse("").unwrap().heaters.is_empty());
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let printer = Machine::load(&root.join("printer.toml")).unwrap();
    assert_eq!(printer.heaters, Heater::default_printer());
    assert!(Machine::load(&root.join("plotter.toml"))
        .unwrap()
        .heaters
        .is_empty());
}

#[test]
fn mistakes_are_reported_where_they_are() {
    let cases = [
        (
            "[heaters.h]\nchannel = \"oven\"\nmax = 100\ntime_constant = 5\n",
            10,
            "unknown channel `oven`",
        ),
        (
            "[heaters.h]\nchannel = \"bed\"\nmax = 5000\ntime_constant = 5\n",
            11,
            "heater h: max",
        ),
        (
            "[heaters.h]\nchannel = \"bed\"\nmax = 100\ntime_constant = 0\n",
            12,
            "heater h: time_constant",
        ),
        (
            "[heaters.h]\nchannel = \"hotend\"\nindex = 300\nmax = 100\ntime_constant = 5\n",
            11,
            "index from 0 to 255",
        ),
        (
            "[heaters.a]\nchannel = \"bed\"\nmax = 100\ntime_constant = 5\n\
             [heaters.b]\nchannel = \"bed\"\nmax = 100\ntime_constant = 5\n",
            14,
            "a already has this channel",
        ),
        (
            "[heaters.h]\nchannel = \"bed\"\nmax = 100\ntime_constant = 5\ncolour = 1\n",
            13,
            "colour",
        ),
    ];
    for (extra, line, words) in cases {
        let e = parse(extra).unwrap_err();
        assert!(e.message.contains(words), "{extra}: {e}");
        assert_eq!(e.line, line, "{extra}: {e}");
    }
}
