//! Table-driven tests for the RS274NGC block rules and the codes beyond plain
//! moves: order of execution within a line, modal group conflicts, work
//! offsets, G53, G28/G28.1, G93, firmware retraction, program end, M4 and the
//! printer/auxiliary codes.

use crate::common;

use common::*;
use motet_gcode::{parse, GcodeOptions};
use motet_planner::AuxChannel::{Bed, Chamber, Coolant, Fan, Hotend};
use Want::{Ps, Sync, A, D, F, P, R, T};

/// Run every case on the printer target and compare the commands.
fn table(cases: &[(&str, Vec<Want>)]) {
    for (src, want) in cases {
        let parsed = run(src).unwrap_or_else(|e| panic!("{src:?}: {e}"));
        check(src, &parsed, want);
    }
}

/// Run every case, expecting an error at line:column whose message contains the text.
fn errors(cases: &[(&str, u32, u32, &str)]) {
    for &(src, line, column, msg) in cases {
        let e = match run(src) {
            Ok(p) => panic!("{src:?}: expected an error, got {:?}", p.commands),
            Err(e) => e,
        };
        assert!(
            e.message.contains(msg),
            "{src:?}: message {:?} lacks {msg:?}",
            e.message
        );
        assert_eq!((e.loc.line, e.loc.column), (line, column), "{src:?}: {e}");
    }
}

#[test]
fn order_of_execution_within_a_line() {
    table(&[
        // F is set before the motion of its line, wherever it is written.
        ("G1 X5 F60", vec![F([5., 2., 3., 0.], 1.)]),
        ("X5 G1 F120", vec![F([5., 2., 3., 0.], 2.)]),
        // M3/M4 come before motion; M5 too.
        ("G1 X5 F60 M3 S500", vec![T(0.5), F([5., 2., 3., 0.], 1.)]),
        (
            "M3 S500\nG1 X5 F60 M5",
            vec![T(0.5), T(0.), F([5., 2., 3., 0.], 1.)],
        ),
        // Coolant and printer codes come before motion.
        ("G0 X5 M8", vec![A(Coolant, 2., false), R([5., 2., 3., 0.])]),
        ("G0 X5 M400", vec![Sync, R([5., 2., 3., 0.])]),
        (
            "G0 X5 M104 S200",
            vec![A(Hotend(0), 200., false), R([5., 2., 3., 0.])],
        ),
        // Dwell before motion.
        ("G0 X5 G4 P100", vec![D(0.1), R([5., 2., 3., 0.])]),
        // Stops come last.
        ("M0 G0 X5", vec![R([5., 2., 3., 0.]), P(false)]),
        ("G0 X5 M1", vec![R([5., 2., 3., 0.]), P(true)]),
        // G92 before the next line's move.
        ("G92 X0\nX5 G0", vec![R([6., 2., 3., 0.])]),
        // G92.1 clears the offsets before the line's motion.
        ("G92 X0\nG92.1 G0 X5", vec![R([5., 2., 3., 0.])]),
        // Units and distance mode apply to the whole line.
        ("G0 X1 G20", vec![R([25.4, 2., 3., 0.])]),
        ("G0 X1 G91", vec![R([2., 2., 3., 0.])]),
        ("G20 G10 L2 P1 X1\nG0 X0", vec![R([25.4, 2., 3., 0.])]),
        // Coordinate system selection before motion and before G10 P0.
        ("G10 L2 P2 X10\nG0 X0 G55", vec![R([10., 2., 3., 0.])]),
        ("G55 G10 L2 P0 X10\nG0 X0", vec![R([10., 2., 3., 0.])]),
        (
            "G0 X0\nG10 L2 P0 X10\nG0 X0",
            vec![R([0., 2., 3., 0.]), R([10., 2., 3., 0.])],
        ),
        // Firmware retraction before the line's move.
        (
            "G1 X5 F60 G10",
            vec![F([1., 2., 3., -0.8], 35.), F([5., 2., 3., -0.8], 1.)],
        ),
        // T before the temperature on its line... (the printer code takes the rest)
        ("T1 M104 S200", vec![A(Hotend(1), 200., false)]),
        // M2 after the line's motion; the tool is switched off.
        (
            "M3 S500\nG0 X5 M2",
            vec![T(0.5), R([5., 2., 3., 0.]), T(0.)],
        ),
    ]);
}

