//! `motet bench-net --traffic`: every frame on the host's side of the wire
//! sorted by what it carries (segment batches, seals, status, clock
//! exchanges, pure acknowledgements, group frames), in bytes and frames per
//! second of motion, each way.

use motet_link::{LinkStats, Stamp, Transport};
use motet_wire::frame::{self, Flags, MAX_RAW};
use motet_wire::group::GroupMessage;
use motet_wire::service::{port, ServiceReply, ServiceRequest};
use motet_wire::{decode, HostMessage, NodeMessage};
use std::collections::BTreeMap;
use std::io;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Frames and bytes of one kind, one way.
#[derive(Clone, Copy, Debug, Default)]
struct Count {
    frames: u64,
    bytes: u64,
}

/// What the taps counted, by direction and kind.
#[derive(Clone, Default)]
pub struct Traffic {
    inner: Arc<Mutex<BTreeMap<(bool, String), Count>>>,
}

impl Traffic {
    fn add(&self, out: bool, frame: &[u8]) {
        let kind = kind(out, frame);
        let mut m = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let c = m.entry((out, kind)).or_default();
        c.frames += 1;
        c.bytes += frame.len() as u64;
    }

    /// Prints the counts per second of `motion` (s), host→nodes first.
    pub fn print(&self, motion: f64) {
        let m = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        for out in [true, false] {
            println!(
                "  traffic {}:",
                if out { "host→nodes" } else { "nodes→host" }
            );
            let mut rows: Vec<(&String, &Count)> = m
                .iter()
                .filter(|((o, _), _)| *o == out)
                .map(|((_, k), c)| (k, c))
                .collect();
            rows.sort_by_key(|r| std::cmp::Reverse(r.1.bytes));
            for (k, c) in rows {
                println!(
                    "    {:<28} {:>7.1} B/s {:>6.2} frames/s {:>6.1} B a frame",
                    k,
                    c.bytes as f64 / motion,
                    c.frames as f64 / motion,
                    c.bytes as f64 / c.frames.max(1) as f64
                );
            }
        }
    }

    /// `transport` with every frame it sends and receives counted.
    pub fn tap(&self, transport: Box<dyn Transport + Send>) -> Box<dyn Transport + Send> {
        Box::new(Tap {
            inner: transport,
            traffic: self.clone(),
        })
    }
}

/// What a frame carries, by its header and the first bytes of its payload.
fn kind(out: bool, bytes: &[u8]) -> String {
    let mut raw = [0u8; MAX_RAW];
    let Ok(f) = frame::decode(bytes, &mut raw) else {
        return "undecodable".into();
    };
    let h = f.header;
    if h.flags == Flags::NONE {
        return match h.port {
            port::GROUP => match decode::<GroupMessage>(f.payload) {
                Ok(GroupMessage::Seal { .. }) => "group seal".into(),
                Ok(GroupMessage::Stop { .. }) => "group stop".into(),
                Ok(GroupMessage::Heartbeat { .. }) => format!("heartbeat from {}", h.src),
                Err(_) => "group ?".into(),
            },
            port::TIME if out => match decode::<ServiceRequest>(f.payload) {
                Ok(ServiceRequest::TimeGet { .. }) => "clock request".into(),
                _ => "time ?".into(),
            },
            port::TIME => match decode::<ServiceReply>(f.payload) {
                Ok(ServiceReply::Time { .. }) => "clock answer".into(),
                _ => "time ?".into(),
            },
            p => format!("datagram port {p}"),
        };
    }
    if h.flags.contains(Flags::SYN) || h.flags.contains(Flags::RST) {
        return "link set-up".into();
    }
    if !h.flags.contains(Flags::DATA) {
        return "pure ack".into();
    }
    let name = if h.port == motet_wire::link::DATA_PORT {
        if out {
            match decode::<HostMessage>(f.payload) {
                Ok(HostMessage::Segments(_)) => "segment batch",
                Ok(HostMessage::Seal { .. }) => "seal",
                Ok(HostMessage::SegmentsSealed(_)) => "segment batch with its seal",
                Ok(HostMessage::Status) => "status request",
                Ok(HostMessage::Where) => "where",
                Ok(_) => "set-up message",
                Err(_) => "motion ?",
            }
            .to_string()
        } else {
            match decode::<NodeMessage>(f.payload) {
                Ok(NodeMessage::Status { .. }) => "status".into(),
                Ok(NodeMessage::Position { .. }) => "position".into(),
                Ok(NodeMessage::Refused { .. }) => "refusal".into(),
                Ok(_) => "motion reply".into(),
                Err(_) => "motion ?".into(),
            }
        }
    } else {
        format!("service port {}", h.port)
    };
    // Data frames carry acks too.
    name + " (+ack)"
}

/// A transport whose frames are counted into a [`Traffic`].
struct Tap {
    inner: Box<dyn Transport + Send>,
    traffic: Traffic,
}

impl Transport for Tap {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        self.traffic.add(true, frame);
        self.inner.send(frame)
    }
    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let got = self.inner.recv(timeout)?;
        if let Some(f) = &got {
            if !self.inner.last_stamp().is_some_and(|s| s.own) {
                self.traffic.add(false, f);
            }
        }
        Ok(got)
    }
    fn stats(&self) -> &LinkStats {
        self.inner.stats()
    }
    fn last_stamp(&self) -> Option<Stamp> {
        self.inner.last_stamp()
    }
}
