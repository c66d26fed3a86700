//! Writes the binary seed inputs of `fuzz/corpus/` (firmware images and
//! wire-frame scripts), made with the real encoders from the example
//! machines and graphs:
//!
//! ```sh
//! cargo run -p motet-fuzz --example seeds
//! ```

use motet_fuzz::wire_frame::Script;
use motet_graph::GraphFile;
use motet_host::{Distributor, Machine};
use motet_planner::{Command, Move, MoveKind, Planned, Planner};
use motet_wire::frame::{Flags, Header};
use motet_wire::image;
use motet_wire::service::{port, Kind, ServiceRequest, Version, HOST_ADDRESS};
use motet_wire::{encode, HostMessage, MAX_MESSAGE};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn write(target: &str, name: &str, bytes: &[u8]) {
    let dir = root().join("fuzz/corpus").join(target);
    std::fs::create_dir_all(&dir).expect("corpus folder");
    std::fs::write(dir.join(name), bytes).expect("seed written");
    println!("fuzz/corpus/{target}/{name}: {} bytes", bytes.len());
}

fn firmware(kind: &str, board: Option<&str>, payload_len: usize) -> Vec<u8> {
    let payload: Vec<u8> = (0..payload_len).map(|i| (i * 7 + 3) as u8).collect();
    let mut out = vec![0u8; image::MAX_HEADER_LEN + payload_len];
    let v = Version {
        major: 1,
        minor: 2,
        patch: 3,
    };
    let n = image::build(kind, board, v, &payload, &mut out).expect("image builds");
    out.truncate(n);
    out
}

fn datagram(port: u8) -> Header {
    Header {
        dst: 2,
        src: HOST_ADDRESS,
        port,
        flags: Flags::NONE,
        seq: 0,
        ack: 0,
    }
}

fn bytes<T: serde::Serialize>(m: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_MESSAGE];
    encode(m, &mut buf).expect("fits").to_vec()
}

/// A few moves on the plotter, set up and streamed in batches as a run does.
fn job_script(windowed: bool) -> Script {
    let text = include_str!("../../../examples/plotter.toml");
    let m = Machine::parse(text, Path::new("examples/plotter.toml")).expect("valid");
    let mut dist = Distributor::new(&m);
    let mut s = Script::default();
    if windowed {
        s = s.message(port::MOTION, &HostMessage::Windowed { run: 1 });
    }
    for msg in dist.stream_setup(&m, &m.start).remove(0) {
        s = s.message(port::MOTION, &msg);
    }
    let mut planner = Planner::new(m.limits(), m.start, 0.0);
    let mut p = m.start;
    let mut cmds = vec![Command::Tool {
        tool: 0,
        value: 1.0,
    }];
    for (x, y) in [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (2.0, 3.0)] {
        p[0] = x;
        p[1] = y;
        cmds.push(Command::Move(Move {
            target: p,
            feed: 50.0,
            kind: MoveKind::Feed,
        }));
    }
    cmds.push(Command::Tool {
        tool: 0,
        value: 0.0,
    });
    let mut items: Vec<Planned> = Vec::new();
    for c in &cmds {
        planner.push(c).expect("plans");
        items.extend(std::iter::from_fn(|| planner.pop()));
    }
    planner.finish();
    items.extend(std::iter::from_fn(|| planner.pop()));
    for item in &items {
        let q = dist.quantize(item);
        for out in dist.route_batched(0, &q).expect("batches") {
            s = s.message(port::MOTION, &out.message);
        }
    }
    if let Some(out) = dist.flush(0) {
        s = s.message(port::MOTION, &out.message);
    }
    if windowed {
        let next_seq = dist.next_seq(0).unwrap_or(0);
        s = s.message(port::MOTION, &HostMessage::Seal { next_seq });
    }
    s.message(port::MOTION, &HostMessage::Status)
        .wait(100_000)
        .message(port::MOTION, &HostMessage::Status)
        .wait(2_000_000)
}

