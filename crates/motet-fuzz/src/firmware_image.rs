//! Firmware images: parsed as `motet nodes flash` does before uploading, and
//! uploaded page by page to a node's bootloader (the `motet-node` service
//! routines over a RAM flash), which must reach the same verdict the host
//! parser did. An image that parses is rebuilt byte for byte, starts on the
//! node, and is refused once a byte of its flash copy flips.

use crate::{bounded, MAX_INPUT};
use motet_node::{NodeConfig, Persisted, RamFlash, RamStore, Services};
use motet_wire::frame::crc32c;
use motet_wire::image::{self, ImageHeader};
use motet_wire::service::{
    port, Kind, ServiceError, ServiceReply, ServiceRequest, Version, PAGE_SIZE,
};
use motet_wire::{encode, MAX_MESSAGE};

const ADDRESS: u16 = 5;
const NOW: u64 = 1_000_000;
/// The node's firmware before the upload.
const INSTALLED: Version = Version {
    major: 0,
    minor: 0,
    patch: 1,
};

type Bootloader = Services<RamStore, RamFlash<MAX_INPUT>>;

fn request(node: &mut Bootloader, r: &ServiceRequest) -> ServiceReply {
    let mut buf = [0u8; MAX_MESSAGE];
    let bytes = encode(r, &mut buf).expect("requests fit a message");
    let h = node.handle(port::FIRMWARE, bytes, false, NOW);
    h.reply.expect("a unicast firmware request is answered")
}

/// Uploads `img` and asks the node to verify it; the node's verdict.
fn upload(
    node: &mut Bootloader,
    img: &[u8],
    kind: &Kind,
    version: Version,
) -> Result<Version, ServiceError> {
    let begin = ServiceRequest::FirmwareBegin {
        size: img.len() as u32,
        crc32c: crc32c(img),
        kind: kind.clone(),
        version,
    };
    match request(node, &begin) {
        ServiceReply::Ack => {}
        ServiceReply::Error(e) => return Err(e),
        other => panic!("FirmwareBegin answered {other:?}"),
    }
    for (i, chunk) in img.chunks(PAGE_SIZE).enumerate() {
        let offset = (i * PAGE_SIZE) as u32;
        let page = ServiceRequest::FirmwarePage {
            offset,
            data: heapless::Vec::from_slice(chunk).expect("chunks are one page"),
        };
        match request(node, &page) {
            ServiceReply::FirmwareWritten { offset: o, len } => {
                assert_eq!((o, len as usize), (offset, chunk.len()), "page echo")
            }
            other => panic!("page at {offset} answered {other:?}"),
        }
    }
    if let Some(first) = img.chunks(PAGE_SIZE).next() {
        let read = ServiceRequest::FirmwareRead {
            offset: 0,
            len: first.len() as u8,
        };
        match request(node, &read) {
            ServiceReply::FirmwareData { offset: 0, data } => {
                assert_eq!(
                    data.as_slice(),
                    first,
                    "read-back differs from what was written"
                )
            }
            other => panic!("read-back answered {other:?}"),
        }
    }
    match request(node, &ServiceRequest::FirmwareVerify) {
        ServiceReply::FirmwareVerified { version } => Ok(version),
        ServiceReply::Error(e) => Err(e),
        other => panic!("FirmwareVerify answered {other:?}"),
    }
}

/// Runs image bytes through the host parser and a node's bootloader.
pub fn firmware_image(data: &[u8]) {
    let img = bounded(data);
    let parsed = image::parse(img);
    // Announced as the host would: the header's kind and version where
    // there is a header, a stepper's otherwise.
    let header = ImageHeader::parse(img).ok();
    let kind = header.as_ref().map_or_else(
        || Kind::try_from("stepper").expect("short kind"),
        |h| h.kind.clone(),
    );
    let version = header.as_ref().map_or(INSTALLED, |h| h.version);
    let cfg = NodeConfig {
        kind: kind.clone(),
        uid: 0x00c0_ffee,
        firmware: INSTALLED,
        protocol_min: 1,
        protocol_max: 1,
        queue_capacity: 64,
        channels: 4,
        tools: 2,
        // A simulated node: it takes an image for any board.
        board: None,
        max_step_hz: 0,
    };
    let store = RamStore {
        record: Some(Persisted {
            uid: cfg.uid,
            address: ADDRESS,
            firmware: INSTALLED,
        }),
        saves: 0,
    };
    let mut node: Box<Bootloader> = Box::new(Services::new(cfg, store, RamFlash::new(), 0));
    let verdict = upload(&mut node, img, &kind, version);
    match (&parsed, &verdict) {
        (Ok(p), Ok(v)) => assert_eq!(p.header.version, *v, "verified another version"),
        (Err(pe), Err(ServiceError::BadImage(ne))) => {
            assert_eq!(
                pe, ne,
                "host and node refuse the image for different reasons"
            )
        }
        (Ok(_), Err(e)) => panic!("the node refused an image the host accepts: {e:?}"),
        (Err(e), Ok(_)) => panic!("the node accepted an image the host refuses: {e}"),
        (Err(_), Err(e)) => panic!("the node refused a bad image without naming why: {e:?}"),
    }
    let Ok(parsed) = parsed else { return };

    // The builder writes the same bytes back.
    let mut out = vec![0u8; img.len()];
    let n = image::build(
        parsed.header.kind.as_str(),
        parsed.header.board.as_ref().map(|b| b.as_str()),
        parsed.header.version,
        parsed.payload,
        &mut out,
    )
    .expect("an image that parses rebuilds");
    assert_eq!(&out[..n], img, "rebuilt image differs");

    // A flipped byte in flash is caught before the image runs.
    let at = img.len() / 2;
    node.flash_mut().bytes_mut()[at] ^= 0x10;
    match request(&mut node, &ServiceRequest::FirmwareVerify) {
        ServiceReply::Error(_) => {}
        other => panic!("a flipped byte at {at} was verified: {other:?}"),
    }
    node.flash_mut().bytes_mut()[at] ^= 0x10;
    assert!(matches!(
        request(&mut node, &ServiceRequest::FirmwareVerify),
        ServiceReply::FirmwareVerified { .. }
    ));
    match request(&mut node, &ServiceRequest::FirmwareStart) {
        ServiceReply::Ack => assert_eq!(node.firmware(), parsed.header.version),
        other => panic!("FirmwareStart after a verify answered {other:?}"),
    }
}