#[test]
fn modal_group_conflicts_are_errors() {
    errors(&[
        (
            "G0 G1 X5",
            1,
            4,
            "G1 and G0 on one line: they are in the same modal group",
        ),
        ("G17 G18", 1, 5, "G18 and G17"),
        ("G18 G19", 1, 5, "same modal group"),
        ("G90.1 G91.1", 1, 7, "G91.1 and G90.1"),
        ("G93 G94", 1, 5, "G94 and G93"),
        ("G54 G55", 1, 5, "G55 and G54"),
        ("G20 G21", 1, 5, "same modal group"),
        ("G92 X0 G28", 1, 8, "G28 and G92"),
        ("G10 G11", 1, 5, "G11 and G10"),
        ("G53 G0 X1 G92 X0", 1, 11, "G92 and G53"),
        ("G53 G92 X0", 1, 5, "G92 and G53"),
        ("G4 P1 G53 G0 X1", 1, 7, "G53 and G4"),
        ("G28.1 G92.1", 1, 7, "G92.1 and G28.1"),
        ("M7 M8", 1, 4, "M8 and M7"),
        ("M9 M7", 1, 4, "M7 and M9"),
        ("M0 M1", 1, 4, "M1 and M0"),
        ("M2 M30", 1, 4, "M30 and M2"),
        ("M3 M4", 1, 4, "M4 and M3"),
        ("M5 M4", 1, 4, "M4 and M5"),
        ("M82 M83", 1, 5, "M83 and M82"),
        // A non-modal code and a motion code both wanting the axis words.
        ("G1 X5 F60 G92 X0", 1, 15, "X appears twice"),
        (
            "G1 F60 G92 X0",
            1,
            8,
            "G92 and G1 on one line both use the axis words",
        ),
        (
            "G92 X0 G0",
            1,
            1,
            "G92 and G0 on one line both use the axis words",
        ),
        (
            "G10 L2 P1 X1 G0",
            1,
            1,
            "G10 and G0 on one line both use the axis words",
        ),
        (
            "G0 G28 Z5",
            1,
            4,
            "G28 and G0 on one line both use the axis words",
        ),
    ]);
}

#[test]
fn work_offsets() {
    table(&[
        // G54..G59 default to zero.
        ("G59 G0 X3", vec![R([3., 2., 3., 0.])]),
        ("G10 L2 P1 X10 Y20\nG0 X0 Y0", vec![R([10., 20., 3., 0.])]),
        (
            "G10 L2 P3 X10\nG0 X0\nG56 G0 X0\nG54 X0",
            vec![
                R([0., 2., 3., 0.]),
                R([10., 2., 3., 0.]),
                R([0., 2., 3., 0.]),
            ],
        ),
        ("G10 L2 P6 Z-5\nG59 G0 Z0", vec![R([1., 2., -5., 0.])]),
        ("G10 L2 P1 E3\nG1 E1 F60", vec![F([1., 2., 3., 4.], 1.)]),
        // L20: the current position reads as the given value.
        ("G10 L20 P1 X0\nG0 X5", vec![R([6., 2., 3., 0.])]),
        (
            "G0 X4\nG10 L20 P2 X1\nG55 G0 X0",
            vec![R([4., 2., 3., 0.]), R([3., 2., 3., 0.])],
        ),
        // G92 adds to the work offset; L20 accounts for it.
        ("G10 L2 P1 X10\nG92 X0\nG0 X5", vec![R([6., 2., 3., 0.])]),
        ("G92 X0\nG10 L20 P1 X0\nG0 X5", vec![R([6., 2., 3., 0.])]),
        (
            "G10 L2 P1 X10\nG92 X0\nG92.1\nG0 X5",
            vec![R([15., 2., 3., 0.])],
        ),
        // Relative moves ignore offsets.
        ("G10 L2 P1 X10\nG91 G0 X1", vec![R([2., 2., 3., 0.])]),
        // G10 L2 values are absolute even in G91.
        ("G91 G10 L2 P1 X10\nG90 G0 X0", vec![R([10., 2., 3., 0.])]),
    ]);
    errors(&[
        ("G10 L3 P1 X0", 1, 1, "G10 L3 is not supported"),
        ("G10 L2 X0", 1, 1, "G10 L2/L20 needs P"),
        ("G10 L2 P7 X0", 1, 8, "P7 is not a coordinate system"),
        ("G10 L2 P1.5 X0", 1, 8, "not a coordinate system"),
        (
            "G10 L2 P1 R5 X0",
            1,
            11,
            "G10 R (rotation) is not supported",
        ),
        ("G0 X1 L2", 1, 7, "L is only used with G10"),
        ("G4 P1 L2", 1, 7, "L is only used with G10"),
        ("G10 L2 P1 X", 1, 11, "X without a number"),
    ]);
}

