//! Placing drawings: the moves of a placed SVG land where the rule says
//! (rotate about the centre, scale or fit, move), a tiny icon fits at a
//! useful size with curves still within the chord tolerance, a few
//! micrometres over the edge is put on it, and every bad value is refused
//! naming its field and flag.

use motet_api::job::{JobError, JobKind};
use motet_api::{JobOptions, JobReader, Placed, Placement};
use motet_host::Machine;
use motet_planner::Command;
use std::path::Path;

/// The example plotter: x travel 0..300, y 0..218 mm.
fn plotter() -> Machine {
    Machine::load(Path::new(&format!(
        "{}/../../examples/plotter.toml",
        env!("CARGO_MANIFEST_DIR")
    )))
    .unwrap()
}

/// A 40 × 20 mm page with a 20 × 10 mm rectangle (machine x 10..30, y 5..15
/// as read) and a tick along its bottom edge from its lower-left corner
/// (machine (10, 5) to (14, 5)), which tells a turn's direction.
const RECT: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="20mm" viewBox="0 0 40 20">
<rect x="10" y="5" width="20" height="10" stroke="black" fill="none"/>
<line x1="10" y1="15" x2="14" y2="15" stroke="red"/>
</svg>"#;

/// Every move's x, y and what placing said, or the error's text.
fn place(
    kind: JobKind,
    data: &[u8],
    placement: Placement,
) -> Result<(Vec<[f64; 2]>, Option<Placed>), String> {
    let m = plotter();
    let opts = JobOptions {
        placement,
        ..JobOptions::default()
    };
    let name = match kind {
        JobKind::Gcode => "job.gcode",
        JobKind::Svg => "job.svg",
        JobKind::Image => "job.png",
    };
    let mut reader =
        JobReader::from_bytes(&m, Path::new(name), kind, data, &opts).map_err(|e| e.to_string())?;
    let commands: Vec<_> = reader
        .by_ref()
        .collect::<Result<_, JobError>>()
        .map_err(|e| e.to_string())?;
    let points = commands
        .iter()
        .filter_map(|c| match c.item {
            Command::Move(mv) => Some([mv.target[0], mv.target[1]]),
            _ => None,
        })
        .collect();
    Ok((points, reader.placed()))
}

fn bounds(points: &[[f64; 2]]) -> [[f64; 2]; 2] {
    let mut b = [[f64::INFINITY; 2], [f64::NEG_INFINITY; 2]];
    for p in points {
        for k in 0..2 {
            b[0][k] = b[0][k].min(p[k]);
            b[1][k] = b[1][k].max(p[k]);
        }
    }
    b
}

fn near(a: [f64; 2], b: [f64; 2], tol: f64) -> bool {
    (a[0] - b[0]).abs() <= tol && (a[1] - b[1]).abs() <= tol
}

fn placement(
    fit: Option<f64>,
    scale: Option<f64>,
    rotate: f64,
    origin: Option<[f64; 2]>,
) -> Placement {
    Placement {
        fit_margin_mm: fit,
        scale,
        rotate_deg: rotate,
        origin,
    }
}

