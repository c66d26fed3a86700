//! Data-driven tests of the photograph job source.

use std::io::Cursor;
use std::time::Instant;

use image::{DynamicImage, GrayImage, ImageFormat, Luma, Rgba, RgbaImage};
use motet_image::{parse, parse_with_info, ImageInfo, ImageOptions};
use motet_planner::{
    AxisInfo, Command, JobTarget, Located, MoveKind, SourceError, ToolInfo, ToolKind,
};
use proptest::prelude::*;

// ---------------------------------------------------------------- helpers

const PEN_ON: f32 = 0.75;
const FEED: f64 = 42.0;

fn target_with(axes: &[(&str, [f64; 2])], start: [f64; 6]) -> JobTarget {
    JobTarget {
        axes: axes
            .iter()
            .map(|&(name, travel)| AxisInfo {
                name: name.into(),
                travel,
                path: true,
            })
            .collect(),
        tools: vec![ToolInfo {
            name: "pen".into(),
            kind: ToolKind::Pen,
            on_value: PEN_ON,
        }],
        start,
        tolerance: 0.01,
        draw_feed: FEED,
    }
}

/// x/y travel `w` × `h` mm from 0, start at the origin.
fn target(w: f64, h: f64) -> JobTarget {
    target_with(&[("x", [0.0, w]), ("y", [0.0, h])], [0.0; 6])
}