#[test]
fn machine_coordinates_g53() {
    table(&[
        (
            "G10 L2 P1 X10\nG0 X0\nG53 G0 X0",
            vec![R([10., 2., 3., 0.]), R([0., 2., 3., 0.])],
        ),
        ("G92 X0\nG53 G1 X5 F60", vec![F([5., 2., 3., 0.], 1.)]),
        (
            "G91\nG53 G0 X5\nG0 X1",
            vec![R([5., 2., 3., 0.]), R([6., 2., 3., 0.])],
        ),
        (
            "M83\nG53 G1 E5 F60\nG1 E1",
            vec![F([1., 2., 3., 5.], 1.), F([1., 2., 3., 6.], 1.)],
        ),
        // G53 is for this line only.
        (
            "G92 X0\nG53 G0 X5\nG0 X5",
            vec![R([5., 2., 3., 0.]), R([6., 2., 3., 0.])],
        ),
        // Modal G0 with G53.
        ("G0 X1\nG53 X7", vec![R([7., 2., 3., 0.])]),
        ("G53", vec![]),
    ]);
    errors(&[
        ("G53 X5", 1, 1, "G53 needs G0 or G1"),
        ("G0 X0 Y0\nG53 G2 X10 I5 F60", 2, 1, "G53 needs G0 or G1"),
        (
            "G0 X0 Y0\nG2 X10 I5 F60\nG53 X0 I-5",
            3,
            1,
            "G53 needs G0 or G1",
        ),
    ]);
}

#[test]
fn home_and_stored_home() {
    table(&[
        (
            "G0 X10 Y10 Z10\nG28",
            vec![R([10., 10., 10., 0.]), R([1., 2., 3., 0.])],
        ),
        // E is not homed unless named.
        ("G1 E5 F60\nG28", vec![F([1., 2., 3., 5.], 1.)]),
        (
            "G1 E5 F60\nG28 E",
            vec![F([1., 2., 3., 5.], 1.), R([1., 2., 3., 0.])],
        ),
        // Intermediate point, absolute and relative.
        ("G28 Z10", vec![R([1., 2., 10., 0.]), R([1., 2., 3., 0.])]),
        (
            "G91\nG28 Z2",
            vec![R([1., 2., 5., 0.]), R([1., 2., 3., 0.])],
        ),
        (
            "G0 X5 Y5\nG28 X Y7",
            vec![
                R([5., 5., 3., 0.]),
                R([5., 7., 3., 0.]),
                R([1., 2., 3., 0.]),
            ],
        ),
        // G28.1 stores the position; G28 goes there (named axes only).
        (
            "G0 X10 Y10\nG28.1\nG0 X0 Y0\nG28",
            vec![
                R([10., 10., 3., 0.]),
                R([0., 0., 3., 0.]),
                R([10., 10., 3., 0.]),
            ],
        ),
        (
            "G0 X10\nG28.1\nG0 X0 Y5 Z7\nG28 Y",
            vec![
                R([10., 2., 3., 0.]),
                R([0., 5., 7., 0.]),
                R([0., 2., 7., 0.]),
            ],
        ),
        (
            "G0 X10 Z9\nG28.1\nG0 X0 Z0\nG28 X",
            vec![
                R([10., 2., 9., 0.]),
                R([0., 2., 0., 0.]),
                R([10., 2., 0., 0.]),
            ],
        ),
        // Homing clears the G92 offset of the homed axes (Marlin).
        ("G92 X0\nG28 X\nG0 X5", vec![R([5., 2., 3., 0.])]),
        ("G92 X0 Y0\nG28 X\nG0 X5 Y5", vec![R([5., 7., 3., 0.])]),
        // ... but not the work offsets.
        ("G10 L2 P1 X10\nG28 X\nG0 X0", vec![R([10., 2., 3., 0.])]),
    ]);
    errors(&[
        ("G28.1 X5", 1, 7, "G28.1 takes no axis words"),
        ("G92.1 X5", 1, 7, "G92.1 takes no axis words"),
    ]);
}