#[test]
fn placed_drawings_land_where_the_rule_says() {
    let s45 = 30.0 / 2f64.sqrt();
    // (name, placement, bounding box of the moves, points among them)
    #[allow(clippy::type_complexity)]
    let cases: &[(&str, Placement, [[f64; 2]; 2], &[[f64; 2]])] = &[
        (
            "as read",
            Placement::default(),
            [[10.0, 5.0], [30.0, 15.0]],
            &[[10.0, 5.0], [14.0, 5.0]],
        ),
        // 280 × 198 of room: the width limits, ×14, centred.
        (
            "fit 10",
            Placement::fit(10.0),
            [[10.0, 39.0], [290.0, 179.0]],
            &[[10.0, 39.0], [66.0, 39.0]],
        ),
        (
            "fit 0",
            Placement::fit(0.0),
            [[0.0, 34.0], [300.0, 184.0]],
            &[],
        ),
        (
            "scale from the corner",
            placement(None, Some(2.0), 0.0, None),
            [[10.0, 5.0], [50.0, 25.0]],
            &[[18.0, 5.0]],
        ),
        (
            "origin",
            placement(None, None, 0.0, Some([5.0, 6.0])),
            [[5.0, 6.0], [25.0, 16.0]],
            &[[9.0, 6.0]],
        ),
        (
            "scale and origin",
            placement(None, Some(2.0), 0.0, Some([100.0, 50.0])),
            [[100.0, 50.0], [140.0, 70.0]],
            &[[108.0, 50.0]],
        ),
        // A quarter turn counter-clockwise about (20, 10), lower-left corner
        // kept: the tick now runs up the right edge.
        (
            "rotate 90",
            placement(None, None, 90.0, None),
            [[10.0, 5.0], [20.0, 25.0]],
            &[[20.0, 5.0], [20.0, 9.0]],
        ),
        (
            "rotate -270",
            placement(None, None, -270.0, None),
            [[10.0, 5.0], [20.0, 25.0]],
            &[[20.0, 5.0], [20.0, 9.0]],
        ),
        (
            "rotate -90",
            placement(None, None, -90.0, None),
            [[10.0, 5.0], [20.0, 25.0]],
            &[[10.0, 25.0], [10.0, 21.0]],
        ),
        // Turned, then fitted: 10 × 20 into 280 × 198, the height limits.
        (
            "rotate 90 then fit",
            placement(Some(10.0), None, 90.0, None),
            [[100.5, 10.0], [199.5, 208.0]],
            &[[199.5, 10.0]],
        ),
        (
            "rotate 45 to the origin",
            placement(None, None, 45.0, Some([0.0, 0.0])),
            [[0.0, 0.0], [s45, s45]],
            &[],
        ),
        (
            "rotate 90, scale 3, origin",
            placement(None, Some(3.0), 90.0, Some([200.0, 100.0])),
            [[200.0, 100.0], [230.0, 160.0]],
            &[[230.0, 100.0], [230.0, 112.0]],
        ),
    ];
    for (name, p, want, pts) in cases {
        let (got, placed) =
            place(JobKind::Svg, RECT.as_bytes(), *p).unwrap_or_else(|e| panic!("{name}: {e}"));
        let b = bounds(&got);
        assert!(
            near(b[0], want[0], 1e-4) && near(b[1], want[1], 1e-4),
            "{name}: moves span {b:?}, want {want:?}"
        );
        for q in *pts {
            assert!(
                got.iter().any(|g| near(*g, *q, 1e-4)),
                "{name}: no move to {q:?} in {got:?}"
            );
        }
        match placed {
            None => assert!(p.is_identity(), "{name}: placed nothing"),
            Some(pl) => {
                assert!(
                    near(pl.min, want[0], 1e-4) && near(pl.max, want[1], 1e-4),
                    "{name}: {pl:?}"
                );
                assert_eq!(pl.clamps.moves, 0, "{name}");
            }
        }
    }
}

/// A 16-pixel icon (a circle 12 px across, 3.2 mm) fitted with the default
/// margin is drawn 198 mm across, its curve flattened to the machine's
/// 0.01 mm at that size, not 62 times coarser.
#[test]
fn a_16_pixel_icon_is_drawn_at_a_useful_size() {
    let icon = r#"<svg xmlns="http://www.w3.org/2000/svg" width="16" height="16" viewBox="0 0 16 16">
<circle cx="8" cy="8" r="6" stroke="black" fill="none"/></svg>"#;
    let (pts, placed) = place(JobKind::Svg, icon.as_bytes(), Placement::fit(10.0)).unwrap();
    let b = bounds(&pts);
    // The height limits the fit, and the chords reach it exactly; across,
    // the chords may stop short of the circle by their sag.
    assert!(near([b[0][1], b[1][1]], [10.0, 208.0], 1e-6), "{b:?}");
    assert!(near([b[0][0], b[1][0]], [51.0, 249.0], 0.011), "{b:?}");
    let placed = placed.unwrap();
    // The chords across the top and bottom fall short of the circle by
    // their sag, so the scale is a little above the circle's.
    let want = 198.0 / (12.0 * 25.4 / 96.0);
    assert!(
        placed.scale >= want && placed.scale <= want * (1.0 + 0.021 / 198.0),
        "{placed:?}"
    );
    let (c, r) = ([150.0, 109.0], 99.0);
    let mut worst_sag: f64 = 0.0;
    for w in pts.windows(2) {
        for p in w {
            assert!(
                ((p[0] - c[0]).hypot(p[1] - c[1]) - r).abs() < 0.011,
                "{p:?} off the circle"
            );
        }
        let half = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / 2.0;
        worst_sag = worst_sag.max(r - (r * r - half * half).max(0.0).sqrt());
    }
    assert!(
        worst_sag > 0.001 && worst_sag <= 0.0101,
        "chord sag {worst_sag} mm"
    );
}

