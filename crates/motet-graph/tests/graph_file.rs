//! Graph files: good and bad files with the expected place of each error;
//! messages round trip; a node builds and runs a graph from the messages and
//! refuses a bad one, keeping the running graph.

use motet_graph::GraphFile;
use motet_node::{Board, Node};
use motet_wire::{decode, encode, HostMessage, NodeMessage, MAX_MESSAGE};

const SKETCH: &str = r#"
frame_us = 40

[components.knob_x]
kind = "encoder"
ratio = 0.05

[components.knob_y]
kind = "encoder"
ratio = 0.05

[components.kin]
kind = "corexy"

[components.ch_a]
kind = "channel"
units = 25.4
steps = 2874

[components.ch_b]
kind = "channel"
units = 25.4
steps = 2874

[[map]]
from = "knob_x.out"
to = "kin.x"

[[map]]
from = "knob_y.out"
to = "kin.y"

[[map]]
from = "kin.a"
to = "ch_a.target"

[[map]]
from = "kin.b"
to = "ch_b.target"
mode = "incremental"

[inputs]
knob_x = "encoder0"
knob_y = "encoder1"
"#;

#[test]
fn good_file_parses_in_file_order() {
    let g = GraphFile::parse(SKETCH, "sketch.toml").unwrap();
    let names: Vec<&str> = g.components.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["knob_x", "knob_y", "kin", "ch_a", "ch_b"]);
    assert_eq!(g.channels().count(), 2);
    assert_eq!(g.inputs.len(), 2);
    assert!(g.set("ch_a", "filter", 10.0).is_ok());
    assert!(g.set("ch_a", "speed", 10.0).is_err());
    assert!(g.set("nope", "filter", 10.0).is_err());
}

/// (file, expected "line:column", words the message must contain).
fn bad_cases() -> Vec<(String, &'static str, &'static str)> {
    let sub = |from: &str, to: &str| {
        assert!(SKETCH.contains(from), "{from}");
        SKETCH.replacen(from, to, 1)
    };
    vec![
        (
            sub("kind = \"corexy\"", "kind = \"coreyx\""),
            "13:8",
            "unknown component kind `coreyx`",
        ),
        (
            sub(
                "ratio = 0.05\n\n[components.knob_y]",
                "ratio = 0.05\nspeed = 3\n\n[components.knob_y]",
            ),
            "7:1",
            "unknown parameter `speed`",
        ),
        (
            sub("to = \"kin.x\"", "to = \"kin.z\""),
            "27:6",
            "has no port `z`",
        ),
        (
            sub("to = \"kin.x\"", "to = \"kni.x\""),
            "27:6",
            "no component `kni`",
        ),
        (
            sub("mode = \"incremental\"", "mode = \"global\""),
            "40:8",
            "unknown mode `global`",
        ),
        (
            sub("knob_y = \"encoder1\"", "knob_y = \"analog1\""),
            "44:10",
            "not an input a `encoder` reads",
        ),
        (
            sub("knob_y = \"encoder1\"", ""),
            "8:13",
            "name it in [inputs]",
        ),
        (
            sub("[components.kin]\nkind", "[components.kin]\nkinds"),
            "12:13",
            "missing `kind`",
        ),
        (
            // A map from an input (not a tap).
            sub("from = \"kin.a\"", "from = \"kin.x\""),
            "33:1",
            "is an input",
        ),
        (
            // An absolute mapping backward in the frame: a cycle.
            sub(
                "from = \"kin.b\"\nto = \"ch_b.target\"\nmode = \"incremental\"",
                "from = \"ch_b.position\"\nto = \"ch_a.target_b\"\nmode = \"absolute\"",
            ),
            "37:1",
            "cycle",
        ),
        (
            // Absolute plus another mapping into kin.y.
            sub(
                "from = \"kin.b\"\nto = \"ch_b.target\"\nmode = \"incremental\"",
                "from = \"knob_x.out\"\nto = \"kin.y\"\nmode = \"absolute\"",
            ),
            "37:1",
            "absolute mapping and another",
        ),
        (
            sub(
                "units = 25.4\nsteps = 2874\n\n[components.ch_b]",
                "units = 0\nsteps = 2874\n\n[components.ch_b]",
            ),
            "15:13",
            "nonzero",
        ),
        (sub("frame_us = 40", "frame_us = 0"), "2:12", "at least 1"),
    ]
}