#[test]
fn inverse_time_feed() {
    table(&[
        // 10 mm in 60/6 = 10 s.
        ("G93 G1 X11 F6", vec![F([11., 2., 3., 0.], 1.)]),
        // 5 mm (3-4-5) in 1 s.
        ("G93 G1 X4 Y6 F60", vec![F([4., 6., 3., 0.], 5.)]),
        (
            "G93 G1 X11 F6\nG1 X21 F12",
            vec![F([11., 2., 3., 0.], 1.), F([21., 2., 3., 0.], 2.)],
        ),
        // Riding axes (E) do not count while a path axis moves...
        ("G93 G1 X11 E100 F6", vec![F([11., 2., 3., 100.], 1.)]),
        // ...but a move of E alone measures E.
        ("G93 G1 E2 F30", vec![F([1., 2., 3., 2.], 1.)]),
        // F is not scaled by G20 in G93.
        ("G20 G93 G1 X2 F6", vec![F([50.8, 2., 3., 0.], 4.98)]),
        // Rapids need no F.
        ("G93\nG0 X5", vec![R([5., 2., 3., 0.])]),
        // Back to G94: F per minute again.
        (
            "G93 G1 X11 F6\nG94 G1 X12 F60",
            vec![F([11., 2., 3., 0.], 1.), F([12., 2., 3., 0.], 1.)],
        ),
        // An F on a line without G1/G2/G3 is ignored in G93.
        ("G93 F5\nG0 X5", vec![R([5., 2., 3., 0.])]),
    ]);
    errors(&[
        (
            "G93 G1 X11 F6\nG1 X12",
            2,
            1,
            "G1 in inverse time mode (G93) needs an F word on its line",
        ),
        ("G93 G1 X11 F6\nX12", 2, 1, "needs an F word"),
        (
            "G1 F60\nG93\nG2 X5 I2 F0",
            3,
            10,
            "feed rate must be positive",
        ),
        ("G1 F60\nG93 G94\n", 2, 5, "same modal group"),
        // Switching modes forgets the feed.
        ("G1 X5 F60\nG93\nG94\nG1 X6", 4, 1, "G1 without a feed rate"),
        ("G93 G1 X11 F6\nG94 G1 X12", 2, 5, "G1 without a feed rate"),
    ]);
}

#[test]
fn firmware_retraction() {
    table(&[
        ("G10", vec![F([1., 2., 3., -0.8], 35.)]),
        (
            "G10\nG10\nG11\nG11",
            vec![F([1., 2., 3., -0.8], 35.), F([1., 2., 3., 0.], 35.)],
        ),
        ("G11", vec![]),
        // The program's E does not change: E1 after a retraction is 0.2 on the machine.
        (
            "G10\nG1 E1 F60\nG11",
            vec![
                F([1., 2., 3., -0.8], 35.),
                F([1., 2., 3., 0.2], 1.),
                F([1., 2., 3., 1.], 35.),
            ],
        ),
        (
            "M83\nG10\nG1 X5 E1 F60\nG11\nG1 E1",
            vec![
                F([1., 2., 3., -0.8], 35.),
                F([5., 2., 3., 0.2], 1.),
                F([5., 2., 3., 1.], 35.),
                F([5., 2., 3., 2.], 1.),
            ],
        ),
        // G92 E while retracted.
        (
            "G10\nG92 E5\nG11\nG1 E6 F60",
            vec![
                F([1., 2., 3., -0.8], 35.),
                F([1., 2., 3., 0.], 35.),
                F([1., 2., 3., 1.], 1.),
            ],
        ),
        // G10 with L is the work offset, not a retraction.
        ("G10 L2 P1 E0", vec![]),
    ]);
    // Configurable length and speed.
    let opts = GcodeOptions {
        retract_length: 2.5,
        retract_speed: 10.0,
        ..GcodeOptions::default()
    };
    let p = parse("G10\nG11", &printer(), &opts).unwrap();
    check(
        "G10\nG11",
        &p,
        &[F([1., 2., 3., -2.5], 10.), F([1., 2., 3., 0.], 10.)],
    );
    let opts = GcodeOptions {
        retract_length: 0.0,
        ..GcodeOptions::default()
    };
    check(
        "G10\nG11",
        &parse("G10\nG11", &printer(), &opts).unwrap(),
        &[],
    );
    for bad in [
        GcodeOptions {
            retract_length: -1.0,
            ..GcodeOptions::default()
        },
        GcodeOptions {
            retract_speed: 0.0,
            ..GcodeOptions::default()
        },
        GcodeOptions {
            retract_speed: f64::NAN,
            ..GcodeOptions::default()
        },
    ] {
        assert!(parse("G0 X1", &printer(), &bad).is_err(), "{bad:?}");
    }
    errors(&[
        (
            "G10 X5",
            1,
            5,
            "G10 without L (firmware retraction) takes no axis words",
        ),
        (
            "G11 E1",
            1,
            5,
            "G11 (firmware unretraction) takes no axis words",
        ),
        ("G10 P1", 1, 5, "P is only used with G4"),
    ]);
    let e = run_with("G10", &no_tools(), false).unwrap_err();
    assert!(e.message.contains("needs an E axis (axes: x, y, z)"), "{e}");
}

