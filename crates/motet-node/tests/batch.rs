//! Segment batches are taken whole or refused whole.

use motet_node::Node;
use motet_planner::{AxisLimits, Command, Limits, Move, MoveKind, Planned, Planner};
use motet_trajectory::{JointMap, ProfileKind};
use motet_wire::stream::{Batch, BatchEncoder, Quantizer};
use motet_wire::{
    encode, ChannelConfig, HostMessage, NodeMessage, Refusal, StreamConfig, MAX_MESSAGE,
};

fn send<const Q: usize>(node: &mut Node<Q>, m: &HostMessage) -> Option<NodeMessage> {
    let mut buf = [0u8; MAX_MESSAGE];
    node.handle(encode(m, &mut buf).unwrap())
}

fn batches(cfg: StreamConfig, n: usize, per_batch: usize) -> Vec<Batch> {
    let axis = AxisLimits {
        max_velocity: 100.0,
        max_acceleration: 1000.0,
        max_jerk: None,
        path: true,
    };
    let limits = Limits {
        axes: vec![axis, axis],
        joints: vec![],
        junction_deviation: 0.05,
        profile: ProfileKind::Trapezoid,
        tools: vec![],
        lookahead: 64,
        stop_horizon: 0,
        min_move_s: 0.0,
        max_move_s: 0.0,
    };
    let mut p = Planner::new(limits, [0.0; 6], 0.0);
    for k in 1..=n {
        let a = k as f64 * 0.3;
        let target = [5.0 * a.cos(), 5.0 * a.sin(), 0.0, 0.0, 0.0, 0.0];
        p.push(&Command::Move(Move {
            target,
            feed: 80.0,
            kind: MoveKind::Feed,
        }))
        .unwrap();
    }
    p.finish();
    let mut q = Quantizer::new(cfg, [0.0; 6]);
    let mut enc = BatchEncoder::new(cfg, 0b11, [0.0; 6], 0, per_batch);
    let mut out = vec![];
    while let Some(x) = p.pop() {
        if let Planned::Segment(s) = x {
            out.extend(enc.push(&q.segment(&s)).unwrap());
        }
    }
    out.extend(enc.flush());
    out
}

/// A node with two linear channels, configured for batches on `cfg`, at
/// rest at the origin.
fn configured<const Q: usize>(cfg: StreamConfig) -> Node<Q> {
    let mut node: Node<Q> = Node::new();
    for (ch, axis) in [(0u8, 0usize), (1, 1)] {
        let mut coeffs = [0.0; 6];
        coeffs[axis] = 1.0;
        let c = ChannelConfig {
            channel: ch,
            map: JointMap::Linear { coeffs },
            steps_per_unit: 80.0,
            pulse_us: 2.0,
            dir_setup_us: 1.0,
        };
        assert_eq!(send(&mut node, &HostMessage::ConfigureChannel(c)), None);
    }
    assert_eq!(send(&mut node, &HostMessage::ConfigureStream(cfg)), None);
    assert_eq!(
        send(&mut node, &HostMessage::SetPosition { position: [0.0; 6] }),
        None
    );
    node
}

#[test]
fn batches_are_taken_whole_or_not_at_all() {
    let cfg = StreamConfig {
        path_mask: 0b11,
        ..StreamConfig::default()
    };
    let mut node: Node<8> = configured(cfg);
    let b = batches(cfg, 20, 6);
    assert!(b.len() >= 3 && b[0].segments == 6);
    // Out of order: the second batch first.
    assert_eq!(
        send(&mut node, &HostMessage::Segments(b[1].batch.clone())),
        Some(NodeMessage::Refused {
            reason: Refusal::OutOfOrder {
                expected: 0,
                got: 6
            }
        })
    );
    assert_eq!(
        send(&mut node, &HostMessage::Segments(b[0].batch.clone())),
        None
    );
    assert_eq!(node.queued(), 6);
    // Six more do not fit in the two places left: nothing is taken.
    let before = node.status();
    assert_eq!(
        send(&mut node, &HostMessage::Segments(b[1].batch.clone())),
        Some(NodeMessage::Refused {
            reason: Refusal::QueueFull
        })
    );
    assert_eq!(node.status(), before);
    // A batch cut short is malformed, and also leaves everything as it was.
    let mut cut = b[1].batch.clone();
    cut.bytes.truncate(cut.bytes.len() - 1);
    assert_eq!(
        send(&mut node, &HostMessage::Segments(cut)),
        Some(NodeMessage::Refused {
            reason: Refusal::Malformed
        })
    );
    assert_eq!(node.status(), before);
}

/// A window's last batch with its seal commits the batch's segments as a
/// `Segments` and a `Seal` would, with no answer (the link's
/// acknowledgement confirms it); a node that takes no seal refuses it and
/// takes none of its segments.
#[test]
fn a_batch_with_its_seal_commits_its_window_or_changes_nothing() {
    let cfg = StreamConfig {
        path_mask: 0b11,
        ..StreamConfig::default()
    };
    let mut node: Node<16> = configured(cfg);
    let b = batches(cfg, 20, 6);
    let sealed = |b: &Batch| HostMessage::SegmentsSealed(b.batch.clone());
    // Not windowed: no seal, so not the batch either.
    let before = node.status();
    assert_eq!(
        send(&mut node, &sealed(&b[0])),
        Some(NodeMessage::Refused {
            reason: Refusal::BadConfig
        })
    );
    assert_eq!(node.status(), before);
    assert_eq!(send(&mut node, &HostMessage::Windowed { run: 3 }), None);
    assert_eq!(send(&mut node, &sealed(&b[0])), None);
    let s = node.status();
    assert_eq!((s.next_seq, s.committed, node.queued()), (6, 6, 6));
    // The same as two messages, and a seal answers nothing.
    assert_eq!(
        send(&mut node, &HostMessage::Segments(b[1].batch.clone())),
        None
    );
    assert_eq!(node.status().committed, 6);
    assert_eq!(send(&mut node, &HostMessage::Seal { next_seq: 12 }), None);
    assert_eq!(node.status().committed, 12);
    // Closed (a group stop): refused, nothing taken.
    node.close(Some(12));
    let before = node.status();
    assert_eq!(
        send(&mut node, &sealed(&b[2])),
        Some(NodeMessage::Refused {
            reason: Refusal::Closed
        })
    );
    assert_eq!((node.status(), node.queued()), (before, 12));
}
