use super::*;
use crate::profile::fastest;

const N: usize = 16;

/// A window from boundary speeds, lengths, limits and a jerk (0: trapezoid).
/// Lengths of 0 are dwells. Speeds must be mutually reachable.
fn window(speeds: &[f64], lengths: &[f64], accels: &[f64], jerk: f64) -> heapless::Vec<Segment, N> {
    let mut out = heapless::Vec::new();
    let mut t0 = 1000.0;
    let mut x = 0.0;
    for i in 0..lengths.len() {
        let (v0, v1, l, a) = (speeds[i], speeds[i + 1], lengths[i], accels[i]);
        let profile = if l == 0.0 {
            Profile::dwell(0.01)
        } else {
            fastest(l, v0, v1, 200.0f64.max(v0).max(v1), a, jerk)
        };
        // A zig-zag path, so geometry is visibly kept.
        let mut start = [0.0; crate::MAX_AXES];
        start[0] = x;
        start[1] = (i % 2) as f64;
        let mut end = start;
        end[0] = x + l * 0.6;
        end[1] = start[1] + if i % 2 == 0 { l * 0.8 } else { -l * 0.8 };
        x = end[0];
        let s = Segment {
            t0,
            start,
            end,
            profile,
        };
        t0 = s.t1();
        out.push(s).unwrap();
    }
    out
}

/// Every property the tail promises, checked against the planned window.
fn check(planned: &[Segment], what: &str) -> Contingency {
    let mut tail = heapless::Vec::<Segment, N>::from_slice(planned).unwrap();
    let c = Contingency::apply(&mut tail).unwrap_or_else(|e| panic!("{what}: {e}"));
    let n = planned.len();
    assert_eq!(c.len, n);
    assert_eq!(
        c.stop,
        planned[n - 1].end,
        "{what}: stops at the last end point"
    );
    assert_eq!(
        &tail[..c.start],
        &planned[..c.start],
        "{what}: before the tail"
    );
    if !c.has_tail() {
        assert_eq!(planned[n - 1].profile.v1(), 0.0, "{what}");
        assert_eq!(c.start_time, planned[n - 1].t1(), "{what}");
        return c;
    }
    assert_eq!(c.start_time, planned[c.start].t0, "{what}: T_s");
    for j in c.start..n {
        let (p, t) = (&planned[j], &tail[j]);
        assert_eq!(
            (p.start, p.end),
            (t.start, t.end),
            "{what}: geometry of {j}"
        );
        assert_eq!(p.profile.length(), t.profile.length(), "{what}");
        let limit = p.profile.params().accel;
        // Speeds stay under the planned boundary speeds, except for a segment
        // left from a planned rest that has to move to reach the stop point.
        let cap = match p.profile.v0().max(t.profile.v1()) {
            0.0 => p.profile.vc(),
            _ => p.profile.v0().max(p.profile.v1()),
        };
        assert!(
            t.profile.v0() <= p.profile.v0(),
            "{what}: entry of {j} over plan"
        );
        assert!(
            t.profile.v1() <= p.profile.v1(),
            "{what}: exit of {j} over plan"
        );
        let dur = t.profile.duration();
        assert!(dur.is_finite(), "{what}: segment {j} never ends");
        for i in 0..=200 {
            let (_, v, a) = t.profile.state(dur * i as f64 / 200.0);
            assert!(
                a.abs() <= limit * (1.0 + 1e-9),
                "{what}: accel {a} > {limit} in {j}"
            );
            assert!(
                v <= cap * (1.0 + 1e-12) + 1e-12,
                "{what}: speed {v} > {cap} in {j}"
            );
            assert!(v >= -1e-9, "{what}");
        }
        let d = t.profile.distance_at(dur);
        assert!(
            (d - t.profile.length()).abs() <= 1e-9 * (1.0 + d),
            "{what}: covers {j}: {d} {:?} {:?}",
            t.profile,
            p.profile
        );
        if j > c.start {
            assert_eq!(t.t0, tail[j - 1].t1(), "{what}: contiguous at {j}");
            assert_eq!(
                t.profile.v0(),
                tail[j - 1].profile.v1(),
                "{what}: speed jump at {j}"
            );
        } else {
            assert_eq!(
                t.profile.v0(),
                p.profile.v0(),
                "{what}: enters at the planned speed"
            );
        }
    }
    assert_eq!(tail[n - 1].profile.v1(), 0.0, "{what}: ends at rest");
    // Latest: from the next boundary on, the machine cannot stop in time.
    for k in c.start + 1..n {
        let v = planned[k].profile.v0();
        let rest: f64 = planned[k..].iter().map(|s| s.profile.length()).sum();
        let min_a = planned[k..]
            .iter()
            .map(|s| s.profile.params().accel)
            .fold(f64::INFINITY, f64::min);
        assert!(
            v > 0.0 && v * v / (2.0 * rest) > min_a,
            "{what}: boundary {k} would have fit (v {v}, rest {rest}, a {min_a})"
        );
    }
    c
}