/// Journals of a short plotter job: run to the end, and stopped by its host
/// mid-job (then with one coordinate edited, as in the issue that asked
/// resume to prove what it resumes).
fn journals() {
    use motet_net::journal::JournalWriter;
    use motet_net::loopback::{Crystal, Loopback};
    let path = root().join("examples/plotter.toml");
    let m = Machine::load(&path).expect("plotter");
    let job = motet_api::load_job(
        &m,
        &root().join("examples/jobs/drawing.svg"),
        &Default::default(),
    )
    .expect("drawing");
    let cmds = job.commands[..40].to_vec();
    let scratch = tempfile::Builder::new()
        .prefix("motet-seeds-")
        .tempdir()
        .expect("temp folder");
    let dir = scratch.path();
    for (name, kill_at) in [
        ("run.journal", None),
        ("stopped.journal", Some(4_500_000u64)),
    ] {
        let jpath = dir.join(name);
        let (a, b) = motet_link::pair("host", "node");
        let mut lb = Loopback::with_journal(
            &m,
            cmds.clone(),
            m.start,
            vec![(Box::new(a), Box::new(b))],
            &[Crystal::default()],
            Default::default(),
            Some(JournalWriter::create(&jpath).expect("journal")),
        );
        match kill_at {
            None => {
                lb.run_until_settled(600_000_000).expect("run");
            }
            Some(t) => {
                while lb.now < t {
                    lb.step().expect("run");
                }
                lb.host_alive = false;
            }
        }
        drop(lb);
        let text = std::fs::read_to_string(&jpath).expect("journal written");
        write("journal", name, text.as_bytes());
        if kill_at.is_some() {
            let edited: Vec<String> = text
                .lines()
                .map(|l| match l.strip_prefix("seg 5 ") {
                    Some(_) => l.replacen(" | ", " | 921", 1),
                    None => l.to_string(),
                })
                .collect();
            write(
                "journal",
                "issue-edited-coordinate.journal",
                (edited.join("\n") + "\n").as_bytes(),
            );
        }
    }
}

fn main() {
    journals();
    write(
        "firmware_image",
        "stepper-300.img",
        &firmware("stepper", None, 300),
    );
    write(
        "firmware_image",
        "stepper-mps2-an500-200.img",
        &firmware("stepper", Some("mps2-an500"), 200),
    );
    // A header that announces no payload: refused by the parser and the node.
    let mut empty = firmware("laser", None, 1);
    empty.truncate(image::MIN_HEADER_LEN);
    empty[28..32].copy_from_slice(&0u32.to_le_bytes());
    write("firmware_image", "laser-empty.img", &empty);
    write(
        "firmware_image",
        "servo-129.img",
        &firmware("servo", None, 129),
    );

    write("wire_frame", "job.bin", &job_script(false).0);
    write("wire_frame", "job-windowed.bin", &job_script(true).0);

    let graph = GraphFile::parse(
        include_str!("../../../examples/dance/harmonograph/graph.toml"),
        "harmonograph/graph.toml",
    )
    .expect("valid graph");
    let mut s = Script::default();
    for m in graph.messages() {
        s = s.message(port::MOTION, &m);
    }
    for i in graph.inputs.iter() {
        s = s.message(
            port::MOTION,
            &HostMessage::GraphInput {
                kind: i.kind,
                index: i.index,
                value: 120.0,
            },
        );
    }
    write("wire_frame", "graph.bin", &s.wait(10_000).0);

    let kind = Kind::try_from("stepper").expect("short");
    let img = firmware("stepper", None, 200);
    let mut s = Script::default()
        .framed(&datagram(port::STATUS), &bytes(&ServiceRequest::Status))
        .framed(&datagram(port::INFO), &bytes(&ServiceRequest::Info))
        .framed(
            &datagram(port::IDENTIFY),
            &bytes(&ServiceRequest::Identify { ms: 500 }),
        )
        .framed(
            &datagram(port::TIME),
            &bytes(&ServiceRequest::TimeGet { t1: 12345 }),
        )
        .message(
            port::TIME,
            &ServiceRequest::TimeSet {
                offset: 10.0,
                skew: 1e-5,
            },
        )
        .message(
            port::FIRMWARE,
            &ServiceRequest::FirmwareBegin {
                size: img.len() as u32,
                crc32c: motet_wire::frame::crc32c(&img),
                kind,
                version: Version {
                    major: 1,
                    minor: 2,
                    patch: 3,
                },
            },
        );
    for (i, chunk) in img.chunks(128).enumerate() {
        s = s.message(
            port::FIRMWARE,
            &ServiceRequest::FirmwarePage {
                offset: (i * 128) as u32,
                data: heapless::Vec::from_slice(chunk).expect("a page"),
            },
        );
    }
    s = s
        .message(port::FIRMWARE, &ServiceRequest::FirmwareVerify)
        .message(port::FIRMWARE, &ServiceRequest::FirmwareStart)
        .message(port::RESET, &ServiceRequest::Reset)
        .raw(&[0x11, 0x22, 0x00, 0x33]);
    let mut frame = [0u8; motet_wire::frame::MAX_FRAME];
    let n = motet_wire::frame::encode(
        &datagram(port::STATUS),
        &bytes(&ServiceRequest::Status),
        &mut frame,
    )
    .expect("encodes");
    s = s.raw(&frame[..n]);
    write("wire_frame", "services.bin", &s.0);
}
