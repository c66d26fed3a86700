//! The base service routines every node runs (ports 1–7 of
//! `motet_wire::service`): status, identify, info, pairing, reset, the
//! bootloader and the clock model.
//!
//! [`Services`] is a state machine over request payloads. The endpoint that
//! owns the transport routes each frame by port: port 0 to its link, port 10
//! to the motion node, every other port to [`Services::handle`], and sends the
//! reply back the way the request came (as a datagram or through the link),
//! on the same port, from the node's own address. It then carries out the
//! returned [`Action`]. The endpoint also reports what only it knows:
//! the motion node's state ([`Services::set_state`]), whether the link is up
//! ([`Services::set_link_up`]), and button presses ([`Services::press_button`]).
//!
//! Like the motion node, it reads no clock: every call takes the node's local
//! clock in µs.

use crate::drift::DriftMeter;
use crate::storage::{Flash, Persisted, Store};
use motet_wire::describe::Description;
use motet_wire::frame::Crc32c;
use motet_wire::image::{ImageError, ImageHeader, MAX_HEADER_LEN, MIN_HEADER_LEN};
use motet_wire::service::{
    is_node_address, port, Info, Kind, NodeState, ServiceError, ServiceReply, ServiceRequest,
    Status, Version, MAX_SKEW, PAGE_SIZE, UNPAIRED,
};
use motet_wire::sync::ClockModel;
use motet_wire::{decode, encode, WireError};

/// What a node is, fixed by its build and board.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeConfig {
    /// Node type the host picks a driver by (see `motet_wire::service::kind`).
    pub kind: Kind,
    /// Unique id, used when the store holds none (then saved): the chip's id
    /// on a board, a random number made once on a simulated node.
    pub uid: u64,
    /// Firmware version of this build, used when the store holds none.
    pub firmware: Version,
    /// Oldest link protocol version the node speaks (see [`Info`]).
    pub protocol_min: u16,
    /// Newest link protocol version the node speaks.
    pub protocol_max: u16,
    /// Places in the motion node's segment queue, as [`Info`] reports them.
    pub queue_capacity: u16,
    /// Step channels the board has.
    pub channels: u8,
    /// Tool outputs the board has.
    pub tools: u8,
    /// The board the firmware runs on: an image must name it. None on a
    /// simulated node, which takes any image (it runs none of them).
    pub board: Option<Kind>,
    /// The fastest step rate a channel reaches, steps/s (0: no limit).
    pub max_step_hz: u32,
}

/// What the endpoint must do after a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Nothing beyond sending the reply.
    None,
    /// Send the reply, then restart the link and the motion node.
    Reset,
    /// Send the reply from the old address, then use this one.
    AddressChanged(u16),
    /// Stop the application (motion): the bootloader owns the node.
    EnterBootloader,
    /// Send the reply, then run the newly installed application.
    StartApplication,
}

/// The outcome of a request: a reply to send (if any) and an action.
#[derive(Clone, Debug, PartialEq)]
pub struct Handled {
    /// What to send back, on the request's port; `None`: nothing (a request
    /// ignored, or a broadcast that is not answered).
    pub reply: Option<ServiceReply>,
    /// What the endpoint does after sending it.
    pub action: Action,
}

impl Handled {
    const SILENT: Handled = Handled {
        reply: None,
        action: Action::None,
    };

    fn reply(reply: ServiceReply) -> Handled {
        Handled {
            reply: Some(reply),
            action: Action::None,
        }
    }

    fn error(e: ServiceError) -> Handled {
        Handled::reply(ServiceReply::Error(e))
    }

    /// Encodes the reply into `out`.
    pub fn encode<'a>(&self, out: &'a mut [u8]) -> Result<Option<&'a [u8]>, WireError> {
        match &self.reply {
            Some(r) => Ok(Some(encode(r, out)?)),
            None => Ok(None),
        }
    }
}

/// A firmware upload in progress.
#[derive(Clone, Copy, Debug)]
struct Upload {
    size: u32,
    crc32c: u32,
    version: Version,
    /// Bytes written contiguously from 0.
    written: u32,
    verified: bool,
}

/// The service routines' state (see the module documentation).
pub struct Services<S: Store, F: Flash> {
    cfg: NodeConfig,
    store: S,
    flash: F,
    persisted: Persisted,
    app_state: NodeState,
    /// Some: in the bootloader.
    upload: Option<Upload>,
    link_up: bool,
    started_us: u64,
    blink_until_us: u64,
    /// Address offered by a Pair broadcast, waiting for the button.
    pairing: Option<u16>,
    clock: Option<ClockModel>,
    /// The node's own measure of its clock's drift.
    drift: DriftMeter,
    /// What it says of itself on port 8: its board's default until given one.
    description: Description,
}