/// (name, boundary speeds, lengths, accels, jerk)
type Case<'a> = (&'a str, &'a [f64], &'a [f64], &'a [f64], f64);

#[test]
fn windows() {
    // (name, boundary speeds, lengths, accels, jerk)
    let cases: &[Case] = &[
        (
            "accelerating",
            &[0.0, 40.0, 60.0, 70.0],
            &[1.0, 1.0, 0.5],
            &[1000.0; 3],
            0.0,
        ),
        (
            "cruising",
            &[80.0; 6],
            &[2.0, 2.0, 1.0, 0.5, 0.5],
            &[1000.0; 5],
            0.0,
        ),
        (
            "decelerating",
            &[80.0, 60.0, 40.0, 20.0],
            &[2.0, 1.5, 1.0],
            &[1000.0; 3],
            0.0,
        ),
        ("one long", &[100.0, 100.0], &[50.0], &[1000.0], 0.0),
        (
            "tight corner",
            &[100.0, 100.0, 5.0, 100.0, 100.0],
            &[10.0, 6.0, 5.0, 0.5],
            &[1000.0; 4],
            0.0,
        ),
        (
            "corner inside the tail",
            &[60.0, 60.0, 10.0, 40.0, 40.0],
            &[3.0, 2.0, 1.0, 0.8],
            &[800.0, 800.0, 800.0, 800.0],
            0.0,
        ),
        (
            "weak axis last",
            &[50.0, 50.0, 30.0, 30.0],
            &[5.0, 1.0, 2.0],
            &[2000.0, 2000.0, 300.0],
            0.0,
        ),
        (
            "dwell then move",
            &[0.0, 0.0, 30.0, 30.0],
            &[0.0, 1.0, 1.0],
            &[0.0, 1000.0, 1000.0],
            0.0,
        ),
        (
            "ends in a dwell",
            &[20.0, 0.0, 0.0],
            &[0.5, 0.0],
            &[1000.0, 0.0],
            0.0,
        ),
        ("at rest", &[0.0, 30.0, 0.0], &[1.0, 1.0], &[1000.0; 2], 0.0),
        (
            "rest inside",
            &[30.0, 0.0, 50.0, 80.0],
            &[1.0, 2.0, 1.0],
            &[1000.0, 1000.0, 3500.0],
            0.0,
        ),
        (
            "s-curve",
            &[0.0, 50.0, 70.0, 70.0],
            &[2.0, 1.0, 1.5],
            &[1000.0; 3],
            30_000.0,
        ),
        (
            "s-curve cruise",
            &[90.0; 5],
            &[3.0, 3.0, 2.0, 1.0],
            &[1500.0; 4],
            60_000.0,
        ),
    ];
    for (name, speeds, lengths, accels, jerk) in cases {
        let w = window(speeds, lengths, accels, *jerk);
        let c = check(&w, name);
        // The cases meant to have a tail have one.
        let ends_moving = *speeds.last().unwrap() > 0.0;
        assert_eq!(c.has_tail(), ends_moving, "{name}");
    }
}

