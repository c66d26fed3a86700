//! A job file read as a stream gives what a whole-text parse gives, and its
//! errors name the file and line; it never holds more than a line's commands.

use flate2::write::GzEncoder;
use motet_api::job::{JobError, JobKind};
use motet_api::reader::MAX_LINE;
use motet_api::{scan_job, JobOptions, JobReader};
use motet_host::{check_job, Machine};
use std::io::Write;
use std::path::Path;
use tempfile::TempDir;

fn machine(name: &str) -> Machine {
    Machine::load(Path::new(&format!(
        "{}/../../examples/{name}",
        env!("CARGO_MANIFEST_DIR")
    )))
    .unwrap()
}

/// An empty scratch folder, removed when dropped.
fn scratch(tag: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("motet-reader-{tag}-"))
        .tempdir()
        .unwrap()
}

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

/// Texts that differ in how lines end and begin, what comes after the end,
/// and lines longer than the reader's buffer.
fn cases() -> Vec<(&'static str, Vec<u8>)> {
    let long_comment = format!("; {}\nG1 X3 Y4 F600\n", "x".repeat(200_000));
    vec![
        ("plain", b"G21 G90\nG1 X10 Y5 F600\nG1 X20\n".to_vec()),
        ("no final newline", b"G21\nG1 X10 Y5 F600\nG1 X20".to_vec()),
        ("crlf", b"G21\r\nG1 X10 Y5 F600\r\nG1 X20\r\n".to_vec()),
        ("bom", b"\xef\xbb\xbfG21\nG1 X10 F600\n".to_vec()),
        ("empty", b"".to_vec()),
        (
            "after end",
            b"G1 X10 F600\nM2\nG1 X50\n\n; c\nG1 X60\n".to_vec(),
        ),
        (
            "arc",
            b"G21 G90\nG1 X50 Y50 F1200\nG2 X60 Y50 I5 J0\n".to_vec(),
        ),
        (
            "warnings",
            b"G1 X10 F600\nM117 hello\nM117 again\nM900 K0\n".to_vec(),
        ),
        ("long line", long_comment.into_bytes()),
    ]
}

/// The same text parsed whole by the G-code crate, then checked.
fn whole(m: &Machine, data: &[u8]) -> (Vec<motet_planner::Located<motet_planner::Command>>, usize) {
    let text = std::str::from_utf8(data).unwrap();
    let opts = motet_gcode::GcodeOptions {
        allow_unknown: true,
        ..Default::default()
    };
    let mut parsed = motet_gcode::parse(text, &m.job_target(), &opts).unwrap();
    check_job(m, &mut parsed.commands).unwrap();
    (parsed.commands, parsed.warnings.len())
}

#[test]
fn a_file_read_as_a_stream_gives_the_whole_text_parse() {
    let m = machine("plotter.toml");
    let tmp = scratch("same");
    let dir = tmp.path();
    let opts = JobOptions {
        allow_unknown: true,
        ..Default::default()
    };
    for (name, data) in cases() {
        let (want, warnings) = whole(&m, &data);
        let plain = dir.join("j.gcode");
        let packed = dir.join("j.gcode.gz");
        std::fs::write(&plain, &data).unwrap();
        std::fs::write(&packed, gzip(&data)).unwrap();
        for path in [&plain, &packed] {
            let mut r = JobReader::open(&m, path, &opts).unwrap();
            let mut got = Vec::new();
            let mut most_held = 0;
            while let Some(c) = r.next() {
                got.push(c.unwrap());
                most_held = most_held.max(r.held());
            }
            assert_eq!(got, want, "{name}: {}", path.display());
            assert_eq!(r.warnings().len(), warnings, "{name}: {:?}", r.warnings());
            assert_eq!(r.commands(), want.len(), "{name}");
            // What waits is what one line made: an arc's chords at most.
            let bound = if name == "arc" { want.len() } else { 3 };
            assert!(most_held < bound, "{name}: held {most_held}");
            let (read, size) = r.progress();
            assert_eq!(
                (read, size),
                (size, std::fs::metadata(path).unwrap().len()),
                "{name}"
            );
        }
    }
}

