//! Table-driven tests: G-code snippet -> expected commands, and bad snippet ->
//! expected line:column and message.

use crate::common;

use common::*;
use motet_planner::{AuxChannel, Command, SourceLoc};
use Want::{A, D, F, R, T};

#[test]
fn snippets_give_expected_commands() {
    let cases: Vec<(&str, Vec<Want>)> = vec![
        // G0 / G1, modal motion and feed
        ("G0 X10 Y20", vec![R([10., 20., 3., 0.])]),
        ("G00 X10", vec![R([10., 2., 3., 0.])]),
        ("G1 X10 F600", vec![F([10., 2., 3., 0.], 10.)]),
        ("G1 F600\nX5\nY6", vec![F([5., 2., 3., 0.], 10.), F([5., 6., 3., 0.], 10.)]),
        ("G0 F600\nG1 X5", vec![F([5., 2., 3., 0.], 10.)]),
        ("G1 X5 F60\nG0 X6\nG1 X7", vec![F([5., 2., 3., 0.], 1.), R([6., 2., 3., 0.]), F([7., 2., 3., 0.], 1.)]),
        ("G1 X5 F60\nF120 X6", vec![F([5., 2., 3., 0.], 1.), F([6., 2., 3., 0.], 2.)]),
        ("G1X5Y6F60", vec![F([5., 6., 3., 0.], 1.)]),
        ("g1 x5 f60", vec![F([5., 2., 3., 0.], 1.)]),
        ("G0 X 5 Y 6", vec![R([5., 6., 3., 0.])]),
        // zero-length moves are dropped; G0/G1 alone just set the mode
        ("G0 X1 Y2 Z3", vec![]),
        ("G1\nG0", vec![]),
        // number forms
        ("G0 X.5 Y+2 Z1.", vec![R([0.5, 2., 1., 0.])]),
        ("G0 X-1.5 Y-.25", vec![R([-1.5, -0.25, 3., 0.])]),
        ("G0 X007", vec![R([7., 2., 3., 0.])]),
        // relative / absolute
        ("G91\nG0 X1\nX1", vec![R([2., 2., 3., 0.]), R([3., 2., 3., 0.])]),
        ("G91 G0 X1 Y-1\nG90 X0", vec![R([2., 1., 3., 0.]), R([0., 1., 3., 0.])]),
        ("G91 G0 Z-1\nG90\nG0 Z5", vec![R([1., 2., 2., 0.]), R([1., 2., 5., 0.])]),
        // inch mode
        ("G20 G1 X1 F60", vec![F([25.4, 2., 3., 0.], 25.4)]),
        ("G20\nG0 X1\nG21\nG0 X1", vec![R([25.4, 2., 3., 0.]), R([1., 2., 3., 0.])]),
        ("G20 G91 G0 X1 Y-0.5", vec![R([26.4, 2. - 12.7, 3., 0.])]),
        ("G1 F60 G20 X1", vec![F([25.4, 2., 3., 0.], 25.4)]),
        // G92 offsets: machine = program + offset
        ("G92 X0 Y0\nG0 X10", vec![R([11., 2., 3., 0.])]),
        ("G92 X0 Y0\nG0 X10 Y10", vec![R([11., 12., 3., 0.])]),
        ("G91\nG92 X100\nG0 X1", vec![R([2., 2., 3., 0.])]),
        ("G92 X5\nG90 G0 X5", vec![]),
        ("G92 X0\nG92 X10\nG0 X10", vec![]),
        ("G20 G92 X1\nG0 X0", vec![R([1. - 25.4, 2., 3., 0.])]),
        // extrusion: E absolute by default, M83 relative, G91 does not touch E
        ("G92 E0\nG1 E5 F60", vec![F([1., 2., 3., 5.], 1.)]),
        ("G1 E2 F60\nG1 E3", vec![F([1., 2., 3., 2.], 1.), F([1., 2., 3., 3.], 1.)]),
        ("M83\nG1 E2 F60\nG1 E2", vec![F([1., 2., 3., 2.], 1.), F([1., 2., 3., 4.], 1.)]),
        ("G91\nG1 X1 E2 F60\nG1 X1 E3", vec![F([2., 2., 3., 2.], 1.), F([3., 2., 3., 3.], 1.)]),
        ("M83\nG90 G1 X1 E1 F60\nG1 X1 E1", vec![F([1., 2., 3., 1.], 1.), F([1., 2., 3., 2.], 1.)]),
        ("M83\nG1 E1 F60\nM82\nG1 E1", vec![F([1., 2., 3., 1.], 1.)]),
        ("M83\nG1 E1 F60\nG92 E0\nM82\nG1 E2", vec![F([1., 2., 3., 1.], 1.), F([1., 2., 3., 3.], 1.)]),
        ("G1 E1 F60\nG92 E0\nG1 E1", vec![F([1., 2., 3., 1.], 1.), F([1., 2., 3., 2.], 1.)]),
        // dwell
        ("G4 P500", vec![D(0.5)]),
        ("G4 S2", vec![D(2.)]),
        ("G4 P0", vec![D(0.)]),
        ("G04 S1.5", vec![D(1.5)]),
        // tool: laser power S/1000 clamped, on_value without S, M5 off
        ("M3 S500", vec![T(0.5)]),
        ("M3", vec![T(0.8)]),
        ("M03 S2000", vec![T(1.0)]),
        ("M3 S-5", vec![T(0.0)]),
        ("M3 S1000\nM5", vec![T(1.0), T(0.0)]),
        ("M3 S1000\nG1 X5 S500 F60", vec![T(1.0), T(0.5), F([5., 2., 3., 0.], 1.)]),
        ("M3 S1000\nG1 X5 S1000 F60", vec![T(1.0), F([5., 2., 3., 0.], 1.)]),
        ("G1 F60 M3 S250 X5", vec![T(0.25), F([5., 2., 3., 0.], 1.)]),
        ("M3 S500 G4 P100", vec![T(0.5), D(0.1)]),
        ("M3 S500\nG4 S1", vec![T(0.5), D(1.)]),
        // G28: rapid to start for named axes (all if none), offsets reset
        ("G0 X10 Y10 Z10\nG28", vec![R([10., 10., 10., 0.]), R([1., 2., 3., 0.])]),
        ("G0 X10 Y10\nG28 X", vec![R([10., 10., 3., 0.]), R([1., 10., 3., 0.])]),
        // (axis words with values are an intermediate point, RS274NGC style)
        ("G0 X10 Y10\nG28 X0 Y0", vec![R([10., 10., 3., 0.]), R([0., 0., 3., 0.]), R([1., 2., 3., 0.])]),
        ("G92 X0\nG28 X\nG0 X5", vec![R([5., 2., 3., 0.])]),
        ("G28", vec![]),
        // comments, line numbers, checksums, blank lines, CRLF, %
        ("G0 X5 ; comment G0 X9", vec![R([5., 2., 3., 0.])]),
        ("(comment) G0 (inline X9) X5 (end)", vec![R([5., 2., 3., 0.])]),
        ("; whole line\n\n   \n\tG0 X5\n", vec![R([5., 2., 3., 0.])]),
        ("N10 G0 X5\nN11 G0 X6", vec![R([5., 2., 3., 0.]), R([6., 2., 3., 0.])]),
        ("G0 X5\r\nG0 X6\r\n", vec![R([5., 2., 3., 0.]), R([6., 2., 3., 0.])]),
        ("%\nG0 X5\n%", vec![R([5., 2., 3., 0.])]),
        ("\u{feff}G0 X5", vec![R([5., 2., 3., 0.])]),
        ("(ünïcödé) G0 X5 ; ☃", vec![R([5., 2., 3., 0.])]),
        ("G0 X5 ; ***** banner *****", vec![R([5., 2., 3., 0.])]),
        // accepted no-op modes
        ("G17 G21 G90 G94 G0 X5", vec![R([5., 2., 3., 0.])]),
        // printer temperatures
        (
            "M104 S200\nM109 S200 T0\nM140 S60\nM190 S60\nG0 X5",
            vec![
                A(AuxChannel::Hotend(0), 200., false),
                A(AuxChannel::Hotend(0), 200., true),
                A(AuxChannel::Bed, 60., false),
                A(AuxChannel::Bed, 60., true),
                R([5., 2., 3., 0.]),
            ],
        ),
        // accepted slicer codes: no command
        ("M84\nM73 P10 R5\nM117 Hello: world 1.2.3 #!\nM201 X1000 Y1000 E5000\nM203 X500 A9\nM204 P500 T1000\nM205 X8 Y8 E5 Q1\nM220 S100\nM221 S95 T0\nM900 K0.05\nM862.3 P \"MK3S\"\nM862.1 P0.4\nM115 U3.9.0\nG29 L1 W2\nG80\nM17\nM18\nM105\nM114\nT0\nT9", vec![]),
    ];
    for (src, want) in &cases {
        let parsed = run(src).unwrap_or_else(|e| panic!("{src:?}: {e}"));
        check(src, &parsed, want);
    }
    // Checksummed lines (Marlin host style).
    let src = [
        with_checksum("N1 G0 X5"),
        with_checksum("N2 G0 X6 (c)"),
        format!("{} ; note", with_checksum("N3 M117 a*b")),
    ]
    .join("\n");
    check(
        &src,
        &run(&src).unwrap(),
        &[R([5., 2., 3., 0.]), R([6., 2., 3., 0.])],
    );
}