fn checked_end(offset: u32, len: usize) -> Option<u32> {
    offset.checked_add(u32::try_from(len).ok()?)
}

impl<S: Store, F: Flash> Services<S, F> {
    /// Loads the persisted identity (or records `cfg`'s on first start).
    pub fn new(cfg: NodeConfig, mut store: S, flash: F, now_local_us: u64) -> Self {
        let persisted = match store.load() {
            Some(mut p) => {
                if !is_node_address(p.address) {
                    p.address = UNPAIRED;
                }
                p
            }
            None => {
                let p = Persisted::new(cfg.uid, cfg.firmware);
                // A store that cannot save leaves the node working, unpaired, in RAM.
                let _ = store.save(&p);
                p
            }
        };
        Services {
            store,
            flash,
            persisted,
            app_state: NodeState::Idle,
            upload: None,
            link_up: false,
            started_us: now_local_us,
            blink_until_us: 0,
            pairing: None,
            clock: None,
            drift: DriftMeter::default(),
            description: Description::default_for(
                cfg.kind.as_str(),
                cfg.board.as_ref().map_or("", |b| b.as_str()),
                cfg.channels,
                cfg.tools,
                cfg.max_step_hz,
            ),
            cfg,
        }
    }

    /// What the node says of itself (port 8): a simulated module's file, a
    /// board's stored description. Without one it serves its board's
    /// default, made from its channels.
    pub fn set_description(&mut self, description: Description) {
        self.description = description;
    }

    /// The description the node serves.
    pub fn description(&self) -> &Description {
        &self.description
    }

    /// The node's address ([`UNPAIRED`] until paired).
    pub fn address(&self) -> u16 {
        self.persisted.address
    }
    /// Whether the node has an address.
    pub fn paired(&self) -> bool {
        self.persisted.address != UNPAIRED
    }
    /// The node's unique id.
    pub fn uid(&self) -> u64 {
        self.persisted.uid
    }
    /// Installed firmware version.
    pub fn firmware(&self) -> Version {
        self.persisted.firmware
    }
    /// Waiting for the button after a Pair broadcast.
    pub fn pairing(&self) -> bool {
        self.pairing.is_some()
    }
    /// Whether an upload is under way: the bootloader owns the node and motion is stopped.
    pub fn in_bootloader(&self) -> bool {
        self.upload.is_some()
    }
    /// The identify LED: on while identifying or waiting for the button.
    pub fn blinking(&self, now_local_us: u64) -> bool {
        self.pairing.is_some() || now_local_us < self.blink_until_us
    }
    /// The store the node's identity and address persist in.
    pub fn store(&self) -> &S {
        &self.store
    }
    /// The firmware storage uploads are written to.
    pub fn flash(&self) -> &F {
        &self.flash
    }
    /// For fault injection in simulations and tests.
    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    /// The state Status reports; the bootloader overrides the application's.
    pub fn state(&self) -> NodeState {
        if self.upload.is_some() {
            NodeState::Bootloader
        } else {
            self.app_state
        }
    }
    /// The endpoint reports the motion node's state (`Bootloader` is ignored:
    /// only an upload enters it).
    pub fn set_state(&mut self, state: NodeState) {
        if state != NodeState::Bootloader {
            self.app_state = state;
        }
    }
    /// Whether the host's link session is up (reported in [`Status`]).
    pub fn set_link_up(&mut self, up: bool) {
        self.link_up = up;
    }

    /// The clock model set by the host, if any.
    pub fn clock_model(&self) -> Option<ClockModel> {
        self.clock
    }
    /// Whether the host set a clock model: motion runs only then.
    pub fn synced(&self) -> bool {
        self.clock.is_some()
    }
    /// Host time at local time `local_us`: `(local − offset) / (1 + skew)`;
    /// None before the host sent a model.
    pub fn host_time(&self, local_us: f64) -> Option<f64> {
        self.clock.map(|m| (local_us - m.offset) / (1.0 + m.skew))
    }
    /// Local time at host time `host_us`; None before the host sent a model.
    pub fn local_time(&self, host_us: f64) -> Option<f64> {
        self.clock.map(|m| m.offset + (1.0 + m.skew) * host_us)
    }

    /// The answer to a `Status` request at local time `now_local_us` (µs).
    pub fn status(&self, now_local_us: u64) -> Status {
        Status {
            state: self.state(),
            address: self.address(),
            paired: self.paired(),
            link_up: self.link_up,
            synced: self.synced(),
            uptime_us: now_local_us.saturating_sub(self.started_us),
            drift: self.drift.drift(),
        }
    }

