//! Talking to nodes outside a run: scan a link, pair, identify, read status,
//! upload firmware. Requests travel as datagrams (frames without link flags)
//! and are repeated until answered, so no link has to be set up first; every
//! request here is safe to repeat (a page written twice writes the same bytes).

use crate::clock::{self, SharedClock};
use motet_link::Transport;
use motet_wire::decode;
use motet_wire::frame::{self, Flags, BROADCAST, MAX_RAW};
use motet_wire::image;
use motet_wire::service::{
    is_node_address, Info, ServiceReply, ServiceRequest, Version, HOST_ADDRESS, PAGE_SIZE,
};
use std::time::Duration;

/// Why an administrative request failed. Every request is safe to repeat,
/// so the person can put the cause right and ask again.
#[derive(Debug, thiserror::Error)]
pub enum AdminError {
    /// The transport failed (port closed, no route).
    #[error("{link}: {error}")]
    Io {
        /// The link's name, as given (its spec).
        link: String,
        /// What the transport said.
        error: std::io::Error,
    },
    /// Nothing answered any of the tries: the node is off, on another link or
    /// at another address.
    #[error("{link}: no answer from node {address:#06x} after {tries} tries")]
    NoAnswer {
        /// The link's name, as given (its spec).
        link: String,
        /// The node's address on the link.
        address: u16,
        /// Requests sent.
        tries: u32,
    },
    /// Only another address answered.
    #[error("{link}: a request to node {address} was answered from address {from}: another node is on this link, or the node's address changed; pair again")]
    WrongAddress {
        /// The link's name, as given (its spec).
        link: String,
        /// The node's address on the link.
        address: u16,
        /// The address that answered.
        from: u16,
    },
    /// The node answered with an error.
    #[error("{link}: node {address:#06x} refused: {error}")]
    Refused {
        /// The link's name, as given (its spec).
        link: String,
        /// The node's address on the link.
        address: u16,
        /// The node's refusal, as text.
        error: String,
    },
    /// The node answered with a reply that does not fit the request.
    #[error("{link}: node {address:#06x} answered {got} to {asked}")]
    Unexpected {
        /// The link's name, as given (its spec).
        link: String,
        /// The node's address on the link.
        address: u16,
        /// The request, as debug text.
        asked: String,
        /// The answer, as debug text.
        got: String,
    },
    /// Pairing was answered by another uid or with another address than asked.
    #[error("{link}: a node answered as uid {got:016x} address {got_address} where uid {want:016x} address {want_address} was asked")]
    WrongNode {
        /// The link's name, as given (its spec).
        link: String,
        /// The uid asked for.
        want: u64,
        /// The address asked for.
        want_address: u16,
        /// The uid that answered.
        got: u64,
        /// The address it answered with.
        got_address: u16,
    },
    /// Nobody pressed a node's button while pairing waited.
    #[error("{link}: no node's button was pressed within {seconds:.0} s")]
    NoButton {
        /// The link's name, as given (its spec).
        link: String,
        /// How long the pairing waited, s.
        seconds: f64,
    },
    /// The image's own message; every one of them says it is about firmware.
    #[error("{0}")]
    Image(String),
    /// The request would lose the position of a node that is moving.
    #[error("{link}: node {address:#06x} is moving (it has committed motion): {what} would lose its position; wait for its job to finish or stop")]
    Busy {
        /// The link's name, as given (its spec).
        link: String,
        /// The node's address on the link.
        address: u16,
        /// What was asked (`a firmware upload`).
        what: &'static str,
    },
    /// The firmware read back from the node is not what was written.
    #[error("{link}: firmware read-back differs at byte {offset}")]
    ReadBack {
        /// The link's name, as given (its spec).
        link: String,
        /// Byte offset in the image of the first difference.
        offset: u32,
    },
    /// The firmware image is built for another board than the node.
    #[error("{link}: the image is for board {image}, node {address:#06x} is a {node}: build the firmware for {node}")]
    WrongBoard {
        /// The link's name, as given (its spec).
        link: String,
        /// The node's address on the link.
        address: u16,
        /// The board the image was built for.
        image: String,
        /// The board the node says it is.
        node: String,
    },
    /// After the upload the node runs another version than the one uploaded.
    #[error("{link}: node {address:#06x} restarted running firmware {running}, not the {flashed} it was given: its bootloader refused the image (the board's console says why)")]
    NotInstalled {
        /// The link's name, as given (its spec).
        link: String,
        /// The node's address on the link.
        address: u16,
        /// The version uploaded.
        flashed: Version,
        /// The version the node runs.
        running: Version,
    },
}