#[test]
fn pen_and_other_targets() {
    let pen = plotter();
    for (src, want) in [
        ("M3 S500", vec![T(1.0)]),
        ("M3", vec![T(0.75)]),
        ("M3\nM5", vec![T(0.75), T(0.0)]),
        ("M3 S1\nG1 X1 F60 S200", vec![T(1.0)]),
    ] {
        let mut p = run_with(src, &pen, false).unwrap();
        // Compare tool events only (the plotter's moves are x/y only).
        p.commands
            .retain(|c| matches!(c.item, Command::Tool { .. }));
        check(src, &p, &want);
    }
    let e = run_with("M3", &no_tools(), false).unwrap_err();
    assert_eq!(e.loc, SourceLoc { line: 1, column: 1 });
    assert!(e.message.contains("M3 needs a tool"), "{e}");
    let e = run_with("G0 X1\nM5", &no_tools(), false).unwrap_err();
    assert_eq!(e.loc, SourceLoc { line: 2, column: 1 });
    let e = run_with("G1 X1 E2 F60", &no_tools(), false).unwrap_err();
    assert_eq!(e.loc, SourceLoc { line: 1, column: 7 });
    assert_eq!(e.message, "axis E is not on this machine (axes: x, y, z)");
}

#[test]
fn warnings_are_located_and_folded() {
    let p = run("G0 X1\n  M205 X8\nM205 S0 T0\nM73 P1\nG28 X\nT1").unwrap();
    let w: Vec<(u32, u32, &str)> = p
        .warnings
        .iter()
        .map(|w| (w.loc.line, w.loc.column, w.message.as_str()))
        .collect();
    assert_eq!(w.len(), 4, "{w:#?}");
    assert_eq!((w[0].0, w[0].1), (2, 3));
    assert!(
        w[0].2
            .starts_with("M205 (set jerk) ignored: limits come from the machine file"),
        "{}",
        w[0].2
    );
    assert!(w[0].2.ends_with("(1 more like this)"), "{}", w[0].2);
    assert_eq!((w[1].0, w[1].1), (4, 1));
    assert!(w[1].2.starts_with("M73 "));
    assert!(!w[1].2.contains("more like this"));
    assert_eq!((w[2].0, w[2].1), (5, 1));
    assert!(w[2]
        .2
        .contains("G28 (home) is simulated as a rapid move to the home position"));
    assert!(w[3].2.contains("T1 selects extruder 1 for temperatures"));
}