#[test]
fn errors_name_the_file_and_line() {
    let m = machine("plotter.toml");
    let tmp = scratch("errors");
    let dir = tmp.path();
    let too_long = {
        let mut d = b"G1 X1 F600\n; ".to_vec();
        d.resize(MAX_LINE + 100, b'x');
        d
    };
    let mut truncated = gzip(b"G1 X1 F600\nG1 X2\nG1 X3\n");
    truncated.truncate(truncated.len() - 12);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "j.gcode",
            b"G1 X1 F600\nG1 X2\nG1 X\xff3\n".to_vec(),
            "j.gcode:3: G-code is not valid UTF-8",
        ),
        (
            "j.gcode",
            too_long,
            "j.gcode:2: line longer than 1048576 bytes",
        ),
        (
            "j.gcode",
            b"G1 X1 F600\nG1 X9000\n".to_vec(),
            "j.gcode:2:1: move to x=9000",
        ),
        (
            "j.gcode",
            b"G1 X1 F600\nG38.2 X5\n".to_vec(),
            "j.gcode:2:1:",
        ),
        ("j.gcode.gz", truncated, "j.gcode.gz: not a valid gzip file"),
    ];
    for (file, data, want) in cases {
        let path = dir.join(file);
        std::fs::write(&path, &data).unwrap();
        let r = JobReader::open(&m, &path, &JobOptions::default()).unwrap();
        let err = scan_job(r, &mut |_, _| {}).unwrap_err().to_string();
        assert!(err.contains(want), "{file}: `{err}` lacks `{want}`");
        // The in-memory reader says the same (gzip aside: bytes come unpacked).
        if !file.ends_with(".gz") {
            let r = JobReader::from_bytes(&m, &path, JobKind::Gcode, &data, &JobOptions::default())
                .unwrap();
            let e2 = r
                .filter_map(Result::err)
                .next()
                .map(|e: JobError| e.to_string());
            assert_eq!(e2.as_deref(), Some(err.as_str()), "{file}");
        }
    }
}

#[test]
fn a_scan_counts_and_plans_what_load_job_keeps() {
    let m = machine("printer.toml");
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/jobs/printer-vase-layers.gcode");
    let opts = JobOptions::default();
    let job = motet_api::load_job(&m, &path, &opts).unwrap();
    let mut seen = Vec::new();
    let scan = scan_job(JobReader::open(&m, &path, &opts).unwrap(), &mut |a, b| {
        seen.push((a, b))
    })
    .unwrap();
    assert_eq!(scan.commands, job.commands.len());
    assert_eq!(Some(scan.planned_s), job.planned_s);
    assert_eq!(scan.warnings, job.warnings);
    assert_eq!(scan.clamps, job.clamps);
    // Progress ends at the whole file.
    let size = std::fs::metadata(&path).unwrap().len();
    assert_eq!(seen.last(), Some(&(size, size)));
}

mod props {
    use super::*;
    use proptest::prelude::*;

    /// Lines from a small G-code vocabulary (moves, comments, blank lines,
    /// unknown codes, the program end), joined by `\n` or `\r\n`, with or
    /// without a final line end and a byte order mark.
    fn arb_text() -> impl Strategy<Value = Vec<u8>> {
        let line = prop_oneof![
            (0.0..200.0f64, 0.0..200.0f64).prop_map(|(x, y)| format!("G1 X{x:.3} Y{y:.3} F1200")),
            (0.0..200.0f64).prop_map(|x| format!("G0 X{x:.2}")),
            Just("; a comment".to_string()),
            Just(String::new()),
            Just("M117 hello".to_string()),
            Just("G21 G90".to_string()),
            Just("M2".to_string()),
        ];
        (
            prop::collection::vec((line, any::<bool>()), 0..40),
            any::<bool>(),
            any::<bool>(),
        )
            .prop_map(|(lines, final_end, bom)| {
                let mut t = if bom {
                    "\u{feff}".to_string()
                } else {
                    String::new()
                };
                let n = lines.len();
                for (i, (l, crlf)) in lines.into_iter().enumerate() {
                    t.push_str(&l);
                    if i + 1 < n || final_end {
                        t.push_str(if crlf { "\r\n" } else { "\n" });
                    }
                }
                t.into_bytes()
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, .. ProptestConfig::default() })]

        #[test]
        fn streamed_equals_whole_text(data in arb_text()) {
            let m = machine("plotter.toml");
            let (want, warnings) = whole(&m, &data);
            let opts = JobOptions { allow_unknown: true, ..Default::default() };
            let mut r = JobReader::from_bytes(&m, Path::new("j.gcode"), JobKind::Gcode, &data, &opts).unwrap();
            let got: Vec<_> = r.by_ref().collect::<Result<_, _>>().unwrap();
            prop_assert_eq!(got, want);
            prop_assert_eq!(r.warnings().len(), warnings);
        }
    }
}