/// Strokes that reach a few micrometres past the page, or a drawing a few
/// micrometres wider than the travel, still go on: the overshoot is put on
/// the travel's edge and counted. A millimetre is refused.
#[test]
fn a_few_micrometres_over_the_edge_is_put_on_it() {
    let svg = |x0: f64, x1: f64| {
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="300mm" height="100mm" viewBox="0 0 300 100">
<path d="M {x0} 50 L {x1} 50 L {x1} 20" stroke="black" fill="none"/></svg>"#
        )
    };
    // (name, x0, x1, placement, clamped moves, farthest clamp at least)
    let cases = [
        (
            "fit without margin",
            -0.004,
            300.003,
            Placement::fit(0.0),
            None,
        ),
        (
            "3 µm over at the origin",
            0.0,
            300.003,
            placement(None, None, 0.0, Some([0.0, 10.0])),
            Some(0.0029),
        ),
        (
            "8 µm over after scaling",
            0.0,
            150.004,
            placement(None, Some(2.0), 0.0, Some([0.0, 10.0])),
            Some(0.0079),
        ),
    ];
    for (name, x0, x1, p, clamped) in cases {
        let (pts, placed) = place(JobKind::Svg, svg(x0, x1).as_bytes(), p)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let b = bounds(&pts);
        assert!(b[0][0] >= 0.0 && b[1][0] <= 300.0, "{name}: {b:?}");
        assert!(
            near([b[0][0], b[1][0]], [0.0, 300.0], 1e-9),
            "{name}: {b:?}"
        );
        let placed = placed.unwrap();
        match clamped {
            Some(min) => {
                assert!(placed.clamps.moves >= 1, "{name}: {placed:?}");
                assert!(
                    placed.clamps.max_mm >= min && placed.clamps.max_mm <= 0.01,
                    "{name}: {placed:?}"
                );
            }
            None => assert!(placed.clamps.max_mm <= 1e-9, "{name}: {placed:?}"),
        }
    }
    let e = place(
        JobKind::Svg,
        svg(0.0, 301.0).as_bytes(),
        placement(None, None, 0.0, Some([0.0, 10.0])),
    )
    .unwrap_err();
    assert!(
        e.contains("spans x 0.000..301.000 mm, beyond the x travel 0..300 mm"),
        "{e}"
    );
}