    /// The answer to an `Info` request.
    pub fn info(&self) -> Info {
        Info {
            kind: self.cfg.kind.clone(),
            firmware: self.persisted.firmware,
            uid: self.persisted.uid,
            address: self.persisted.address,
            protocol_min: self.cfg.protocol_min,
            protocol_max: self.cfg.protocol_max,
            queue_capacity: self.cfg.queue_capacity,
            channels: self.cfg.channels,
            tools: self.cfg.tools,
            board: self.cfg.board.clone().unwrap_or_default(),
            max_step_hz: self.cfg.max_step_hz,
        }
    }

    /// The node's button. While pairing, the node takes the offered address,
    /// persists it and returns [`ServiceReply::Paired`] for the endpoint to
    /// send to the host as a datagram on port 4, with
    /// [`Action::AddressChanged`]. Otherwise it does nothing (None).
    pub fn press_button(&mut self, _now_local_us: u64) -> Option<Handled> {
        let address = self.pairing?;
        Some(match self.take_address(address) {
            Ok(action) => {
                self.pairing = None;
                Handled {
                    reply: Some(self.paired_reply()),
                    action,
                }
            }
            Err(e) => Handled::error(e),
        })
    }

    /// Acts on a service request: `port` and `payload` from the frame,
    /// `from_broadcast` when it was sent to the broadcast or a group address.
    /// Never panics; a refused request changes nothing.
    ///
    /// An unpaired node answers unicast frames only for a SetAddress naming
    /// its uid (the frame was addressed to nobody, and several unpaired nodes
    /// may share the medium). Broadcasts get only informative replies
    /// ([`ServiceReply::answers_broadcast`]).
    pub fn handle(
        &mut self,
        port: u8,
        payload: &[u8],
        from_broadcast: bool,
        now_local_us: u64,
    ) -> Handled {
        if !(port::STATUS..=port::DESCRIBE).contains(&port) {
            return self.unless_broadcast(
                Handled::reply(ServiceReply::UnknownPort { port }),
                from_broadcast,
            );
        }
        let req = decode::<ServiceRequest>(payload);
        if !self.paired() && !from_broadcast {
            let names_me = match &req {
                Ok(ServiceRequest::SetAddress { uid, .. }) => *uid == self.uid(),
                Ok(ServiceRequest::Describe { uid: Some(uid), .. }) => *uid == self.uid(),
                _ => false,
            };
            if !names_me || !matches!(port, port::ADDRESS | port::DESCRIBE) {
                return Handled::SILENT;
            }
        }
        let h = match req {
            Err(_) => Handled::error(ServiceError::Malformed),
            Ok(r) if r.port() != port => Handled::error(ServiceError::WrongPort { port: r.port() }),
            Ok(r) if from_broadcast && !r.allowed_by_broadcast() => Handled::SILENT,
            Ok(r) => self.dispatch(&r, now_local_us),
        };
        self.unless_broadcast(h, from_broadcast)
    }

    fn unless_broadcast(&self, mut h: Handled, from_broadcast: bool) -> Handled {
        if from_broadcast
            && !h
                .reply
                .as_ref()
                .is_some_and(ServiceReply::answers_broadcast)
        {
            h.reply = None;
        }
        h
    }

    /// The motion node has committed motion: anything that would lose its
    /// position (a reset, the bootloader, a new address and with it a new
    /// link) must wait until it is at rest.
    fn moving(&self) -> bool {
        self.upload.is_none() && self.app_state == NodeState::Running
    }

