//! Arcs: flattened points lie on the circle, chords stay within tolerance,
//! the last point is exactly the programmed end, the sweep goes the right way.

use crate::common;

use common::*;
use core::f64::consts::{PI, TAU};
use motet_planner::{Command, MoveKind};

#[derive(Clone, Copy)]
struct ArcCase {
    src: &'static str,
    center: [f64; 2],
    radius: f64,
    end: [f64; 4],
    /// Signed swept angle (negative = clockwise).
    sweep: f64,
    feed: f64,
}

fn check_arc(c: &ArcCase, tol: f64) {
    let p = run(c.src).unwrap_or_else(|e| panic!("{}: {e}", c.src));
    // Commands before the arc: those of every line but the last.
    let setup = c.src.rsplit_once('\n').map_or("", |(a, _)| a);
    let skip = run(setup).unwrap().commands.len();
    let moves: Vec<_> = p
        .commands
        .iter()
        .skip(skip)
        .map(|m| match m.item {
            Command::Move(m) => m,
            other => panic!("{}: unexpected {other:?}", c.src),
        })
        .collect();
    assert!(!moves.is_empty(), "{}", c.src);
    let last = moves.last().unwrap();
    assert_eq!(&last.target[..4], &c.end[..], "{}: end is exact", c.src);
    // Walk the chords from the start point (the machine position before the arc).
    let mut prev = match p.commands[skip - 1].item {
        Command::Move(m) => m.target,
        _ => unreachable!(),
    };
    let [cx, cy] = c.center;
    let mut swept = 0.0;
    let z0 = prev[2];
    let n = moves.len();
    for (k, m) in moves.iter().enumerate() {
        assert_eq!(m.kind, MoveKind::Feed, "{}", c.src);
        assert!((m.feed - c.feed).abs() < 1e-12, "{}", c.src);
        let t = m.target;
        let r = (t[0] - cx).hypot(t[1] - cy);
        assert!(
            (r - c.radius).abs() <= 1e-6,
            "{}: point {k} radius {r} != {}",
            c.src,
            c.radius
        );
        // Sagitta: the chord midpoint is no deeper inside the circle than tol.
        let mid = ((prev[0] + t[0]) / 2.0 - cx).hypot((prev[1] + t[1]) / 2.0 - cy);
        assert!(
            c.radius - mid <= tol + 1e-9,
            "{}: chord {k} sagitta {}",
            c.src,
            c.radius - mid
        );
        let mut d = (t[1] - cy).atan2(t[0] - cx) - (prev[1] - cy).atan2(prev[0] - cx);
        if d > PI {
            d -= TAU;
        } else if d < -PI {
            d += TAU;
        }
        assert!(
            d * c.sweep.signum() > 0.0,
            "{}: chord {k} goes the wrong way",
            c.src
        );
        swept += d;
        // Helix: z (and e) move linearly with the angle.
        let frac = (k + 1) as f64 / n as f64;
        let z = z0 + (c.end[2] - z0) * frac;
        assert!((t[2] - z).abs() < 1e-9, "{}: z {} != {z}", c.src, t[2]);
        prev = t;
    }
    assert!(
        (swept - c.sweep).abs() < 1e-6,
        "{}: swept {swept}, want {}",
        c.src,
        c.sweep
    );
}