#[test]
fn command_locations_point_at_the_word() {
    let p = run("G1 F60\n  X5\nN3 G0 X1 Y1\nM3 S10\n  G4 P1").unwrap();
    let locs: Vec<(u32, u32)> = p
        .commands
        .iter()
        .map(|c| (c.loc.line, c.loc.column))
        .collect();
    assert_eq!(locs, vec![(2, 3), (3, 4), (4, 1), (5, 3)]);
}

#[test]
fn allow_unknown_skips_with_warnings() {
    let t = printer();
    let cases: &[(&str, Vec<Want>, usize)] = &[
        ("G38.2 Z-10 F100\nG0 X5", vec![R([5., 2., 3., 0.])], 1),
        ("M300 S440 P200\nM60\nG0 X5", vec![R([5., 2., 3., 0.])], 2),
        ("G59.1 G0 X5", vec![R([5., 2., 3., 0.])], 1),
        ("G43 H1 Z15\nG0 X5", vec![R([5., 2., 3., 0.])], 2),
        (
            "G0 X5\nG30 P1 X0\nX3",
            vec![R([5., 2., 3., 0.]), R([3., 2., 3., 0.])],
            1,
        ),
        ("T256\nG0 X5", vec![R([5., 2., 3., 0.])], 1),
    ];
    for (src, want, nwarn) in cases {
        assert!(
            run(src).is_err(),
            "{src:?} should fail without allow_unknown"
        );
        let p = run_with(src, &t, true).unwrap_or_else(|e| panic!("{src:?}: {e}"));
        check(src, &p, want);
        assert_eq!(p.warnings.len(), *nwarn, "{src:?}: {:#?}", p.warnings);
        assert!(
            p.warnings.iter().all(|w| w.message.contains("skipped")),
            "{:#?}",
            p.warnings
        );
    }
    let p = run_with("G38.2 Z-10", &t, true).unwrap();
    assert_eq!(p.warnings[0].message, "unsupported G-code G38.2 skipped");
}