    fn dispatch(&mut self, req: &ServiceRequest, now: u64) -> Handled {
        let disruptive = match *req {
            ServiceRequest::Reset | ServiceRequest::FirmwareBegin { .. } => true,
            ServiceRequest::SetAddress { uid, address } => {
                uid == self.uid() && address != self.address()
            }
            _ => false,
        };
        if disruptive && self.moving() {
            return Handled::error(ServiceError::Busy);
        }
        match *req {
            ServiceRequest::Status => Handled::reply(ServiceReply::Status(self.status(now))),
            ServiceRequest::Identify { ms } => {
                self.blink_until_us = now.saturating_add(ms as u64 * 1000);
                Handled::reply(ServiceReply::Ack)
            }
            ServiceRequest::Info => Handled::reply(ServiceReply::Info(self.info())),
            ServiceRequest::Pair { address } => self.pair(address),
            ServiceRequest::PairCancel => {
                self.pairing = None;
                self.blink_until_us = 0;
                Handled::reply(ServiceReply::Ack)
            }
            ServiceRequest::SetAddress { uid, address } => {
                if uid != self.uid() {
                    return Handled::error(ServiceError::WrongUid { uid: self.uid() });
                }
                match self.take_address(address) {
                    Ok(action) => {
                        self.pairing = None;
                        Handled {
                            reply: Some(self.paired_reply()),
                            action,
                        }
                    }
                    Err(e) => Handled::error(e),
                }
            }
            ServiceRequest::Reset => {
                self.upload = None;
                self.pairing = None;
                self.blink_until_us = 0;
                self.clock = None;
                self.link_up = false;
                self.app_state = NodeState::Idle;
                self.started_us = now;
                Handled {
                    reply: Some(ServiceReply::Ack),
                    action: Action::Reset,
                }
            }
            ServiceRequest::FirmwareBegin {
                size,
                crc32c,
                ref kind,
                version,
            } => self.firmware_begin(size, crc32c, kind, version),
            ServiceRequest::FirmwarePage { offset, ref data } => self.firmware_page(offset, data),
            ServiceRequest::FirmwareRead { offset, len } => self.firmware_read(offset, len),
            ServiceRequest::FirmwareVerify => match self.firmware_verify() {
                Ok(version) => Handled::reply(ServiceReply::FirmwareVerified { version }),
                Err(e) => Handled::error(e),
            },
            ServiceRequest::FirmwareStart => self.firmware_start(),
            ServiceRequest::TimeGet { t1 } => {
                self.drift.take(t1, now);
                Handled::reply(ServiceReply::Time {
                    t1,
                    t2: now,
                    t3: now,
                })
            }
            ServiceRequest::TimeSet { offset, skew } => {
                if !offset.is_finite() || !skew.is_finite() || skew.abs() >= MAX_SKEW {
                    return Handled::error(ServiceError::BadClock);
                }
                self.clock = Some(ClockModel { offset, skew });
                Handled::reply(ServiceReply::Ack)
            }
            ServiceRequest::Describe { uid, part } => {
                if uid.is_some_and(|u| u != self.uid()) {
                    return Handled::error(ServiceError::WrongUid { uid: self.uid() });
                }
                match self.description.part(self.uid(), part) {
                    Some(data) => Handled::reply(ServiceReply::Description { part, data }),
                    None => Handled::error(ServiceError::NoPart {
                        parts: self.description.parts(),
                    }),
                }
            }
        }
    }

    fn paired_reply(&self) -> ServiceReply {
        ServiceReply::Paired {
            uid: self.uid(),
            address: self.address(),
        }
    }

    fn pair(&mut self, address: u16) -> Handled {
        if self.paired() {
            // Broadcast: not for us (silent). Unicast reaches only a paired node.
            return Handled::error(ServiceError::AlreadyPaired);
        }
        if !is_node_address(address) {
            return Handled::error(ServiceError::BadAddress { address });
        }
        self.pairing = Some(address);
        Handled::SILENT
    }

    /// Persists `address`; on a storage error nothing changes.
    fn take_address(&mut self, address: u16) -> Result<Action, ServiceError> {
        if !is_node_address(address) {
            return Err(ServiceError::BadAddress { address });
        }
        let old = self.persisted.address;
        let p = Persisted {
            address,
            ..self.persisted
        };
        if p != self.persisted {
            self.store.save(&p).map_err(|_| ServiceError::Storage)?;
            self.persisted = p;
        }
        Ok(if old == address {
            Action::None
        } else {
            Action::AddressChanged(address)
        })
    }

    fn firmware_begin(&mut self, size: u32, crc32c: u32, kind: &Kind, version: Version) -> Handled {
        if *kind != self.cfg.kind {
            return Handled::error(ServiceError::WrongKind);
        }
        if (size as usize) < MIN_HEADER_LEN {
            return Handled::error(ServiceError::BadImage(ImageError::Truncated));
        }
        let capacity = self.flash.capacity();
        if size > capacity {
            return Handled::error(ServiceError::TooLarge { capacity });
        }
        let entering = self.upload.is_none();
        self.upload = Some(Upload {
            size,
            crc32c,
            version,
            written: 0,
            verified: false,
        });
        Handled {
            reply: Some(ServiceReply::Ack),
            action: if entering {
                Action::EnterBootloader
            } else {
                Action::None
            },
        }
    }

