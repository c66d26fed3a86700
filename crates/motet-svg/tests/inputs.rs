//! Bad and odd input: located errors, never a panic, options checked.

use crate::common;

use common::*;
use motet_planner::Command;
use motet_svg::*;
use proptest::prelude::*;

#[test]
fn other_axis_names_and_missing_axes() {
    let svg = mm_doc(
        20.0,
        10.0,
        r#"<line x1="1" y1="1" x2="2" y2="1" stroke="black"/>"#,
    );
    // y before x, plus an extra axis that must keep its start value.
    let mut t = target();
    t.axes.swap(0, 1);
    t.start = [7.0, 8.0, 9.0, 0.0, 0.0, 0.0];
    let cmds = parse(svg.as_bytes(), &t, &no_flip()).unwrap();
    let Command::Move(m) = cmds
        .iter()
        .rev()
        .find(|c| matches!(c.item, Command::Move(_)))
        .unwrap()
        .item
    else {
        unreachable!()
    };
    assert!(close([m.target[1], m.target[0]], [2.0, 1.0], EPS));
    assert_eq!(m.target[2], 9.0);

    for missing in ["x", "y"] {
        let mut t = target();
        t.axes.retain(|a| a.name != missing);
        let e = parse(svg.as_bytes(), &t, &no_flip()).unwrap_err();
        assert!(e.message.contains(&format!("{missing} axis")), "{e}");
    }
}

#[test]
fn locations() {
    let mixed = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"100mm\" height=\"100mm\" viewBox=\"0 0 100 100\">\n\
               \x20 <line x1=\"1\" y1=\"1\" x2=\"2\" y2=\"1\" stroke=\"black\"/>\n\
               \x20 <g id=\"grp\">\n\
               \x20   <path id=\"p\" d=\"M5 5 L6 6\" stroke=\"black\"/>\n\
               \x20   <circle cx=\"50\" cy=\"50\" r=\"3\"/>\n\
               \x20 </g>\n\
               <defs><rect id=\"r\" width=\"1\" height=\"1\"/></defs>\n\
               \x20<use href=\"#r\" x=\"20\"/>\n\
               <polyline points=\"70,70 80,80\" stroke=\"red\" marker-end=\"url(#m)\"/>\n\
               </svg>";
    let all_ids = "<svg id=\"s\" xmlns=\"http://www.w3.org/2000/svg\">\n\
                   <g id=\"g\"><path id=\"a\" d=\"M1 1 L2 2\"/>\n\
                   \x20   <path id=\"b\" d=\"M3 1 L2 2\"/></g></svg>";
    let clash = "<svg xmlns=\"http://www.w3.org/2000/svg\">\n<path id=\"motet-svg-0\" d=\"M1 1 L2 2\"/>\n<path d=\"M3 1 L2 2\"/></svg>";
    let multibyte =
        "<svg xmlns=\"http://www.w3.org/2000/svg\"><!-- äöü€ --><path d=\"M1 1 L2 2\"/></svg>";
    // (name, document, distinct locations in command order)
    type Case<'a> = (&'a str, &'a str, Vec<(u32, u32)>);
    let cases: Vec<Case> = vec![
        ("mixed", mixed, vec![(2, 3), (4, 5), (5, 5), (8, 2), (9, 1)]),
        ("all elements have ids", all_ids, vec![(2, 11), (3, 5)]),
        ("ids that look generated", clash, vec![(2, 1), (3, 1)]),
        ("columns count characters", multibyte, vec![(1, 54)]),
    ];
    for (name, svg, want) in cases {
        let cmds = run(svg, &no_flip());
        let mut locs: Vec<(u32, u32)> = cmds.iter().map(|c| (c.loc.line, c.loc.column)).collect();
        locs.dedup();
        assert_eq!(locs, want, "{name}: {cmds:?}");
    }
}