#[test]
fn bad_placements_are_refused_naming_the_flag() {
    let nan = f64::NAN;
    let inf = f64::INFINITY;
    let cases: &[(&str, JobKind, Placement, &[&str])] = &[
        (
            "zero scale",
            JobKind::Svg,
            placement(None, Some(0.0), 0.0, None),
            &["scale (`--scale`) must be a finite number > 0, not 0"],
        ),
        (
            "negative scale",
            JobKind::Svg,
            placement(None, Some(-2.0), 0.0, None),
            &["`--scale`", "not -2"],
        ),
        (
            "NaN scale",
            JobKind::Svg,
            placement(None, Some(nan), 0.0, None),
            &["`--scale`", "not NaN"],
        ),
        (
            "infinite scale",
            JobKind::Svg,
            placement(None, Some(inf), 0.0, None),
            &["`--scale`", "not inf"],
        ),
        (
            "negative margin",
            JobKind::Svg,
            Placement::fit(-1.0),
            &["fit_margin_mm (`--fit`)", "not -1"],
        ),
        (
            "NaN margin",
            JobKind::Svg,
            Placement::fit(nan),
            &["`--fit`", "not NaN"],
        ),
        (
            "NaN rotation",
            JobKind::Svg,
            placement(None, None, nan, None),
            &["rotate_deg (`--rotate`)", "not NaN"],
        ),
        (
            "infinite rotation",
            JobKind::Svg,
            placement(None, None, -inf, None),
            &["`--rotate`", "not -inf"],
        ),
        (
            "NaN origin",
            JobKind::Svg,
            placement(None, None, 0.0, Some([1.0, nan])),
            &["origin (`--origin`)", "not NaN"],
        ),
        (
            "fit and scale",
            JobKind::Svg,
            placement(Some(10.0), Some(2.0), 0.0, None),
            &["`--fit`", "`--scale`", "cannot be combined"],
        ),
        (
            "fit and origin",
            JobKind::Svg,
            placement(Some(10.0), None, 0.0, Some([0.0, 0.0])),
            &["`--fit`", "`--origin`", "cannot be combined"],
        ),
        (
            "margin of half the travel",
            JobKind::Svg,
            Placement::fit(109.0),
            &["`--fit`) 109 mm leaves nothing of the 300 × 218 mm"],
        ),
        (
            "huge margin",
            JobKind::Svg,
            Placement::fit(1e300),
            &["`--fit`) 1e300 mm leaves nothing"],
        ),
        (
            "too large",
            JobKind::Svg,
            placement(None, Some(100.0), 0.0, None),
            &[
                "spans x 10.000..2010.000 mm, beyond the x travel 0..300 mm",
                "--scale",
            ],
        ),
        (
            "overflowing scale",
            JobKind::Svg,
            placement(None, Some(1e308), 0.0, None),
            &["beyond the x travel"],
        ),
        (
            "far origin",
            JobKind::Svg,
            placement(None, None, 0.0, Some([1e300, 0.0])),
            &["beyond the x travel"],
        ),
        (
            "below the travel",
            JobKind::Svg,
            placement(None, None, 0.0, Some([0.0, -1.0])),
            &["spans y -1.000..9.000 mm, beyond the y travel 0..218 mm"],
        ),
        (
            "G-code",
            JobKind::Gcode,
            placement(None, Some(2.0), 0.0, None),
            &["job.gcode: placement", "SVG and photo jobs"],
        ),
        (
            "G-code, rotated",
            JobKind::Gcode,
            placement(None, None, 90.0, None),
            &["not placed"],
        ),
    ];
    for (name, kind, p, want) in cases {
        let data: &[u8] = match kind {
            JobKind::Gcode => b"G1 X10 Y10 F600\n",
            _ => RECT.as_bytes(),
        };
        let e = place(*kind, data, *p).expect_err(name);
        for w in *want {
            assert!(e.contains(w), "{name}: `{e}` lacks `{w}`");
        }
    }
}

/// A placement given to a G-code job or to nothing at all changes nothing
/// when it is the default, and a drawing without strokes is placed nowhere.
#[test]
fn the_default_places_nothing() {
    let (pts, placed) = place(JobKind::Gcode, b"G1 X10 Y10 F600\n", Placement::default()).unwrap();
    assert_eq!((pts, placed), (vec![[10.0, 10.0]], None));
    let empty = r#"<svg xmlns="http://www.w3.org/2000/svg" width="10mm" height="10mm"/>"#;
    let (pts, placed) = place(JobKind::Svg, empty.as_bytes(), Placement::fit(10.0)).unwrap();
    assert_eq!((pts.len(), placed), (0, None));
}