#[test]
fn program_end() {
    table(&[
        ("G0 X5\nM2\nG0 X6", vec![R([5., 2., 3., 0.])]),
        ("G0 X5 M30\nG0 X6\nG0 garbage #!", vec![R([5., 2., 3., 0.])]),
        (
            "M3 S500\nM8\nM2",
            vec![T(0.5), A(Coolant, 2., false), T(0.), A(Coolant, 0., false)],
        ),
        (
            "M3 S500\nM5\nM7\nM9\nM30",
            vec![T(0.5), T(0.), A(Coolant, 1., false), A(Coolant, 0., false)],
        ),
        ("G1 F600 M4 S500\nM2", vec![Ps(0.5, 10.), T(0.)]),
    ]);
    // One warning if anything but blanks and comments follows.
    let p = run("G0 X5\nM2\nG0 X6\n\nG0 X7\n").unwrap();
    assert_eq!(p.warnings.len(), 1, "{:?}", p.warnings);
    assert_eq!(p.warnings[0].loc.line, 3);
    assert!(
        p.warnings[0]
            .message
            .contains("2 line(s) after the program end"),
        "{:?}",
        p.warnings
    );
    let p = run("G0 X5\nM30\n; the end\n\n%\n  \n").unwrap();
    assert!(p.warnings.is_empty(), "{:?}", p.warnings);
}

#[test]
fn m4_power_follows_speed() {
    table(&[
        ("G1 F600\nM4 S500", vec![Ps(0.5, 10.)]),
        ("G1 F600 M4", vec![Ps(0.8, 10.)]),
        // No feed yet: emitted before the first feed move.
        (
            "M4 S500\nG1 X5 F600",
            vec![Ps(0.5, 10.), F([5., 2., 3., 0.], 10.)],
        ),
        (
            "M4 S500 G1 X5 F600",
            vec![Ps(0.5, 10.), F([5., 2., 3., 0.], 10.)],
        ),
        // Re-emitted when F changes...
        (
            "G1 F600 M4 S500\nG1 X5 F1200",
            vec![Ps(0.5, 10.), Ps(0.5, 20.), F([5., 2., 3., 0.], 20.)],
        ),
        (
            "G1 F600 M4 S500\nF1200\nX5",
            vec![Ps(0.5, 10.), Ps(0.5, 20.), F([5., 2., 3., 0.], 20.)],
        ),
        // ...or S changes...
        ("G1 F600 M4 S500\nS250", vec![Ps(0.5, 10.), Ps(0.25, 10.)]),
        (
            "G1 F600 M4 S500\nG1 X5 S250",
            vec![Ps(0.5, 10.), Ps(0.25, 10.), F([5., 2., 3., 0.], 10.)],
        ),
        // ...but not for rapids or an unchanged feed.
        (
            "G1 F600 M4 S500\nG0 X5\nG1 X6\nG1 X7 F600",
            vec![
                Ps(0.5, 10.),
                R([5., 2., 3., 0.]),
                F([6., 2., 3., 0.], 10.),
                F([7., 2., 3., 0.], 10.),
            ],
        ),
        // In G93 every move's feed.
        (
            "G93 M4 S500\nG1 X11 F6\nG1 X21 F12",
            vec![
                Ps(0.5, 1.),
                F([11., 2., 3., 0.], 1.),
                Ps(0.5, 2.),
                F([21., 2., 3., 0.], 2.),
            ],
        ),
        // M3 after M4 and M5.
        (
            "G1 F600 M4 S500\nM3 S500\nM5",
            vec![Ps(0.5, 10.), T(0.5), T(0.)],
        ),
        ("M4 S500\nM5", vec![T(0.)]),
    ]);
    // A pen (or spindle): M4 acts as M3, with a warning.
    let p = run_with("M4 S500\nM4", &plotter(), false).unwrap();
    check("M4 (pen)", &p, &[T(1.0), T(0.75)]);
    assert_eq!(p.warnings.len(), 1);
    assert!(
        p.warnings[0]
            .message
            .contains("M4 on a pen or spindle acts as M3"),
        "{:?}",
        p.warnings
    );
    let e = run_with("M4", &no_tools(), false).unwrap_err();
    assert!(e.message.contains("M4 needs a tool"), "{e}");
}

