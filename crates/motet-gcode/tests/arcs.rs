//! Arcs: flattened points lie on the circle, chords stay within tolerance,
//! the last point is exactly the programmed end, the sweep goes the right way.

mod common;

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