#[test]
fn origins_are_read_or_refused() {
    let cases: &[(&str, Result<[f64; 2], &str>)] = &[
        ("10,20", Ok([10.0, 20.0])),
        (" -1.5 , 2e1 ", Ok([-1.5, 20.0])),
        ("0,-0", Ok([0.0, -0.0])),
        ("10", Err("exactly one comma")),
        ("", Err("exactly one comma")),
        ("1,2,3", Err("exactly one comma")),
        ("a,1", Err("X `a` is not a number")),
        ("1,", Err("Y `` is not a number")),
        ("1,inf", Err("Y must be finite")),
        ("NaN,1", Err("X must be finite")),
        ("1;2", Err("exactly one comma")),
    ];
    for (text, want) in cases {
        let got = Placement::parse_origin(text).map_err(|e| e.to_string());
        match (want, got) {
            (Ok(w), Ok(g)) => assert_eq!(*w, g, "{text:?}"),
            (Err(w), Err(g)) => {
                assert!(g.contains(w) && g.contains("`--origin`"), "{text:?}: {g}")
            }
            (w, g) => panic!("{text:?}: want {w:?}, got {g:?}"),
        }
    }
}

/// Placement arrives as JSON from programs (a server's request): every
/// field optional, unknown ones refused.
#[test]
fn placement_reads_from_json() {
    let p: Placement = serde_json::from_str(r#"{"fit_margin_mm": 5, "rotate_deg": 90}"#).unwrap();
    assert_eq!(p, placement(Some(5.0), None, 90.0, None));
    let p: Placement = serde_json::from_str("{}").unwrap();
    assert!(p.is_identity());
    let e = serde_json::from_str::<Placement>(r#"{"scal": 2}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field `scal`"), "{e}");
}

mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

        /// Finite numbers, however written, come back exactly.
        #[test]
        fn origins_round_trip(x in -1e9f64..1e9, y in -1e9f64..1e9, exp in any::<bool>(), pad in "[ \t]{0,2}") {
            let text = if exp { format!("{pad}{x:e}{pad},{pad}{y:e}{pad}") } else { format!("{x},{pad}{y}") };
            prop_assert_eq!(Placement::parse_origin(&text), Ok([x, y]));
        }

        /// Any text is read or refused, never a panic; text without exactly
        /// one comma is always refused.
        #[test]
        fn any_text_is_read_or_refused(text in "\\PC{0,24}") {
            let got = Placement::parse_origin(&text);
            if text.matches(',').count() != 1 {
                prop_assert!(got.is_err());
            }
            if let Ok(o) = got {
                prop_assert!(o.iter().all(|v| v.is_finite()));
            }
        }

        /// Fitting any rotation of the rectangle with any margin that
        /// leaves room keeps the drawing inside the travel less the margin
        /// and touches it on at least one axis, centred.
        #[test]
        fn fits_stay_inside_and_centred(rot in -720.0f64..720.0, margin in 0.0f64..100.0) {
            let (pts, _) = place(JobKind::Svg, RECT.as_bytes(), placement(Some(margin), None, rot, None)).unwrap();
            let [lo, hi] = bounds(&pts);
            let tol = 1e-9;
            prop_assert!(lo[0] >= margin - tol && hi[0] <= 300.0 - margin + tol, "{:?}", (lo, hi));
            prop_assert!(lo[1] >= margin - tol && hi[1] <= 218.0 - margin + tol, "{:?}", (lo, hi));
            let touches = (hi[0] - lo[0] - (300.0 - 2.0 * margin)).abs() < 1e-6
                || (hi[1] - lo[1] - (218.0 - 2.0 * margin)).abs() < 1e-6;
            prop_assert!(touches, "{:?}", (lo, hi));
            prop_assert!(near([(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0], [150.0, 109.0], 1e-6));
        }
    }
}

/// A photo is placed by the same rule: turned a quarter and fitted without
/// margin, the portrait fills the travel's height, centred across.
#[test]
fn a_photo_is_placed_like_a_drawing() {
    let photo = std::fs::read(format!(
        "{}/../../examples/photos/portrait.jpg",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let (pts, placed) = place(
        JobKind::Image,
        &photo,
        placement(Some(0.0), None, 90.0, None),
    )
    .unwrap();
    let [lo, hi] = bounds(&pts);
    assert!(near([lo[1], hi[1]], [0.0, 218.0], 1e-9), "{lo:?} {hi:?}");
    assert!(
        (lo[0] + hi[0] - 300.0).abs() < 1e-9 && hi[0] - lo[0] < 300.0,
        "{lo:?} {hi:?}"
    );
    assert_eq!(placed.unwrap().rotate_deg, 90.0);
}