/// A node found by a scan.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Found {
    /// The address the answer came from.
    pub from: u16,
    /// What it says it is: uid, kind, board, firmware, queue size.
    pub info: Info,
}

/// Administrative requests over one transport. Waits are measured on its
/// clock (the wall clock unless given another, [`Admin::with_clock`]).
pub struct Admin {
    transport: Box<dyn Transport + Send>,
    link: String,
    clock: SharedClock,
    /// Wait for an answer before repeating the request.
    pub timeout: Duration,
    /// How many times a request is sent before giving up.
    pub tries: u32,
}

impl Admin {
    /// Requests over `transport` (named `link` in errors), waits on the wall
    /// clock, 200 ms per try, 5 tries.
    pub fn new(transport: Box<dyn Transport + Send>, link: &str) -> Admin {
        Admin::with_clock(transport, link, clock::wall())
    }

    /// Requests whose waits are measured on `clock`.
    pub fn with_clock(
        transport: Box<dyn Transport + Send>,
        link: &str,
        clock: SharedClock,
    ) -> Admin {
        Admin {
            transport,
            link: link.to_string(),
            clock,
            timeout: Duration::from_millis(200),
            tries: 5,
        }
    }

    /// The link's name, as given.
    pub fn link(&self) -> &str {
        &self.link
    }

    /// The transport, for a run to go on with.
    pub fn into_transport(self) -> Box<dyn Transport + Send> {
        self.transport
    }

    fn io(&self, error: std::io::Error) -> AdminError {
        AdminError::Io {
            link: self.link.clone(),
            error,
        }
    }

    fn send(&mut self, dst: u16, req: &ServiceRequest) -> Result<(), AdminError> {
        let r = self.transport.send(&crate::peer::datagram(dst, req));
        r.map_err(|e| self.io(e))
    }

    fn now(&self) -> u64 {
        self.clock.now_us()
    }

    /// The next service reply datagram to the host before `until` (µs of
    /// the clock), with its source.
    fn receive(&mut self, until: u64) -> Result<Option<(u16, u8, ServiceReply)>, AdminError> {
        loop {
            let now = self.now();
            if now >= until {
                return Ok(None);
            }
            let r = self.transport.recv(Some(self.clock.real(until - now)));
            let Some(bytes) = r.map_err(|e| self.io(e))? else {
                continue;
            };
            let mut raw = [0u8; MAX_RAW];
            let Ok(f) = frame::decode(&bytes, &mut raw) else {
                continue;
            };
            if f.header.dst != HOST_ADDRESS || f.header.flags != Flags::NONE {
                continue;
            }
            if let Ok(reply) = decode::<ServiceReply>(f.payload) {
                return Ok(Some((f.header.src, f.header.port, reply)));
            }
        }
    }

    /// Sends `req` to `dst` until a reply on its port comes from `dst`.
    pub fn request(&mut self, dst: u16, req: &ServiceRequest) -> Result<ServiceReply, AdminError> {
        let mut stranger = None;
        for _ in 0..self.tries {
            self.send(dst, req)?;
            let until = self.now() + us(self.timeout);
            while let Some((src, port, reply)) = self.receive(until)? {
                if port != req.port() {
                    continue;
                }
                if dst != BROADCAST && src != dst {
                    stranger = Some(src);
                    continue;
                }
                if let ServiceReply::Error(e) = reply {
                    return Err(AdminError::Refused {
                        link: self.link.clone(),
                        address: dst,
                        error: e.to_string(),
                    });
                }
                return Ok(reply);
            }
        }
        Err(match stranger {
            Some(from) => AdminError::WrongAddress {
                link: self.link.clone(),
                address: dst,
                from,
            },
            None => AdminError::NoAnswer {
                link: self.link.clone(),
                address: dst,
                tries: self.tries,
            },
        })
    }

    fn unexpected(&self, dst: u16, asked: &ServiceRequest, got: &ServiceReply) -> AdminError {
        AdminError::Unexpected {
            link: self.link.clone(),
            address: dst,
            asked: format!("{asked:?}"),
            got: format!("{got:?}"),
        }
    }