#[test]
fn arcs_lie_on_the_circle_and_end_exactly() {
    let h = 75f64.sqrt(); // for R10 over a chord of 10
    let cases = [
        // IJK, half circles both ways
        ArcCase {
            src: "G0 X0 Y0\nG2 X10 Y0 I5 J0 F600",
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 3., 0.],
            sweep: -PI,
            feed: 10.,
        },
        ArcCase {
            src: "G0 X0 Y0\nG3 X10 Y0 I5 J0 F600",
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 3., 0.],
            sweep: PI,
            feed: 10.,
        },
        // quarter circle, centre offset in J only
        ArcCase {
            src: "G0 X0 Y0\nG3 X5 Y5 J5 F60",
            center: [0., 5.],
            radius: 5.,
            end: [5., 5., 3., 0.],
            sweep: PI / 2.0,
            feed: 1.,
        },
        ArcCase {
            src: "G0 X0 Y0\nG2 X5 Y5 J5 F60",
            center: [0., 5.],
            radius: 5.,
            end: [5., 5., 3., 0.],
            sweep: -1.5 * PI,
            feed: 1.,
        },
        // R form: short arc for R>0, long arc for R<0, half circle when R = chord/2
        ArcCase {
            src: "G0 X0 Y0\nG2 X10 Y0 R5 F600",
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 3., 0.],
            sweep: -PI,
            feed: 10.,
        },
        ArcCase {
            src: "G0 X0 Y0\nG2 X10 Y0 R10 F600",
            center: [5., -h],
            radius: 10.,
            end: [10., 0., 3., 0.],
            sweep: -(PI / 3.0),
            feed: 10.,
        },
        ArcCase {
            src: "G0 X0 Y0\nG3 X10 Y0 R10 F600",
            center: [5., h],
            radius: 10.,
            end: [10., 0., 3., 0.],
            sweep: PI / 3.0,
            feed: 10.,
        },
        ArcCase {
            src: "G0 X0 Y0\nG2 X10 Y0 R-10 F600",
            center: [5., h],
            radius: 10.,
            end: [10., 0., 3., 0.],
            sweep: -(TAU - PI / 3.0),
            feed: 10.,
        },
        // full circles (IJK with end == start, with or without axis words)
        ArcCase {
            src: "G0 X0 Y0\nG2 X0 Y0 I5 F600",
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., 3., 0.],
            sweep: -TAU,
            feed: 10.,
        },
        ArcCase {
            src: "G0 X0 Y0\nG3 I-5 J0 F600",
            center: [-5., 0.],
            radius: 5.,
            end: [0., 0., 3., 0.],
            sweep: TAU,
            feed: 10.,
        },
        // helix: z moves linearly
        ArcCase {
            src: "G0 X0 Y0 Z0\nG3 X0 Y0 I5 Z-2 F600",
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., -2., 0.],
            sweep: TAU,
            feed: 10.,
        },
        ArcCase {
            src: "G0 X0 Y0 Z0\nG2 X10 Y0 I5 Z4 F600",
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 4., 0.],
            sweep: -PI,
            feed: 10.,
        },
        // relative mode, inch mode, G92 offsets
        ArcCase {
            src: "G0 X0 Y0\nG91 G2 X10 I5 F600",
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 3., 0.],
            sweep: -PI,
            feed: 10.,
        },
        ArcCase {
            src: "G0 X0 Y0\nG20 G3 X1 I0.5 F60",
            center: [12.7, 0.],
            radius: 12.7,
            end: [25.4, 0., 3., 0.],
            sweep: PI,
            feed: 25.4,
        },
        ArcCase {
            src: "G0 X0 Y0\nG92 X100 Y100\nG2 X110 Y100 R5 F600",
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 3., 0.],
            sweep: -PI,
            feed: 10.,
        },
        // tiny radius: at least a few chords
        ArcCase {
            src: "G0 X0 Y0\nG2 X0.002 Y0 I0.001 F600",
            center: [0.001, 0.],
            radius: 0.001,
            end: [0.002, 0., 3., 0.],
            sweep: -PI,
            feed: 10.,
        },
        // modal G2 continues on the next line
        ArcCase {
            src: "G0 X0 Y0\nG2 X10 Y0 I5 F600\nX0 I-5",
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., 3., 0.],
            sweep: -PI,
            feed: 10.,
        },
    ];
    for c in &cases {
        check_arc(c, 0.01);
    }
}

#[test]
fn chord_count_follows_tolerance() {
    // r = 5, tol = 0.01: max step 2 acos(1 - 0.002) = 0.12651 rad -> 50 chords for 2 pi.
    let p = run("G0 X0 Y0\nG2 I5 F600").unwrap();
    let n = p.commands.len() - 1;
    let step = 2.0 * (1.0f64 - 0.01 / 5.0).acos();
    assert_eq!(n, (TAU / step).ceil() as usize);
    // Coarse tolerance never gives fewer than 4 chords for a full circle.
    let mut t = printer();
    t.tolerance = 100.0;
    let p = run_with("G0 X0 Y0\nG2 I5 F600", &t, false).unwrap();
    assert_eq!(p.commands.len() - 1, 4);
    // Nonsense tolerance falls back to a sane default rather than looping.
    t.tolerance = 0.0;
    assert!(run_with("G0 X0 Y0\nG2 I5 F600", &t, false).is_ok());
    t.tolerance = f64::NAN;
    assert!(run_with("G0 X0 Y0\nG2 I5 F600", &t, false).is_ok());
}

#[test]
fn ijk_radius_mismatch_limit() {
    // 0.1% of r = 10 is 0.01 > 0.002: a 0.009 mismatch passes, 0.011 fails.
    assert!(run("G0 X0 Y0\nG2 X20.009 Y0 I10 F600").is_ok());
    assert!(run("G0 X0 Y0\nG2 X20.011 Y0 I10 F600").is_err());
    // Small radius: the 0.002 mm floor applies.
    assert!(run("G0 X0 Y0\nG2 X1.0019 Y0 I0.5 F600").is_ok());
    assert!(run("G0 X0 Y0\nG2 X1.0021 Y0 I0.5 F600").is_err());
    // R just about half the chord is accepted as a half circle.
    assert!(run("G0 X0 Y0\nG2 X10 Y0 R4.9999999999999 F600").is_ok());
}