#[test]
fn bad_files_name_the_place() {
    let mut bad = Vec::new();
    for (text, at, words) in bad_cases() {
        let e = GraphFile::parse(&text, "g.toml").expect_err(words);
        let got = format!("{}:{}", e.line, e.column);
        let msg = e.to_string();
        assert!(msg.starts_with(&format!("g.toml:{got}: ")), "{msg}");
        if got != at || !msg.contains(words) {
            bad.push(format!("want {at} {words:?}, got {msg}"));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn stages_validate() {
    let base = SKETCH.to_string()
        + r#"
[components.pen]
kind = "position"
speed = 100

[[stage]]
name = "up"
set = { "pen.go" = 1 }
until = { finished = "pen" }

[[stage]]
name = "wait"
until = { pressed = "knob_x" }
next = "up"
"#;
    let g = GraphFile::parse(&base, "g.toml").unwrap();
    assert_eq!(g.stages.len(), 2);
    let bad = base.replace("\"pen.go\"", "\"pen.goo\"");
    let e = GraphFile::parse(&bad, "g.toml").unwrap_err();
    assert!(e.to_string().contains("no live parameter `goo`"), "{e}");
    let bad = base.replace("next = \"up\"", "next = \"down\"");
    let e = GraphFile::parse(&bad, "g.toml").unwrap_err();
    assert!(e.to_string().contains("no stage `down`"), "{e}");
}

#[test]
fn messages_round_trip() {
    let g = GraphFile::parse(SKETCH, "sketch.toml").unwrap();
    let mut buf = [0u8; MAX_MESSAGE];
    let msgs = g.messages();
    assert!(matches!(msgs[0], HostMessage::GraphBegin { .. }));
    assert!(matches!(msgs.last(), Some(HostMessage::GraphCommit)));
    for m in msgs {
        let bytes = encode(&m, &mut buf).unwrap();
        let back: HostMessage = decode(bytes).unwrap();
        assert_eq!(back, m);
    }
}

#[derive(Default)]
struct Steps(Vec<(u8, bool, f64)>);
impl Board for Steps {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        self.0.push((channel, forward, at_us));
    }
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
}

fn send(node: &mut Node<8>, m: &HostMessage) -> Option<NodeMessage> {
    let mut buf = [0u8; MAX_MESSAGE];
    node.handle(encode(m, &mut buf).unwrap())
}

#[test]
fn node_builds_runs_and_refuses_bad_graphs() {
    let g = GraphFile::parse(SKETCH, "sketch.toml").unwrap();
    let mut node: Box<Node<8>> = Box::new(Node::new());
    assert_eq!(node.next_deadline(), None);
    for m in g.messages() {
        assert_eq!(send(&mut node, &m), None, "{m:?}");
    }
    assert!(node.graph().is_some());
    assert_eq!(node.next_deadline(), Some(0.0));
    // 20 counts on x: 1 mm → a and b each 2874/25.4 ≈ 113 steps.
    send(&mut node, &g.input_message("knob_x", 20.0).unwrap());
    let mut board = Steps::default();
    node.poll(40.0 * 400.0, &mut board);
    assert_eq!(node.graph_frames(), 400);
    let a = board.0.iter().filter(|s| s.0 == 0).count();
    let b = board.0.iter().filter(|s| s.0 == 1).count();
    assert_eq!(a, 113);
    assert_eq!(b, 113);
    assert!(board.0.iter().all(|s| s.1 && s.2 % 40.0 == 0.0));
    assert_eq!(node.next_deadline(), Some(16000.0));

    // A bad graph: a mapping to a port that does not exist. Refused at the
    // mapping and at the commit; the running graph keeps running.
    let before = node.graph().unwrap().clone();
    let mut msgs = g.messages();
    let k = msgs
        .iter()
        .position(|m| matches!(m, HostMessage::GraphMap { .. }))
        .unwrap();
    if let HostMessage::GraphMap { to, .. } = &mut msgs[k] {
        to.port = 9;
    }
    let mut refused = 0;
    for m in &msgs {
        if let Some(NodeMessage::Refused { .. }) = send(&mut node, m) {
            refused += 1;
        }
    }
    assert!(refused >= 2, "{refused}");
    assert_eq!(node.graph().unwrap(), &before);
    send(&mut node, &g.input_message("knob_x", 0.0).unwrap());
    node.poll(40.0 * 800.0, &mut board);
    assert_eq!(board.0.iter().filter(|s| s.0 == 0 && !s.1).count(), 113);
    // A parameter change with no such parameter is refused.
    let bad = HostMessage::GraphParam {
        component: 0,
        param: 7,
        value: 1.0,
    };
    assert!(matches!(
        send(&mut node, &bad),
        Some(NodeMessage::Refused { .. })
    ));
    assert_eq!(
        send(&mut node, &g.set("ch_a", "filter", 4.0).unwrap()),
        None
    );
}