    /// Every node that answers a broadcast Info within `wait`.
    pub fn scan(&mut self, wait: Duration) -> Result<Vec<Found>, AdminError> {
        let mut found: Vec<Found> = Vec::new();
        let start = self.now();
        // Asked a few times: a datagram may be lost.
        for _ in 0..3 {
            self.send(BROADCAST, &ServiceRequest::Info)?;
            let until = (self.now() + us(wait / 3)).min(start + us(wait));
            while let Some((src, _, reply)) = self.receive(until)? {
                if let ServiceReply::Info(info) = reply {
                    if !found.iter().any(|f| f.info.uid == info.uid) {
                        found.push(Found { from: src, info });
                    }
                }
            }
        }
        Ok(found)
    }

    /// Info of the node at `address`.
    pub fn info(&mut self, address: u16) -> Result<Info, AdminError> {
        let req = ServiceRequest::Info;
        match self.request(address, &req)? {
            ServiceReply::Info(i) => Ok(i),
            other => Err(self.unexpected(address, &req, &other)),
        }
    }

    /// Status of the node at `address`.
    pub fn status(&mut self, address: u16) -> Result<motet_wire::service::Status, AdminError> {
        let req = ServiceRequest::Status;
        match self.request(address, &req)? {
            ServiceReply::Status(s) => Ok(s),
            other => Err(self.unexpected(address, &req, &other)),
        }
    }

    /// Makes the node at `address` blink for `ms`.
    pub fn identify(&mut self, address: u16, ms: u32) -> Result<(), AdminError> {
        let req = ServiceRequest::Identify { ms };
        match self.request(address, &req)? {
            ServiceReply::Ack => Ok(()),
            other => Err(self.unexpected(address, &req, &other)),
        }
    }

    /// Gives the node with `uid` the address `address` (a node alone on its
    /// link, or one already known). The answer must name the same uid and address.
    pub fn set_address(&mut self, uid: u64, address: u16) -> Result<(), AdminError> {
        let req = ServiceRequest::SetAddress { uid, address };
        match self.request(BROADCAST, &req)? {
            ServiceReply::Paired {
                uid: got,
                address: got_address,
            } if got == uid && got_address == address => Ok(()),
            ServiceReply::Paired {
                uid: got,
                address: got_address,
            } => Err(AdminError::WrongNode {
                link: self.link.clone(),
                want: uid,
                want_address: address,
                got,
                got_address,
            }),
            other => Err(self.unexpected(BROADCAST, &req, &other)),
        }
    }

    /// Asks every unpaired node to blink and waits up to `wait` for a person
    /// to press one's button; that node takes `address`. Returns its uid.
    pub fn pair_by_button(&mut self, address: u16, wait: Duration) -> Result<u64, AdminError> {
        let start = self.now();
        let end = start + us(wait);
        let mut next_ask = start;
        while self.now() < end {
            if self.now() >= next_ask {
                // Repeated so that a lost datagram or a node started late still blinks.
                self.send(BROADCAST, &ServiceRequest::Pair { address })?;
                next_ask = self.now() + 1_000_000;
            }
            let until = next_ask.min(end);
            while let Some((_, _, reply)) = self.receive(until)? {
                if let ServiceReply::Paired { uid, address: got } = reply {
                    let _ = self.send(BROADCAST, &ServiceRequest::PairCancel);
                    if got != address {
                        return Err(AdminError::WrongNode {
                            link: self.link.clone(),
                            want: uid,
                            want_address: address,
                            got: uid,
                            got_address: got,
                        });
                    }
                    return Ok(uid);
                }
            }
        }
        let _ = self.send(BROADCAST, &ServiceRequest::PairCancel);
        Err(AdminError::NoButton {
            link: self.link.clone(),
            seconds: wait.as_secs_f64(),
        })
    }

    /// Refuses, before asking the node, what would lose a moving node's
    /// position (the node refuses it too: this names it first).
    pub fn at_rest(&mut self, address: u16, what: &'static str) -> Result<(), AdminError> {
        if self.status(address)?.state == motet_wire::service::NodeState::Running {
            return Err(AdminError::Busy {
                link: self.link.clone(),
                address,
                what,
            });
        }
        Ok(())
    }