    fn firmware_page(&mut self, offset: u32, data: &[u8]) -> Handled {
        let Some(up) = self.upload.as_mut() else {
            return Handled::error(ServiceError::NoUpload);
        };
        if offset > up.written {
            return Handled::error(ServiceError::OutOfOrder {
                expected: up.written,
            });
        }
        let out_of_range = ServiceError::OutOfRange {
            offset,
            len: data.len() as u32,
        };
        let Some(end) = checked_end(offset, data.len()).filter(|&e| e <= up.size) else {
            return Handled::error(out_of_range);
        };
        if self.flash.write(offset, data).is_err() {
            return Handled::error(ServiceError::Storage);
        }
        up.written = up.written.max(end);
        up.verified = false;
        Handled::reply(ServiceReply::FirmwareWritten {
            offset,
            len: data.len() as u8,
        })
    }

    fn firmware_read(&mut self, offset: u32, len: u8) -> Handled {
        let out_of_range = Handled::error(ServiceError::OutOfRange {
            offset,
            len: len as u32,
        });
        let n = len as usize;
        if n > PAGE_SIZE {
            return out_of_range;
        }
        match checked_end(offset, n) {
            Some(end) if end <= self.flash.capacity() => {}
            _ => return out_of_range,
        }
        let mut buf = [0u8; PAGE_SIZE];
        if self.flash.read(offset, &mut buf[..n]).is_err() {
            return Handled::error(ServiceError::Storage);
        }
        let mut data = heapless::Vec::new();
        // n ≤ PAGE_SIZE was checked above.
        let _ = data.extend_from_slice(&buf[..n]);
        Handled::reply(ServiceReply::FirmwareData { offset, data })
    }

    /// CRC-32C of flash bytes `from..to`, a page at a time.
    fn flash_crc(&self, from: u32, to: u32) -> Result<u32, ServiceError> {
        let mut crc = Crc32c::new();
        let mut buf = [0u8; PAGE_SIZE];
        let mut at = from;
        while at < to {
            let n = ((to - at) as usize).min(PAGE_SIZE);
            self.flash
                .read(at, &mut buf[..n])
                .map_err(|_| ServiceError::Storage)?;
            crc.update(&buf[..n]);
            at += n as u32;
        }
        Ok(crc.finish())
    }

    fn firmware_verify(&mut self) -> Result<Version, ServiceError> {
        let up = self.upload.ok_or(ServiceError::NoUpload)?;
        if up.written < up.size {
            return Err(ServiceError::SizeMismatch {
                expected: up.size,
                written: up.written,
            });
        }
        let actual = self.flash_crc(0, up.size)?;
        if actual != up.crc32c {
            return Err(ServiceError::CrcMismatch {
                expected: up.crc32c,
                actual,
            });
        }
        let mut head = [0u8; MAX_HEADER_LEN];
        let n = (up.size as usize).min(MAX_HEADER_LEN);
        self.flash
            .read(0, &mut head[..n])
            .map_err(|_| ServiceError::Storage)?;
        let header = ImageHeader::parse(&head[..n]).map_err(ServiceError::BadImage)?;
        if header.kind != self.cfg.kind {
            return Err(ServiceError::WrongKind);
        }
        if let Some(board) = &self.cfg.board {
            if header.board.as_ref() != Some(board) {
                return Err(ServiceError::WrongBoard);
            }
        }
        let len = header.image_len();
        if len != up.size as u64 {
            return Err(ServiceError::BadImage(if len > up.size as u64 {
                ImageError::Truncated
            } else {
                ImageError::TrailingBytes
            }));
        }
        let payload_crc = self.flash_crc(header.header_len() as u32, up.size)?;
        if payload_crc != header.payload_crc {
            return Err(ServiceError::BadImage(ImageError::CrcMismatch {
                expected: header.payload_crc,
                actual: payload_crc,
            }));
        }
        if header.version != up.version {
            return Err(ServiceError::VersionMismatch {
                image: header.version,
            });
        }
        if let Some(u) = self.upload.as_mut() {
            u.verified = true;
        }
        Ok(header.version)
    }

    fn firmware_start(&mut self) -> Handled {
        let Some(up) = self.upload else {
            return Handled::error(ServiceError::NoUpload);
        };
        if !up.verified {
            return Handled::error(ServiceError::NotVerified);
        }
        let p = Persisted {
            firmware: up.version,
            ..self.persisted
        };
        if self.store.save(&p).is_err() {
            return Handled::error(ServiceError::Storage);
        }
        self.persisted = p;
        self.upload = None;
        self.app_state = NodeState::Idle;
        Handled {
            reply: Some(ServiceReply::Ack),
            action: Action::StartApplication,
        }
    }
}