fn encode(img: DynamicImage, format: ImageFormat) -> Vec<u8> {
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

fn png(img: GrayImage) -> Vec<u8> {
    encode(DynamicImage::ImageLuma8(img), ImageFormat::Png)
}

fn jpeg(img: GrayImage) -> Vec<u8> {
    encode(DynamicImage::ImageLuma8(img), ImageFormat::Jpeg)
}

/// White `w` × `h` image with black pixels where `ink(x, y)`.
fn drawn(w: u32, h: u32, ink: impl Fn(f64, f64) -> bool) -> GrayImage {
    GrayImage::from_fn(w, h, |x, y| {
        if ink(x as f64 + 0.5, y as f64 + 0.5) {
            Luma([0])
        } else {
            Luma([255])
        }
    })
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> impl Fn(f64, f64) -> bool {
    move |x, y| x >= x0 && x < x1 && y >= y0 && y < y1
}

fn opts(max_px: u32) -> ImageOptions {
    ImageOptions {
        max_px,
        ..ImageOptions::default()
    }
}

/// Checks the invariants every output must satisfy and returns the strokes
/// (pen-down polylines, each starting where the pen went down).
fn check(cmds: &[Located<Command>], target: &JobTarget) -> Vec<Vec<[f64; 2]>> {
    let xi = target.axis("x").unwrap();
    let yi = target.axis("y").unwrap();
    let mut pos = target.start;
    let mut down: Option<bool> = None;
    let mut strokes: Vec<Vec<[f64; 2]>> = Vec::new();
    for (k, c) in cmds.iter().enumerate() {
        assert_eq!(c.loc.line, 0, "images are located at line 0");
        match c.item {
            Command::Tool { tool, value } => {
                assert_eq!(tool, 0);
                let d = if value == PEN_ON {
                    true
                } else {
                    assert_eq!(value, 0.0, "pen values are on_value or 0");
                    false
                };
                assert_ne!(down, Some(d), "command {k}: repeated pen state");
                down = Some(d);
                if d {
                    strokes.push(vec![[pos[xi], pos[yi]]]);
                }
            }
            Command::Move(m) => {
                for (i, axis) in target.axes.iter().enumerate() {
                    let v = m.target[i];
                    assert!(
                        v >= axis.travel[0] && v <= axis.travel[1],
                        "command {k}: {} = {v} outside {:?}",
                        axis.name,
                        axis.travel
                    );
                }
                let len = (m.target[xi] - pos[xi]).hypot(m.target[yi] - pos[yi]);
                assert!(len > 1e-9, "command {k}: zero-length move");
                match m.kind {
                    MoveKind::Rapid => assert_ne!(down, Some(true), "rapid with the pen down"),
                    MoveKind::Feed => {
                        assert_eq!(down, Some(true), "feed with the pen up");
                        assert_eq!(m.feed, FEED);
                        strokes
                            .last_mut()
                            .unwrap()
                            .push([m.target[xi], m.target[yi]]);
                    }
                }
                pos = m.target;
            }
            other => panic!("unexpected command {other:?}"),
        }
    }
    if !cmds.is_empty() {
        assert_eq!(down, Some(false), "the pen is lifted at the end");
    }
    for s in &strokes {
        assert!(s.len() >= 2, "a pen-down without drawing");
    }
    strokes
}

fn points(strokes: &[Vec<[f64; 2]>]) -> impl Iterator<Item = [f64; 2]> + '_ {
    strokes.iter().flatten().copied()
}

/// Distance from `p` to the nearest drawn segment.
fn dist_to_drawing(p: [f64; 2], strokes: &[Vec<[f64; 2]>]) -> f64 {
    let mut best = f64::INFINITY;
    for s in strokes {
        for w in s.windows(2) {
            let (a, b) = (w[0], w[1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let l2 = dx * dx + dy * dy;
            let t = if l2 > 0.0 {
                (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            best = best.min((p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy));
        }
    }
    best
}

fn run(data: &[u8], target: &JobTarget, o: &ImageOptions) -> (Vec<Vec<[f64; 2]>>, ImageInfo) {
    let (cmds, info) = parse_with_info(data, target, o).unwrap();
    let strokes = check(&cmds, target);
    (strokes, info)
}

fn portrait() -> Vec<u8> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/photos/portrait.jpg"
    );
    std::fs::read(path).unwrap()
}

// ------------------------------------------------------------------ shapes

/// A filled rectangle gives its outline. The image is 200 × 150 px drawn
/// at 1 mm per pixel (travel 220 × 170, 10 mm margins), so pixel (x, y)
/// lands at machine (10 + x, 160 - y).
#[test]
fn rectangle_outline() {
    let img = drawn(200, 150, rect(50.0, 40.0, 150.0, 110.0));
    for (name, data) in [("png", png(img.clone())), ("jpeg", jpeg(img))] {
        let t = target(220.0, 170.0);
        let (strokes, info) = run(&data, &t, &opts(200));
        assert_eq!((info.width_px, info.height_px), (200, 150));
        let (x0, x1, y0, y1) = (60.0, 160.0, 50.0, 120.0);
        let to_outline = |p: [f64; 2]| {
            let inside_x = p[0].clamp(x0, x1);
            let inside_y = p[1].clamp(y0, y1);
            if p[0] > x0 && p[0] < x1 && p[1] > y0 && p[1] < y1 {
                (p[0] - x0).min(x1 - p[0]).min(p[1] - y0).min(y1 - p[1])
            } else {
                (p[0] - inside_x).hypot(p[1] - inside_y)
            }
        };
        for p in points(&strokes) {
            assert!(to_outline(p) <= 2.0, "{name}: {p:?} is off the outline");
        }
        // Every side is covered (away from the blurred corners).
        let mut samples = Vec::new();
        for i in 0..=90 {
            let f = 65.0 + i as f64;
            samples.push([f, y0]);
            samples.push([f, y1]);
        }
        for i in 0..=60 {
            let f = 55.0 + i as f64;
            samples.push([x0, f]);
            samples.push([x1, f]);
        }
        for s in samples {
            let d = dist_to_drawing(s, &strokes);
            assert!(
                d <= 2.0,
                "{name}: outline point {s:?} is {d} mm from the drawing"
            );
        }
        let perimeter = 2.0 * (100.0 + 70.0);
        assert!(
            (info.drawn_mm - perimeter).abs() < 0.15 * perimeter,
            "{name}: drew {} mm",
            info.drawn_mm
        );
        // One closed-ish outline: few strokes, ending near where it started.
        assert!(info.polylines <= 4, "{name}: {info:?}");
        let (first, last) = (strokes[0][0], *strokes.last().unwrap().last().unwrap());
        assert!((first[0] - last[0]).hypot(first[1] - last[1]) < 3.0);
    }
}

/// A disk gives points on its circle: radius 90 px at 1 mm per pixel,
/// centred at machine (160, 160).
#[test]
fn circle_outline() {
    let img = drawn(300, 300, |x, y| (x - 150.0).hypot(y - 150.0) < 90.0);
    let t = target(320.0, 320.0);
    let (strokes, info) = run(&png(img), &t, &opts(300));
    let r = |p: [f64; 2]| (p[0] - 160.0).hypot(p[1] - 160.0);
    for p in points(&strokes) {
        assert!((r(p) - 90.0).abs() <= 2.0, "{p:?} at radius {}", r(p));
    }
    for deg in (0..360).step_by(5) {
        let a = (deg as f64).to_radians();
        let s = [160.0 + 90.0 * a.cos(), 160.0 + 90.0 * a.sin()];
        assert!(dist_to_drawing(s, &strokes) <= 2.0, "gap at {deg}°");
    }
    let circ = 2.0 * std::f64::consts::PI * 90.0;
    assert!((info.drawn_mm - circ).abs() < 0.1 * circ, "{info:?}");
    // Simplification keeps far fewer points than the ~570 edge pixels.
    assert!(info.points < 300, "{info:?}");
}

#[test]
fn blank_images_draw_nothing() {
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("white png", png(GrayImage::from_pixel(64, 48, Luma([255])))),
        ("black png", png(GrayImage::from_pixel(64, 48, Luma([0])))),
        (
            "gray jpeg",
            jpeg(GrayImage::from_pixel(300, 200, Luma([128]))),
        ),
        ("1x1 png", png(GrayImage::from_pixel(1, 1, Luma([0])))),
        (
            "1-pixel-high png",
            png(GrayImage::from_pixel(500, 1, Luma([0]))),
        ),
        (
            "transparent png",
            encode(
                DynamicImage::ImageRgba8(RgbaImage::from_pixel(40, 40, Rgba([0, 0, 0, 0]))),
                ImageFormat::Png,
            ),
        ),
    ];
    for (name, data) in cases {
        let (cmds, info) = parse_with_info(&data, &target(200.0, 200.0), &opts(400))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(cmds.is_empty(), "{name}: {cmds:?}");
        assert_eq!((info.polylines, info.points), (0, 0), "{name}");
        assert_eq!((info.drawn_mm, info.travel_mm), (0.0, 0.0), "{name}");
    }
}

/// Transparent pixels are paper: a black square on a transparent (black)
/// background still has an outline.
#[test]
fn transparency_is_white() {
    let img = RgbaImage::from_fn(100, 100, |x, y| {
        if (30..70).contains(&x) && (30..70).contains(&y) {
            Rgba([0, 0, 0, 255])
        } else {
            Rgba([0, 0, 0, 0])
        }
    });
    let data = encode(DynamicImage::ImageRgba8(img), ImageFormat::Png);
    let t = target(120.0, 120.0);
    let (strokes, info) = run(&data, &t, &opts(100));
    assert!(info.polylines >= 1);
    // Square 30..70 px at 1 mm/px from (10, 10): x 40..80, y 40..80.
    for p in points(&strokes) {
        assert!(
            p[0] > 36.0 && p[0] < 84.0 && p[1] > 36.0 && p[1] < 84.0,
            "{p:?}"
        );
    }
}

/// Two separate shapes give two groups of strokes, drawn one after the other.
#[test]
fn two_shapes_two_groups() {
    let left = rect(20.0, 60.0, 120.0, 140.0);
    let right = |x: f64, y: f64| (x - 300.0).hypot(y - 100.0) < 50.0;
    let img = drawn(400, 200, move |x, y| left(x, y) || right(x, y));
    let t = target(420.0, 220.0);
    let (strokes, _) = run(&png(img), &t, &opts(400));
    // Machine x = 10 + px: left shape at x < 140, right shape at x > 240.
    let group = |s: &Vec<[f64; 2]>| {
        if s.iter().all(|p| p[0] < 140.0) {
            0
        } else if s.iter().all(|p| p[0] > 240.0) {
            1
        } else {
            panic!("stroke spans both shapes: {s:?}")
        }
    };
    let groups: Vec<u8> = strokes.iter().map(group).collect();
    assert!(groups.contains(&0) && groups.contains(&1), "{groups:?}");
    let switches = groups.windows(2).filter(|w| w[0] != w[1]).count();
    assert_eq!(switches, 1, "each shape drawn in one go: {groups:?}");
}

// --------------------------------------------------------------- placement

/// Every move stays within travel, whatever the machine and placement.
#[test]
fn moves_within_travel() {
    let shapes: Vec<(&str, GrayImage)> = vec![
        (
            "wide",
            drawn(300, 80, |x, y| {
                (x - 150.0).abs() + (y - 40.0).abs() * 3.0 < 120.0
            }),
        ),
        ("tall", drawn(60, 240, rect(0.0, 0.0, 30.0, 240.0))),
        ("edge to edge", drawn(100, 100, |x, _| x < 50.0)),
        (
            "checkerboard",
            drawn(97, 61, |x, y| {
                ((x / 12.0) as u32 + (y / 9.0) as u32) & 1 == 0
            }),
        ),
    ];
    let targets: Vec<(&str, JobTarget, ImageOptions)> = vec![
        ("square", target(200.0, 200.0), ImageOptions::default()),
        (
            "offset, negative",
            target_with(&[("x", [-150.0, -20.0]), ("y", [40.0, 400.0])], [0.0; 6]),
            ImageOptions::default(),
        ),
        (
            "z axis, start out of travel, y first",
            target_with(
                &[("y", [0.0, 90.0]), ("x", [0.0, 300.0]), ("z", [0.0, 5.0])],
                [500.0, -20.0, 9.0, 0.0, 0.0, 0.0],
            ),
            ImageOptions::default(),
        ),
        (
            "tiny travel",
            target(12.0, 30.0),
            ImageOptions {
                max_px: 64,
                ..ImageOptions::default()
            },
        ),
        (
            "placed",
            target(300.0, 300.0),
            ImageOptions {
                width_mm: Some(50.0),
                origin: Some([240.0, 5.0]),
                ..ImageOptions::default()
            },
        ),
        (
            "unbounded travel, placed",
            target_with(
                &[
                    ("x", [f64::NEG_INFINITY, f64::INFINITY]),
                    ("y", [-1e9, f64::INFINITY]),
                ],
                [0.0; 6],
            ),
            ImageOptions {
                width_mm: Some(120.0),
                origin: Some([-60.0, 0.0]),
                ..ImageOptions::default()
            },
        ),
    ];
    for (sname, img) in &shapes {
        for (tname, t, o) in &targets {
            for data in [png(img.clone()), jpeg(img.clone())] {
                let (cmds, info) = parse_with_info(&data, t, o)
                    .unwrap_or_else(|e| panic!("{sname} on {tname}: {e}"));
                assert!(!cmds.is_empty(), "{sname} on {tname}: nothing drawn");
                let strokes = check(&cmds, t);
                assert_eq!(info.polylines > 0, !strokes.is_empty());
                if let Some(z) = t.axis("z") {
                    for c in &cmds {
                        if let Command::Move(m) = c.item {
                            assert_eq!(m.target[z], 5.0, "z clamped into travel");
                        }
                    }
                }
            }
        }
    }
}

/// The default placement centres the image and leaves 10 mm margins on the
/// limiting side.
#[test]
fn default_fit_keeps_aspect() {
    // 200 × 100 px shape touching nothing, on a 300 × 300 travel: the width
    // limits, 280 mm for 200 px = 1.4 mm/px; height 140 mm, centred.
    let img = drawn(200, 100, rect(20.0, 20.0, 180.0, 80.0));
    let (strokes, _) = run(&png(img), &target(300.0, 300.0), &opts(200));
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points(&strokes) {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    // Rectangle 20..180 × 20..80 px -> x 10 + 1.4*[20, 180] = 38..262,
    // y 80 + 1.4*(100 - [80, 20]) = 108..192.
    let want = ([38.0, 108.0], [262.0, 192.0]);
    for k in 0..2 {
        assert!((lo[k] - want.0[k]).abs() < 2.5, "{lo:?} {hi:?}");
        assert!((hi[k] - want.1[k]).abs() < 2.5, "{lo:?} {hi:?}");
    }
}

#[test]
fn options_and_machine_errors() {
    let data = png(drawn(50, 50, rect(10.0, 10.0, 40.0, 40.0)));
    let t = target(100.0, 100.0);
    let cases: Vec<(&str, JobTarget, ImageOptions, &str)> = vec![
        (
            "max_px 0",
            t.clone(),
            ImageOptions {
                max_px: 0,
                ..ImageOptions::default()
            },
            "max_px",
        ),
        (
            "low above high",
            t.clone(),
            ImageOptions {
                low_threshold: 50.0,
                high_threshold: 10.0,
                ..ImageOptions::default()
            },
            "low_threshold",
        ),
        (
            "negative threshold",
            t.clone(),
            ImageOptions {
                high_threshold: -1.0,
                ..ImageOptions::default()
            },
            "high_threshold",
        ),
        (
            "NaN blur",
            t.clone(),
            ImageOptions {
                blur_sigma: f32::NAN,
                ..ImageOptions::default()
            },
            "blur_sigma",
        ),
        (
            "negative simplify",
            t.clone(),
            ImageOptions {
                simplify_px: -0.1,
                ..ImageOptions::default()
            },
            "simplify_px",
        ),
        (
            "zero width",
            t.clone(),
            ImageOptions {
                width_mm: Some(0.0),
                ..ImageOptions::default()
            },
            "width_mm",
        ),
        (
            "too wide",
            t.clone(),
            ImageOptions {
                width_mm: Some(500.0),
                ..ImageOptions::default()
            },
            "beyond the x travel",
        ),
        (
            "off the bed",
            t.clone(),
            ImageOptions {
                origin: Some([0.0, 90.0]),
                ..ImageOptions::default()
            },
            "beyond the y travel",
        ),
        (
            "no y axis",
            target_with(&[("x", [0.0, 100.0]), ("z", [0.0, 100.0])], [0.0; 6]),
            ImageOptions::default(),
            "y axis",
        ),
        (
            "unbounded travel, no width",
            target_with(
                &[("x", [0.0, f64::INFINITY]), ("y", [0.0, 100.0])],
                [0.0; 6],
            ),
            ImageOptions::default(),
            "unbounded",
        ),
        (
            "inverted travel",
            target_with(&[("x", [100.0, 0.0]), ("y", [0.0, 100.0])], [0.0; 6]),
            ImageOptions::default(),
            "travel",
        ),
    ];
    for (name, t, o, want) in cases {
        let e = parse(&data, &t, &o).expect_err(name);
        assert_eq!((e.loc.line, e.loc.column), (0, 0), "{name}");
        assert!(e.message.contains(want), "{name}: {}", e.message);
    }
}

#[test]
fn thresholds() {
    let data = png(drawn(100, 100, rect(20.0, 20.0, 80.0, 80.0)));
    let t = target(120.0, 120.0);
    let draw = |low: f32, high: f32| {
        let o = ImageOptions {
            low_threshold: low,
            high_threshold: high,
            max_px: 100,
            ..ImageOptions::default()
        };
        parse_with_info(&data, &t, &o).unwrap().1.polylines
    };
    assert!(draw(f32::NAN, f32::NAN) >= 1);
    assert!(
        draw(0.0, 0.0) >= 1,
        "zero thresholds are raised, not a panic"
    );
    assert!(draw(10.0, f32::NAN) >= 1);
    assert!(draw(f32::NAN, 100.0) >= 1);
    assert_eq!(draw(f32::INFINITY, f32::INFINITY), 0);
    assert_eq!(draw(f32::NAN, 1e6), 0, "nothing is that steep");
}

// ---------------------------------------------------------------- portrait

#[test]
fn portrait_is_drawn() {
    let data = portrait();
    let t = target(200.0, 280.0);
    let started = Instant::now();
    let (cmds, info) = parse_with_info(&data, &t, &ImageOptions::default()).unwrap();
    let elapsed = started.elapsed();
    println!("portrait: {info:?}, {} commands, {elapsed:?}", cmds.len());
    check(&cmds, &t);
    assert_eq!((info.width_px, info.height_px), (400, 400));
    assert!(
        (100..=5000).contains(&info.polylines),
        "{} polylines",
        info.polylines
    );
    assert!(info.points > info.polylines);
    assert!(info.drawn_mm > info.travel_mm, "{info:?}");
    // Deterministic.
    assert_eq!(parse(&data, &t, &ImageOptions::default()).unwrap(), cmds);
}

// ----------------------------------------------------------- broken input

fn assert_decode_error(r: Result<Vec<Located<Command>>, SourceError>, what: &str) {
    let e = r.expect_err(what);
    assert_eq!((e.loc.line, e.loc.column), (0, 0), "{what}");
    assert!(
        e.message.starts_with("cannot decode image: "),
        "{what}: {}",
        e.message
    );
}

#[test]
fn broken_inputs() {
    let photo = portrait();
    let shape = png(drawn(64, 64, rect(10.0, 10.0, 50.0, 50.0)));
    let mut corrupt_png = shape.clone();
    for b in corrupt_png.iter_mut().skip(60).step_by(7) {
        *b ^= 0x5A;
    }
    let mut bad_crc = shape.clone();
    let n = bad_crc.len();
    bad_crc[n - 20] ^= 1;
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty", vec![]),
        ("truncated jpeg", photo[..photo.len() / 2].to_vec()),
        ("jpeg header only", photo[..200].to_vec()),
        ("jpeg without end marker", photo[..photo.len() - 2].to_vec()),
        ("truncated png", shape[..shape.len() / 2].to_vec()),
        ("png signature only", shape[..8].to_vec()),
        ("corrupt png", corrupt_png),
        ("png with a bad checksum", bad_crc),
        ("text", b"G1 X10 Y10\nG1 X20 Y0\n".to_vec()),
        ("svg", b"<svg xmlns='http://www.w3.org/2000/svg'/>".to_vec()),
        ("gif", b"GIF89a\x01\x00\x01\x00\x00\x00\x00;".to_vec()),
        (
            "bmp",
            b"BM\x1e\x00\x00\x00\x00\x00\x00\x00\x1a\x00\x00\x00".to_vec(),
        ),
        (
            "random",
            (0..4096u32)
                .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
                .collect(),
        ),
    ];
    let t = target(200.0, 200.0);
    for (name, data) in cases {
        assert_decode_error(parse(&data, &t, &ImageOptions::default()), name);
    }
}

fn small_png() -> Vec<u8> {
    png(drawn(24, 16, rect(4.0, 4.0, 20.0, 12.0)))
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_bytes_are_errors(data in proptest::collection::vec(any::<u8>(), 0..2048)) {
        assert_decode_error(parse(&data, &target(100.0, 100.0), &opts(64)), "random bytes");
    }

    /// Random bytes behind a real signature reach the decoders themselves.
    #[test]
    fn random_bodies_are_errors(
        jpeg in any::<bool>(),
        body in proptest::collection::vec(any::<u8>(), 0..2048),
    ) {
        let mut data = if jpeg {
            vec![0xFF, 0xD8, 0xFF, 0xE0]
        } else {
            b"\x89PNG\r\n\x1a\n".to_vec()
        };
        data.extend(body);
        assert_decode_error(parse(&data, &target(100.0, 100.0), &opts(64)), "random body");
    }

    #[test]
    fn png_truncations_are_errors(cut in 0usize..10_000) {
        let data = small_png();
        let cut = cut % data.len();
        assert_decode_error(
            parse(&data[..cut], &target(100.0, 100.0), &opts(64)),
            "truncated png",
        );
    }

    #[test]
    fn png_corruptions_never_panic(at in 0usize..10_000, xor in 1u8..=255) {
        let mut data = small_png();
        let at = at % data.len();
        data[at] ^= xor;
        // Some flips (in ancillary data) still decode; none may panic, and an
        // image that decodes draws within travel.
        let t = target(100.0, 100.0);
        match parse(&data, &t, &opts(64)) {
            Ok(cmds) => { check(&cmds, &t); }
            Err(e) => prop_assert!(e.message.starts_with("cannot decode image: "), "{}", e.message),
        }
    }
}

#[test]
fn jpeg_truncations_are_errors() {
    let data = jpeg(drawn(64, 48, rect(10.0, 10.0, 50.0, 40.0)));
    let t = target(100.0, 100.0);
    for cut in 0..data.len() {
        assert_decode_error(parse(&data[..cut], &t, &opts(64)), "truncated jpeg");
    }
    check(&parse(&data, &t, &opts(64)).unwrap(), &t);
}