#[test]
fn bad_snippets_give_located_errors() {
    let cases: &[(&str, u32, u32, &str)] = &[
        ("G1 X10", 1, 1, "G1 without a feed rate (no F word yet)"),
        ("G0 X1\n  G1 X2", 2, 3, "G1 without a feed rate"),
        ("G1\nX2", 2, 1, "G1 without a feed rate"),
        ("G2 X10 I5", 1, 1, "G2 without a feed rate"),
        (
            "G0 A5",
            1,
            4,
            "axis A is not on this machine (axes: x, y, z, e)",
        ),
        ("G0 X1 W5", 1, 7, "unsupported word W5"),
        ("G38.2 Z-10", 1, 1, "unsupported G-code G38.2"),
        ("G0 X0\n G038.2 Z-10", 2, 2, "unsupported G-code G38.2"),
        ("M6 T1", 1, 1, "unsupported M-code M6"),
        ("T256", 1, 1, "unsupported tool select T256"),
        ("G-1", 1, 1, "unsupported G-code G-1"),
        ("G1.25", 1, 1, "unsupported G-code G1.25"),
        ("G0 X1.2.3", 1, 4, "bad number '1.2.3'"),
        ("G0 X-", 1, 4, "bad number '-'"),
        ("G0 X1-2", 1, 4, "bad number '1-2'"),
        ("G0 X.", 1, 4, "bad number '.'"),
        ("G0 X", 1, 4, "X without a number"),
        ("G1 F", 1, 4, "F without a number"),
        ("G0 X1 #5", 1, 7, "unexpected character '#'"),
        ("G0 X1 [2]", 1, 7, "unexpected character '['"),
        ("(é) G0 X1 #", 1, 11, "unexpected character '#'"),
        ("Ñ", 1, 1, "unexpected character 'Ñ'"),
        ("G0 X1=5", 1, 6, "unexpected character '='"),
        ("10 G0", 1, 1, "number without a letter"),
        ("G0 X1 20", 1, 7, "number without a letter"),
        ("G0 X1\rG0 X2", 1, 7, "same modal group"), // a lone CR is not a line end
        ("G0 X1*99", 1, 6, "checksum mismatch"),
        ("G0 X1*", 1, 6, "'*' without a checksum number"),
        ("G0 X1 (unclosed", 1, 7, "unclosed '(' comment"),
        ("G0 G1 X5", 1, 4, "same modal group"),
        ("G2 G3 X5", 1, 4, "same modal group"),
        ("G20 G21", 1, 5, "same modal group"),
        ("G90 G91", 1, 5, "same modal group"),
        ("G4 P1 G92 X0", 1, 7, "same modal group"),
        ("M3 M5", 1, 4, "same modal group"),
        ("M82 M83", 1, 5, "same modal group"),
        ("G0 X1 X2", 1, 7, "X appears twice on this line"),
        ("G1 F60 F70", 1, 8, "F appears twice"),
        ("X5", 1, 1, "axis words without a motion mode"),
        ("G0 I5", 1, 4, "I is only used with G2/G3"),
        ("G1 X1 F60 R5", 1, 11, "R is only used with G2/G3"),
        ("G0 X5 P3", 1, 7, "P is only used with G4"),
        ("G4", 1, 1, "G4 needs P (milliseconds) or S (seconds)"),
        ("G4 P-5", 1, 4, "G4 P (dwell) must be from 0 to 8.64e7 ms, got -5"),
        // Extreme values: each word out of its range in motet_planner::ranges.
        ("G4 S20000000000000", 1, 4, "G4 S (dwell) must be from 0 to 86400 s, got 2e13"),
        ("G4 S86401", 1, 4, "G4 S (dwell) must be from 0 to 86400 s, got 86401"),
        ("G4 P86400001", 1, 4, "G4 P (dwell) must be from 0 to 8.64e7 ms, got 8.6400001e7"),
        ("G1 X1 F0.01", 1, 7, "F0.01 is a feed of 0.00016666666666666666 units/s; feeds must be from 0.001 to 100000 units/s"),
        ("G1 X1 F99999999", 1, 7, "feeds must be from 0.001 to 100000 units/s"),
        ("G20\nG1 X1 F1000000", 2, 7, "F1000000 is a feed of 423333.3333333333 units/s"),
        ("G93 G1 X1 F100000000", 1, 11, "F (inverse time, G93) must be from 0.001 to 1e7 per minute, got 1e8"),
        ("G0 X2000000", 1, 4, "X must be from -1000000 to 1000000 mm, got 2000000"),
        ("G20\nG0 Y50000", 2, 4, "Y must be from -1000000 to 1000000 mm, got 1270000"),
        ("G92 Z-1000001", 1, 5, "Z must be from -1000000 to 1000000 mm, got -1000001"),
        ("G10 L2 P1 X1000001", 1, 11, "X must be from -1000000 to 1000000 mm"),
        ("G0 E1000001", 1, 4, "E must be from -1000000 to 1000000 mm"),
        ("G2 X1 I1000000000 F60", 1, 7, "I must be from -1000000 to 1000000 mm, got 1e9"),
        ("G2 X1 R-2000000 F60", 1, 7, "R must be from -1000000 to 1000000 mm, got -2000000"),
        ("G4 P1 S1", 1, 7, "not both"),
        ("G1 F0 X1", 1, 4, "feed rate must be positive"),
        ("G1 F-5", 1, 4, "feed rate must be positive"),
        ("G92", 1, 1, "G92 needs at least one axis word"),
        ("G92 X", 1, 5, "X without a number"),
        (
            "G28 X0 G0 Y5",
            1,
            1,
            "G28 and G0 on one line both use the axis words",
        ),
        (
            "G0 X0 Y0\nG2 X10 R2 F60",
            2,
            8,
            "smaller than half the distance",
        ),
        (
            "G0 X0 Y0\nG2 X10 I3 F60",
            2,
            1,
            "end point is not on the arc",
        ),
        (
            "G0 X0 Y0\nG2 X10 Y1 I5 F60",
            2,
            1,
            "end point is not on the arc",
        ),
        ("G2 I0 J0 F60", 1, 1, "radius is zero"),
        (
            "G2 X5 F60",
            1,
            1,
            "G2 needs I/J (centre offset) or R (radius)",
        ),
        (
            "G3 R5 F60",
            1,
            4,
            "needs an end point different from the start",
        ),
        ("G2 X10 R5 I5 F60", 1, 11, "either R or I/J"),
        ("N1x G0", 1, 3, "X without a number"),
        ("Nx", 1, 1, "bad line number"),
        ("G0 X1\nG0 Y2\n\n\nG0 Q1", 5, 4, "unsupported word Q1"),
    ];
    for &(src, line, column, msg) in cases {
        let e = match run(src) {
            Ok(p) => panic!(
                "{src:?}: expected an error, got {} commands",
                p.commands.len()
            ),
            Err(e) => e,
        };
        assert!(
            e.message.contains(msg),
            "{src:?}: message {:?} lacks {msg:?}",
            e.message
        );
        assert_eq!(
            (e.loc.line, e.loc.column),
            (line, column),
            "{src:?}: {}",
            e.message
        );
    }
}