#[test]
fn printer_and_auxiliary_codes() {
    table(&[
        ("M104 S200", vec![A(Hotend(0), 200., false)]),
        ("M104 S200 T1", vec![A(Hotend(1), 200., false)]),
        (
            "T2\nM104 S210\nM109 S215 T0",
            vec![A(Hotend(2), 210., false), A(Hotend(0), 215., true)],
        ),
        ("M109 S215", vec![A(Hotend(0), 215., true)]),
        ("M109 R190", vec![A(Hotend(0), 190., true)]),
        ("M104 S0 ; off", vec![A(Hotend(0), 0., false)]),
        ("M140 S60", vec![A(Bed, 60., false)]),
        ("M190 S60", vec![A(Bed, 60., true)]),
        ("M190 R40", vec![A(Bed, 40., true)]),
        ("M141 S40", vec![A(Chamber, 40., false)]),
        ("M191 S45", vec![A(Chamber, 45., true)]),
        ("M106", vec![A(Fan(0), 1., false)]),
        ("M106 S255", vec![A(Fan(0), 1., false)]),
        ("M106 S127.5", vec![A(Fan(0), 0.5, false)]),
        ("M106 P1 S51", vec![A(Fan(1), 0.2, false)]),
        ("M106 S300", vec![A(Fan(0), 1., false)]),
        ("M106 S-5", vec![A(Fan(0), 0., false)]),
        ("M107", vec![A(Fan(0), 0., false)]),
        ("M107 P2", vec![A(Fan(2), 0., false)]),
        ("M7", vec![A(Coolant, 1., false)]),
        ("M8", vec![A(Coolant, 2., false)]),
        ("M9", vec![A(Coolant, 0., false)]),
        ("M400", vec![Sync]),
        ("M0", vec![P(false)]),
        ("M1", vec![P(true)]),
        ("M00\nM01", vec![P(false), P(true)]),
        // Extra firmware arguments are ignored, checksums still verified.
        ("M104 S200 B210 F1", vec![A(Hotend(0), 200., false)]),
        ("M106 S255 I1", vec![A(Fan(0), 1., false)]),
    ]);
    let src = format!("{}\n", with_checksum("N4 M104 S200 T0"));
    check(&src, &run(&src).unwrap(), &[A(Hotend(0), 200., false)]);
    errors(&[
        ("M104", 1, 1, "M104 needs S (temperature)"),
        ("M109 T0", 1, 1, "M109 needs S (temperature) or R"),
        ("M104 R200", 1, 1, "M104 needs S"),
        (
            "M140 S99999",
            1,
            1,
            "temperature must be from -273.15 to 2000 °C, got 99999",
        ),
        ("M106 P-1 S5", 1, 1, "M106: bad P-1"),
        ("M104 S200 T1.5", 1, 1, "M104: bad T1.5"),
        ("M104 S", 1, 6, "S without a number"),
        ("M104 S1.2.3", 1, 6, "bad number"),
        ("M104 S200 S210", 1, 11, "S appears twice"),
        ("M104 S200*1", 1, 10, "checksum mismatch"),
        ("T1 T2", 1, 4, "T appears twice"),
    ]);
    // Accepted with a warning and no command.
    for code in ["M114", "M84", "M18", "M17", "M105", "M84 X Y"] {
        let p = run(code).unwrap_or_else(|e| panic!("{code}: {e}"));
        assert!(p.commands.is_empty(), "{code}");
        assert_eq!(p.warnings.len(), 1, "{code}");
    }
}