#[test]
fn bad_inputs() {
    // (name, input, expected location if the parser knows it)
    type Case = (&'static str, &'static [u8], Option<(u32, u32)>);
    let cases: Vec<Case> = vec![
        ("empty", b"", None),
        ("garbage bytes", b"\xff\xfe\x00\x01garbage", Some((1, 1))),
        ("not UTF-8 later on", b"<svg>\n  \xff</svg>", Some((2, 3))),
        ("plain text", b"hello world", Some((1, 1))),
        (
            "truncated",
            b"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\"",
            None,
        ),
        (
            "unclosed tag",
            b"<svg xmlns=\"http://www.w3.org/2000/svg\">\n<g>\n<path d=\"M0 0 L1 1\"/>\n</svg>",
            Some((4, 1)),
        ),
        ("mismatched quotes", b"<svg width=\"10'/>", None),
        ("gzip", b"\x1f\x8b\x08\x00\x00", None),
        ("not svg root", b"<html/>", Some((1, 1))),
        (
            "zero size",
            b"\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"0\" height=\"10\"/>",
            Some((2, 1)),
        ),
    ];
    for (name, input, loc) in cases {
        let e = parse(input, &target(), &SvgOptions::default()).unwrap_err();
        assert!(e.message.starts_with("invalid SVG: "), "{name}: {e}");
        if let Some((line, column)) = loc {
            assert_eq!((e.loc.line, e.loc.column), (line, column), "{name}: {e}");
        } else if name != "gzip" {
            assert!(e.loc.line > 0, "{name}: {e}");
        }
    }
}

#[test]
fn odd_but_valid_inputs() {
    let cases: Vec<(&str, &str)> = vec![
        ("bom", "\u{feff}<svg xmlns=\"http://www.w3.org/2000/svg\"/>"),
        ("text only", "<svg xmlns=\"http://www.w3.org/2000/svg\"><text>hi</text></svg>"),
        (
            "image",
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><image href=\"/etc/passwd\" width=\"5\" height=\"5\"/></svg>",
        ),
        (
            "dtd entity",
            "<!DOCTYPE svg [<!ENTITY l \"<line x1='0' y1='0' x2='5' y2='5' stroke='black'/>\">]>\
             <svg xmlns=\"http://www.w3.org/2000/svg\">&l;</svg>",
        ),
        (
            "bad path data",
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><path d=\"M 1 1 L x\" stroke=\"black\"/></svg>",
        ),
        (
            "huge transform",
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><path transform=\"scale(1e30)\" d=\"M 0 0 C 1 1 2 0 3 1\" stroke=\"black\"/></svg>",
        ),
    ];
    for &(name, svg) in &cases {
        // Must not panic; errors are allowed only for the huge transform.
        match parse(svg.as_bytes(), &target(), &SvgOptions::default()) {
            Ok(cmds) => {
                let _ = polylines(&cmds);
            }
            Err(e) => assert_eq!(name, "huge transform", "{e}"),
        }
    }
    // The entity-made line is still drawn.
    let entity = cases.iter().find(|c| c.0 == "dtd entity").unwrap().1;
    let cmds = run(entity, &no_flip());
    assert_eq!(polylines(&cmds).len(), 1);
}

#[test]
fn bad_options() {
    let svg = mm_doc(10.0, 10.0, r#"<rect width="5" height="5"/>"#);
    let hatch = |spacing_mm, angle_deg| SvgOptions {
        hatch: Some(Hatch {
            spacing_mm,
            angle_deg,
        }),
        ..Default::default()
    };
    let cases = [
        (hatch(0.0, 0.0), "spacing"),
        (hatch(-1.0, 0.0), "spacing"),
        (hatch(f64::NAN, 0.0), "spacing"),
        (hatch(1.0, f64::INFINITY), "angle"),
        (hatch(1e-9, 0.0), "too dense"),
        (
            SvgOptions {
                pen_change_position: Some([f64::NAN, 0.0]),
                ..Default::default()
            },
            "pen change",
        ),
    ];
    for (opts, want) in cases {
        let e = parse(svg.as_bytes(), &target(), &opts).unwrap_err();
        assert!(e.message.contains(want), "{want}: {e}");
    }
}

#[test]
fn deep_nesting_is_refused_with_its_depth_in_linear_time() {
    // 200,000 nested groups: refused at the first group too deep, without
    // reading the rest.
    let n = 200_000;
    let svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">\n{}<path d=\"M0 0 L1 1\" stroke=\"black\"/>{}</svg>",
        "<g>".repeat(n),
        "</g>".repeat(n)
    );
    let e = parse(svg.as_bytes(), &target(), &SvgOptions::default()).unwrap_err();
    assert!(
        e.message.contains("elements nest more than 256 deep here"),
        "{e}"
    );
    // The svg element is level 1; the 256th group is level 257.
    assert_eq!((e.loc.line, e.loc.column), (2, 255 * 3 + 1), "{e}");
    // As deep as allowed still draws.
    let ok = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">{}<path d=\"M0 0 L1 1\" stroke=\"black\"/>{}</svg>",
        "<g>".repeat(254),
        "</g>".repeat(254)
    );
    assert_eq!(polylines(&run(&ok, &SvgOptions::default())).len(), 1);
}