/// An arc in any plane: `a`, `b` are the plane's first and second axis
/// (G17: x y, G18: z x, G19: y z), the sweep is counter-clockwise-positive in
/// (a, b); every other axis moves linearly.
struct PlaneArc {
    src: &'static str,
    a: usize,
    b: usize,
    center: [f64; 2],
    radius: f64,
    end: [f64; 4],
    sweep: f64,
}

fn check_plane_arc(c: &PlaneArc) {
    let p = run(c.src).unwrap_or_else(|e| panic!("{}: {e}", c.src));
    let setup = c.src.rsplit_once('\n').map_or("", |(a, _)| a);
    let skip = run(setup).unwrap().commands.len();
    let mut prev = match p.commands[skip - 1].item {
        Command::Move(m) => m.target,
        _ => unreachable!(),
    };
    let start = prev;
    let moves: Vec<_> = p.commands[skip..]
        .iter()
        .map(|m| match m.item {
            Command::Move(m) => m.target,
            other => panic!("{}: unexpected {other:?}", c.src),
        })
        .collect();
    assert!(moves.len() >= 4, "{}", c.src);
    assert_eq!(
        &moves.last().unwrap()[..4],
        &c.end[..],
        "{}: end is exact",
        c.src
    );
    let [ca, cb] = c.center;
    let ang = |t: &[f64; 6]| (t[c.b] - cb).atan2(t[c.a] - ca);
    let mut swept = 0.0;
    let n = moves.len();
    for (k, t) in moves.iter().enumerate() {
        let r = (t[c.a] - ca).hypot(t[c.b] - cb);
        assert!(
            (r - c.radius).abs() < 1e-6,
            "{}: point {k} radius {r}",
            c.src
        );
        let mut d = ang(t) - ang(&prev);
        if d > PI {
            d -= TAU;
        } else if d < -PI {
            d += TAU;
        }
        assert!(
            d * c.sweep.signum() > 0.0,
            "{}: chord {k} goes the wrong way",
            c.src
        );
        swept += d;
        let frac = (k + 1) as f64 / n as f64;
        for i in (0..4).filter(|&i| i != c.a && i != c.b) {
            let want = start[i] + (c.end[i] - start[i]) * frac;
            assert!(
                (t[i] - want).abs() < 1e-9,
                "{}: axis {i} {} != {want}",
                c.src,
                t[i]
            );
        }
        prev = *t;
    }
    assert!(
        (swept - c.sweep).abs() < 1e-6,
        "{}: swept {swept}, want {}",
        c.src,
        c.sweep
    );
}