    /// Uploads a firmware image to the node at `address`: pages, read-back,
    /// verify, start. Returns the version the node then runs. `progress`
    /// gets bytes written and the total. Refused while the node moves.
    pub fn flash(
        &mut self,
        address: u16,
        image_bytes: &[u8],
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Version, AdminError> {
        let img = image::parse(image_bytes).map_err(|e| AdminError::Image(e.to_string()))?;
        let header = img.header.clone();
        self.at_rest(address, "a firmware upload")?;
        // A board names itself; an image for another (or for none) would
        // be refused after the whole upload.
        let info = self.info(address)?;
        if !info.board.is_empty() && header.board.as_ref() != Some(&info.board) {
            return Err(AdminError::WrongBoard {
                link: self.link.clone(),
                address,
                image: header
                    .board
                    .as_ref()
                    .map_or("(none: a format 1 image)".to_string(), |b| b.to_string()),
                node: info.board.to_string(),
            });
        }
        let begin = ServiceRequest::FirmwareBegin {
            size: image_bytes.len() as u32,
            crc32c: frame::crc32c(image_bytes),
            kind: header.kind.clone(),
            version: header.version,
        };
        self.expect_ack(address, &begin)?;
        for (i, chunk) in image_bytes.chunks(PAGE_SIZE).enumerate() {
            let offset = (i * PAGE_SIZE) as u32;
            let req = ServiceRequest::FirmwarePage {
                offset,
                data: heapless::Vec::from_slice(chunk).expect("chunks are one page"),
            };
            match self.request(address, &req)? {
                ServiceReply::FirmwareWritten { offset: o, len }
                    if o == offset && len as usize == chunk.len() => {}
                other => return Err(self.unexpected(address, &req, &other)),
            }
            progress(offset as usize + chunk.len(), image_bytes.len());
        }
        for (i, chunk) in image_bytes.chunks(PAGE_SIZE).enumerate() {
            let offset = (i * PAGE_SIZE) as u32;
            let req = ServiceRequest::FirmwareRead {
                offset,
                len: chunk.len() as u8,
            };
            match self.request(address, &req)? {
                ServiceReply::FirmwareData { offset: o, data } if o == offset => {
                    if data.as_slice() != chunk {
                        let at = data
                            .iter()
                            .zip(chunk)
                            .position(|(a, b)| a != b)
                            .unwrap_or(0);
                        return Err(AdminError::ReadBack {
                            link: self.link.clone(),
                            offset: offset + at as u32,
                        });
                    }
                }
                other => return Err(self.unexpected(address, &req, &other)),
            }
        }
        let req = ServiceRequest::FirmwareVerify;
        let version = match self.request(address, &req)? {
            ServiceReply::FirmwareVerified { version } => version,
            other => return Err(self.unexpected(address, &req, &other)),
        };
        self.expect_ack(address, &ServiceRequest::FirmwareStart)?;
        self.running(address, version)?;
        Ok(version)
    }

    /// Waits for the node at `address` to answer after a firmware start (a
    /// board restarts through its bootloader) and checks it runs `version`.
    fn running(&mut self, address: u16, version: Version) -> Result<(), AdminError> {
        let until = self.now() + 15_000_000;
        loop {
            match self.info(address) {
                Ok(i) if i.firmware == version => return Ok(()),
                Ok(i) => {
                    return Err(AdminError::NotInstalled {
                        link: self.link.clone(),
                        address,
                        flashed: version,
                        running: i.firmware,
                    })
                }
                Err(AdminError::NoAnswer { .. }) if self.now() < until => {}
                Err(e) => return Err(e),
            }
        }
    }

    fn expect_ack(&mut self, address: u16, req: &ServiceRequest) -> Result<(), AdminError> {
        match self.request(address, req)? {
            ServiceReply::Ack => Ok(()),
            other => Err(self.unexpected(address, req, &other)),
        }
    }
}

/// A wait in µs.
fn us(d: Duration) -> u64 {
    d.as_micros().min(u64::MAX as u128) as u64
}

/// The next free node address not in `taken`.
pub fn free_address(taken: &[u16]) -> u16 {
    (2..=0xFFEFu16)
        .find(|a| !taken.contains(a))
        .filter(|a| is_node_address(*a))
        .unwrap_or(2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_wire::frame::{Header, MAX_FRAME};
    use motet_wire::service::{NodeState, Status};
    use motet_wire::{encode, MAX_MESSAGE};

    /// A fake node on the far end of `t`: answers every request with `reply`
    /// from address `from`, until the test ends.
    fn fake_node(mut t: motet_link::MemTransport, from: u16, reply: ServiceReply) {
        std::thread::spawn(move || {
            while let Ok(got) = t.recv(Some(Duration::from_secs(5))) {
                let Some(bytes) = got else { break };
                let mut raw = [0u8; MAX_RAW];
                let Ok(f) = frame::decode(&bytes, &mut raw) else {
                    continue;
                };
                let mut buf = [0u8; MAX_MESSAGE];
                let payload = encode(&reply, &mut buf).unwrap();
                let h = Header {
                    dst: HOST_ADDRESS,
                    src: from,
                    port: f.header.port,
                    flags: Flags::NONE,
                    seq: 0,
                    ack: 0,
                };
                let mut out = [0u8; MAX_FRAME];
                let n = frame::encode(&h, payload, &mut out).unwrap();
                if t.send(&out[..n]).is_err() {
                    break;
                }
            }
        });
    }

    fn admin_with(from: u16, reply: ServiceReply) -> Admin {
        let (a, b) = motet_link::pair("host", "node");
        fake_node(b, from, reply);
        let mut admin = Admin::new(Box::new(a), "mem");
        admin.timeout = Duration::from_millis(50);
        admin.tries = 2;
        admin
    }

    #[test]
    fn wrong_answers_are_named() {
        let status = ServiceReply::Status(Status {
            state: NodeState::Idle,
            address: 7,
            paired: true,
            link_up: false,
            synced: false,
            uptime_us: 1,
            drift: None,
        });
        // A node answering from another address than the one asked.
        let e = admin_with(7, status.clone())
            .status(2)
            .unwrap_err()
            .to_string();
        assert!(e.contains("answered from address 7"), "{e}");
        // The right address but the wrong kind of answer.
        let e = admin_with(2, status).info(2).unwrap_err().to_string();
        assert!(e.contains("answered Status"), "{e}");
        // SetAddress answered by another node than the uid named.
        let e = admin_with(
            0,
            ServiceReply::Paired {
                uid: 99,
                address: 2,
            },
        )
        .set_address(5, 2)
        .unwrap_err()
        .to_string();
        assert!(e.contains("uid 0000000000000063"), "{e}");
        // A refusal is passed on with its reason.
        let e = admin_with(
            2,
            ServiceReply::Error(motet_wire::service::ServiceError::NotVerified),
        )
        .identify(2, 10)
        .unwrap_err()
        .to_string();
        assert!(e.contains("refused"), "{e}");
    }

    /// A transport on which every receive lets `step` µs of a simulated
    /// clock pass and nothing ever arrives.
    struct Silent {
        inner: motet_link::MemTransport,
        clock: motet_link::SimClock,
        step: u64,
    }

    impl Transport for Silent {
        fn name(&self) -> &str {
            "silent"
        }
        fn send(&mut self, frame: &[u8]) -> std::io::Result<()> {
            self.inner.send(frame)
        }
        fn recv(&mut self, _: Option<Duration>) -> std::io::Result<Option<Vec<u8>>> {
            self.clock.advance(self.step);
            Ok(None)
        }
        fn stats(&self) -> &motet_link::LinkStats {
            self.inner.stats()
        }
    }

    #[test]
    fn waits_are_measured_on_the_admin_clock() {
        // (timeout, tries, µs per receive, receives until the request gives up)
        let cases = [
            (200_000u64, 5u32, 50_000u64, 20u32),
            (1_000, 3, 1_000, 3),
            (10_000, 1, 3_000, 4),
        ];
        for (timeout, tries, step, receives) in cases {
            let clock = motet_link::SimClock::new();
            let (a, _b) = motet_link::pair("host", "node");
            let silent = Silent {
                inner: a,
                clock: clock.clone(),
                step,
            };
            let mut admin =
                Admin::with_clock(Box::new(silent), "sim", std::sync::Arc::new(clock.clone()));
            admin.timeout = Duration::from_micros(timeout);
            admin.tries = tries;
            let e = admin.info(2).unwrap_err();
            assert!(
                matches!(e, AdminError::NoAnswer { tries: t, .. } if t == tries),
                "{e}"
            );
            assert_eq!(
                clock.get(),
                step * receives as u64,
                "{timeout} {tries} {step}"
            );
        }
    }
}