#[test]
fn entities_cannot_nest_deeper_than_the_text_shows() {
    // Each entity opens 100 groups around the one before; the text itself
    // nests one level.
    let g100 = |inner: &str| format!("{}{inner}{}", "<g>".repeat(100), "</g>".repeat(100));
    let doc = |body: &str| {
        format!(
            "<!DOCTYPE svg [<!ENTITY e \"{}\"><!ENTITY f \"{}\"><!ENTITY h \"{}\">]>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">{body}</svg>",
            g100("<path d='M0 0 L1 1' stroke='black'/>"),
            g100("&e;"),
            g100("&f;")
        )
    };
    // 1 + 200 + the path: fits.
    assert_eq!(
        polylines(&run(&doc("&f;"), &SvgOptions::default())).len(),
        1
    );
    // 1 + 300: refused.
    let e = parse(doc("&h;").as_bytes(), &target(), &SvgOptions::default()).unwrap_err();
    assert!(
        e.message.contains("elements nest more than 256 deep"),
        "{e}"
    );
}

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic(data in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = parse(&data, &target(), &SvgOptions::default());
    }

    #[test]
    fn svgish_soup_never_panics(parts in proptest::collection::vec(prop_oneof![
        Just("<svg xmlns=\"http://www.w3.org/2000/svg\""), Just(">"), Just("</svg>"),
        Just("<g transform=\""), Just("\">"), Just("</g>"), Just("<path d=\""),
        Just("\"/>"), Just(" width=\""), Just(" viewBox=\""), Just("M"), Just("L"),
        Just("C"), Just("A"), Just("Z"), Just(" "), Just("-"), Just("1e9"), Just("0"),
        Just("3.5"), Just("rotate("), Just(")"), Just("<circle r=\""), Just("<use href=\"#a\"/>"),
        Just(" id=\"a\""), Just("<rect rx=\""), Just(" height=\""), Just("scale("),
    ], 0..40)) {
        let doc: String = parts.concat();
        let _ = parse(doc.as_bytes(), &target(), &SvgOptions::default());
    }

    #[test]
    fn options_soup_never_panics(parts in proptest::collection::vec(prop_oneof![
        Just("<svg xmlns=\"http://www.w3.org/2000/svg\""), Just(">"), Just("</svg>"),
        Just("<g transform=\""), Just("\">"), Just("</g>"), Just("<path d=\""),
        Just("\"/>"), Just(" width=\""), Just(" viewBox=\""), Just("M"), Just("L"),
        Just("C"), Just("A"), Just("Z"), Just(" "), Just("-"), Just("1e9"), Just("0"),
        Just("3.5"), Just("rotate("), Just(")"), Just("<circle r=\""), Just("<use href=\"#a\"/>"),
        Just(" id=\"a\""), Just("<rect rx=\""), Just(" height=\""), Just("scale("),
        Just(" fill=\"red\""), Just(" stroke=\"blue\""), Just(" fill-rule=\"evenodd\""),
        Just("<g>"), Just("7"), Just("20"),
    ], 0..40), spacing in 0.05f64..5.0, angle in -400.0f64..400.0, split in 0..3usize,
       optimize in any::<bool>(), park in any::<bool>()) {
        let doc: String = parts.concat();
        let opts = SvgOptions {
            hatch: Some(Hatch { spacing_mm: spacing, angle_deg: angle }),
            pens: [PenSplit::ByColour, PenSplit::ByLayer, PenSplit::Single][split],
            optimize,
            pen_change_position: park.then_some([1.0, 2.0]),
            ..Default::default()
        };
        if let Ok((cmds, info)) = parse_with_info(doc.as_bytes(), &target(), &opts) {
            let _ = polylines(&cmds);
            prop_assert!(info.travel_after_mm <= info.travel_before_mm + 1e-6);
        }
    }
}
