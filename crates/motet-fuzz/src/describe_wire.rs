//! Description parts as a host receives them from a module: a run of
//! postcard-encoded [`DescribePart`]s (each as a node's reply carries it).
//! The first that decodes as a head opens an [`Assembler`]; the parts after
//! it are taken at the next indices. Whatever the bytes, nothing panics; a
//! description that comes whole gives its head's digest, and a node given it
//! serves every part back unchanged.

use crate::bounded;
use motet_node::{NodeConfig, RamFlash, RamStore, Services};
use motet_wire::describe::{Assembler, DescribePart};
use motet_wire::service::{port, Kind, ServiceReply, ServiceRequest, Version};
use motet_wire::{decode, encode, MAX_MESSAGE};

/// Runs the bytes as a sequence of description parts (see the module
/// documentation), and each byte run as a Describe request to a node.
pub fn describe_wire(data: &[u8]) {
    let mut rest = bounded(data);
    let mut parts = Vec::new();
    while !rest.is_empty() && parts.len() < 16 {
        match postcard::take_from_bytes::<DescribePart>(rest) {
            Ok((p, r)) => {
                parts.push(p);
                rest = r;
            }
            Err(_) => rest = &rest[1..],
        }
    }
    let mut node = Services::new(config(), RamStore::default(), RamFlash::<64>::new(), 0);
    // Any payload as a Describe request: a reply or silence, never a panic.
    let _ = node.handle(port::DESCRIBE, bounded(data), false, 0);
    let Some(DescribePart::Head(head)) = parts.first().cloned() else {
        return;
    };
    let Ok(mut a) = Assembler::new(head) else {
        return;
    };
    for (i, p) in parts.into_iter().enumerate().skip(1) {
        let _ = a.take(i as u8, p);
    }
    let Ok(d) = a.finish() else { return };
    assert_eq!(
        d.digest(),
        head.digest,
        "a description that does not give its digest"
    );
    node.set_description(d.clone());
    let mut buf = [0u8; MAX_MESSAGE];
    for i in 0..d.parts() {
        // An unpaired node answers a request that names it.
        let req = ServiceRequest::Describe {
            uid: Some(0x5157),
            part: i,
        };
        let bytes = encode(&req, &mut buf).expect("a request fits");
        let reply = node.handle(port::DESCRIBE, bytes, false, 0).reply;
        let want = d
            .part(0x5157, i)
            .map(|data| ServiceReply::Description { part: i, data });
        assert_eq!(reply, want, "part {i} served otherwise");
        if let Some(r) = reply {
            let bytes = encode(&r, &mut buf).expect("a part fits one reply");
            assert_eq!(decode::<ServiceReply>(bytes).as_ref(), Ok(&r));
        }
    }
}

fn config() -> NodeConfig {
    NodeConfig {
        kind: Kind::try_from("stepper").expect("a short kind"),
        uid: 0x5157,
        firmware: Version::default(),
        protocol_min: 1,
        protocol_max: 1,
        queue_capacity: 64,
        channels: 2,
        tools: 1,
        board: None,
        max_step_hz: 0,
    }
}