#[test]
fn arcs_in_every_plane_land_on_the_right_circle() {
    const X: usize = 0;
    const Y: usize = 1;
    const Z: usize = 2;
    let cases = [
        // G17 for reference.
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG17 G2 X10 I5 F600",
            a: X,
            b: Y,
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 0., 0.],
            sweep: -PI,
        },
        // G18: plane (Z, X), offsets K I; G3 from Z0 to Z10 about Z5 dips into -X.
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG18 G3 Z10 K5 F600",
            a: Z,
            b: X,
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., 10., 0.],
            sweep: PI,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG18 G2 Z10 K5 F600",
            a: Z,
            b: X,
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., 10., 0.],
            sweep: -PI,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG18 G2 X5 Z5 I5 F600",
            a: Z,
            b: X,
            center: [0., 5.],
            radius: 5.,
            end: [5., 0., 5., 0.],
            sweep: -1.5 * PI,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG18 G2 Z10 R5 F600",
            a: Z,
            b: X,
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., 10., 0.],
            sweep: -PI,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG18 G2 Z10 J0 K5 F600",
            a: Z,
            b: X,
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., 10., 0.],
            sweep: -PI,
        },
        // G18 helix along Y, full circle.
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG18 G3 I3 Y6 F600",
            a: Z,
            b: X,
            center: [0., 3.],
            radius: 3.,
            end: [0., 6., 0., 0.],
            sweep: TAU,
        },
        // G19: plane (Y, Z), offsets J K; G2 from Y0 to Y10 about Y5 rises into +Z.
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG19 G2 Y10 J5 F600",
            a: Y,
            b: Z,
            center: [5., 0.],
            radius: 5.,
            end: [0., 10., 0., 0.],
            sweep: -PI,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG19 G3 Y10 J5 F600",
            a: Y,
            b: Z,
            center: [5., 0.],
            radius: 5.,
            end: [0., 10., 0., 0.],
            sweep: PI,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG19 G3 Y5 Z5 K5 F600",
            a: Y,
            b: Z,
            center: [0., 5.],
            radius: 5.,
            end: [0., 5., 5., 0.],
            sweep: PI / 2.0,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG19 G3 Y10 R-5 F600",
            a: Y,
            b: Z,
            center: [5., 0.],
            radius: 5.,
            end: [0., 10., 0., 0.],
            sweep: PI,
        },
        // G19 helix along X with E riding along.
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG19 G3 J-5 X4 E2 F600",
            a: Y,
            b: Z,
            center: [-5., 0.],
            radius: 5.,
            end: [4., 0., 0., 2.],
            sweep: TAU,
        },
        // G90.1: absolute centre, in program coordinates (work offset X1).
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG10 L2 P1 X1\nG90.1 G3 X12 I5.5 J0 F600",
            a: X,
            b: Y,
            center: [6.5, 0.],
            radius: 6.5,
            end: [13., 0., 0., 0.],
            sweep: PI,
        },
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG90.1 G18 G2 Z10 K5 I0 F600",
            a: Z,
            b: X,
            center: [5., 0.],
            radius: 5.,
            end: [0., 0., 10., 0.],
            sweep: -PI,
        },
        // G91.1 back to relative.
        PlaneArc {
            src: "G0 X0 Y0 Z0\nG90.1\nG91.1 G2 X10 I5 F600",
            a: X,
            b: Y,
            center: [5., 0.],
            radius: 5.,
            end: [10., 0., 0., 0.],
            sweep: -PI,
        },
    ];
    for c in &cases {
        check_plane_arc(c);
    }
}

#[test]
fn plane_arc_errors() {
    let cases: &[(&str, u32, u32, &str)] = &[
        (
            "G18 G2 X5 J1 F60",
            1,
            11,
            "J is not used by arcs in plane G18 (K/I are)",
        ),
        (
            "G19 G2 Y5 I1 J2 F60",
            1,
            11,
            "I is not used by arcs in plane G19",
        ),
        (
            "G17 G2 X5 I2 K1 F60",
            1,
            14,
            "K is not used by arcs in plane G17",
        ),
        (
            "G18 G2 X5 F60",
            1,
            5,
            "G2 needs K/I (centre offset) or R (radius)",
        ),
        (
            "G19 G3 Y5 R5 K1 F60",
            1,
            14,
            "G3 takes either R or J/K, not both",
        ),
        (
            "G0 X0 Y0 Z0\nG18 G2 Z10 K4 F60",
            2,
            5,
            "end point is not on the arc",
        ),
        (
            "G0 X0 Y0 Z0\nG19 G2 Y10 R4 F60",
            2,
            12,
            "smaller than half the distance",
        ),
        (
            "G0 X0 Y0 Z0\nG93 G18 G2 Z10 K5",
            2,
            9,
            "G2 in inverse time mode (G93) needs an F word",
        ),
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
            "{src:?}: {:?} lacks {msg:?}",
            e.message
        );
        assert_eq!((e.loc.line, e.loc.column), (line, column), "{src:?}: {e}");
    }
    // A plotter has no z: G18 arcs are an error naming the axes.
    let e = run_with("G18 G2 X5 K1 F60", &plotter(), false).unwrap_err();
    assert!(
        e.message
            .contains("G2 in plane G18 needs axes z and x (axes: x, y)"),
        "{e}"
    );
}

#[test]
fn inverse_time_arc_takes_one_over_f_minutes() {
    // Half circle r = 5 in 60/6 = 10 s: the feed is the chord length / 10 s.
    let p = run("G0 X0 Y0\nG93 G2 X10 I5 F6").unwrap();
    let mut prev = [0.0, 0.0];
    let mut len = 0.0;
    let mut feed = None;
    for c in &p.commands[1..] {
        let Command::Move(m) = c.item else { panic!() };
        len += (m.target[0] - prev[0]).hypot(m.target[1] - prev[1]);
        prev = [m.target[0], m.target[1]];
        assert!(
            feed.is_none_or(|f| f == m.feed),
            "one feed for the whole arc"
        );
        feed = Some(m.feed);
    }
    let feed = feed.unwrap();
    assert!((feed * 10.0 - len).abs() < 1e-9, "{feed} * 10 s != {len}");
    assert!((len - 5.0 * PI).abs() < 0.001 * 5.0 * PI, "{len}");
}