#[test]
fn tail_start_moves_back_for_a_short_last_segment() {
    // Cruising at 100 with 1000 mm/s²: 5 mm to stop, so the tail takes in
    // segments back to the first boundary with 5 mm ahead of it.
    let w = window(&[100.0; 7], &[2.0; 6], &[1000.0; 6], 0.0);
    let c = check(&w, "short");
    assert_eq!(c.start, 3, "6 mm from boundary 3, 4 mm from boundary 4");
    assert!((c.decel - 100.0 * 100.0 / 12.0).abs() < 1e-9);
}

#[test]
fn no_room_and_empty_are_errors() {
    let w = window(&[100.0, 100.0], &[1.0], &[1000.0], 0.0);
    assert_eq!(Contingency::of(w.iter()), Err(TailError::NoRoom));
    assert_eq!(Contingency::of([].iter()), Err(TailError::Empty));
}

#[test]
fn suffix_gives_the_same_tail() {
    // A node that has retired the window's head finds the same tail.
    let w = window(
        &[0.0, 50.0, 80.0, 80.0, 80.0, 80.0],
        &[3.0, 2.0, 1.0, 1.0, 1.0],
        &[1000.0; 5],
        0.0,
    );
    let whole = Contingency::of(w.iter()).unwrap();
    let part = Contingency::of(w[1..].iter()).unwrap();
    assert_eq!(whole.start - 1, part.start);
    assert_eq!(
        (whole.start_time, whole.decel, whole.distance),
        (part.start_time, part.decel, part.distance)
    );
}

proptest::proptest! {
    #[test]
    fn random_windows(
        raw in proptest::collection::vec((0.05f64..20.0, 0.0f64..1.0, 200.0f64..5000.0, 0u8..8), 1..12),
        v_first in 0.0f64..1.0,
        scurve in proptest::bool::ANY,
    ) {
        // Boundary speeds drawn within what each segment can reach, so the
        // window is plannable; some boundaries are forced to rest.
        let mut speeds = heapless::Vec::<f64, N>::new();
        let mut lengths = heapless::Vec::<f64, N>::new();
        let mut accels = heapless::Vec::<f64, N>::new();
        let v_max = 150.0;
        speeds.push(v_first * v_max).unwrap();
        for &(l, frac, a, kind) in &raw {
            let v0 = *speeds.last().unwrap();
            let (l, a) = if kind == 0 && v0 == 0.0 { (0.0, 0.0) } else { (l, a) };
            let lo = (v0 * v0 - 2.0 * a * l).max(0.0).sqrt();
            let hi = (v0 * v0 + 2.0 * a * l).sqrt().min(v_max);
            let v1 = if l == 0.0 || (kind == 1 && lo == 0.0) {
                0.0
            } else {
                lo + frac * (hi - lo).max(0.0)
            };
            speeds.push(v1).unwrap();
            lengths.push(l).unwrap();
            accels.push(a).unwrap();
        }
        let w = window(&speeds, &lengths, &accels, if scurve { 40_000.0 } else { 0.0 });
        match Contingency::of(w.iter()) {
            Ok(_) => { check(&w, "random"); }
            Err(TailError::NoRoom) => {
                // Only a window entered at speed may have no room.
                proptest::prop_assert!(w[0].profile.v0() > 0.0);
                let all: f64 = w.iter().map(|s| s.profile.length()).sum();
                let min_a = w.iter().map(|s| s.profile.params().accel).fold(f64::INFINITY, f64::min);
                let v = w[0].profile.v0();
                proptest::prop_assert!(v * v / (2.0 * all) > min_a);
            }
            Err(e) => panic!("{e}"),
        }
    }
}