#[test]
fn an_extruder_without_travel_counts_up_to_a_billion_mm() {
    // An extruder's position counts all the filament it ever pushed.
    let mut t = printer();
    t.axes[3].travel = [f64::NEG_INFINITY, f64::INFINITY];
    let p = run_with("G1 E999999999 F60", &t, false).unwrap();
    assert_eq!(p.commands.len(), 1);
    let e = run_with("G1 E1000000001 F60", &t, false).unwrap_err();
    assert!(e.message.contains("E must be from -1e9 to 1e9 mm"), "{e}");
    assert_eq!((e.loc.line, e.loc.column), (1, 4));
}

#[test]
fn huge_arc_is_an_error_not_a_hang() {
    // The largest radius at the finest tolerance would need more chords than
    // an arc may have.
    let mut fine = printer();
    fine.tolerance = 1e-4;
    match run_with("G0 X0 Y0\nG2 X0 Y0 I1000000 F60", &fine, false) {
        Ok(p) => panic!("expected an error, got {} commands", p.commands.len()),
        Err(e) => assert!(e.message.contains("chords"), "{e}"),
    }
    let e = run_with("G1 X1e5 F60", &no_tools(), false).unwrap_err();
    assert!(e.message.contains("axis E"), "{e}"); // no exponents: 'e' starts a word
}
