//! Reliable, ordered delivery between two addresses over [frames](crate::frame).
//!
//! A [`Link`] is a state machine for one peer. It reads no clock: every call
//! takes the time `now` in µs, and [`Link::next_timeout`] says when to call
//! [`Link::poll`] again. The shape follows smoltcp: the application calls
//! [`Link::send`] to queue a payload, hands every received frame to
//! [`Link::on_frame`], and calls [`Link::poll`] until it returns `None`,
//! transmitting each frame it returns.
//!
//! Rules (see docs/wire.md):
//! - Connect: each side sends SYN with its protocol version range, window and
//!   initial sequence number (ISN) until the peer acknowledges it (ack = ISN+1);
//!   a SYN is answered with SYN|ACK. The agreed version is the highest both
//!   support; if there is none the link fails with
//!   [`LinkError::VersionMismatch`], answers with RST and accepts no data. A
//!   passive side ([`Config::active`] false) sends its SYN only in answer.
//! - Data: each payload has a sequence number (u16, from ISN+1, serial
//!   arithmetic). At most [`WINDOW`] payloads are unacknowledged; a full window
//!   makes [`Link::send`] return [`SendError::WindowFull`] and keeps nothing.
//! - Acks are cumulative: every frame carries ACK with the next sequence number
//!   the sender expects. Each received data frame, new or duplicate, is
//!   acknowledged (piggybacked on data when there is some to send).
//! - Receive: frames within the window are buffered out of order and delivered
//!   in order exactly once; duplicates and frames outside the window are
//!   dropped (and acknowledged).
//! - Retransmission: one timer for the oldest unacknowledged frame, RTO after
//!   RFC 6298 (SRTT, RTTVAR, RTO = SRTT + max(G, 4·RTTVAR), clamped), samples
//!   only from frames sent once (Karn), RTO doubled on each timeout up to
//!   [`Config::max_rto_us`]. Three duplicate acks retransmit the oldest frame
//!   at once; during recovery every partial ack retransmits the next hole.

use crate::frame::{self, Flags, Frame, FrameError, Header, MAX_FRAME, MAX_PAYLOAD, MAX_RAW};

/// Frames in flight per direction.
pub const WINDOW: usize = 8;
/// This implementation's link protocol version.
pub const PROTOCOL_VERSION: u16 = 1;
/// Port of the link's own frames (SYN, RST, pure ACK).
pub const LINK_PORT: u8 = 0;
/// Default port of application payloads.
pub const DATA_PORT: u8 = 10;

const DUP_ACK_THRESHOLD: u8 = 3;
const MAX_BACKOFF: u32 = 16;

/// Link settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// This side's address (the frames' source).
    pub local: u16,
    /// The other side's address: frames from anyone else are counted in [`Stats::foreign`] and
    /// dropped.
    pub peer: u16,
    /// Port used by [`Link::send`].
    pub port: u8,
    /// Send SYN first (the host); a passive side (a node) waits for one.
    pub active: bool,
    /// Lowest and highest link protocol version this side speaks.
    pub version_min: u16,
    /// See `version_min`; the highest common version is agreed in the handshake.
    pub version_max: u16,
    /// Initial sequence number; should differ across restarts (a boot counter
    /// or a random number) so that a peer recognises a restart.
    pub isn: u16,
    /// Frames in flight, at most [`WINDOW`]; the smaller of both sides' is used.
    pub window: u8,
    /// RTO before any RTT sample, µs.
    pub initial_rto_us: u64,
    /// Least RTO however small the RTT, µs (RFC 6298 suggests 1 s on the Internet; a serial or USB
    /// link is far quicker).
    pub min_rto_us: u64,
    /// Most RTO, backoff included, µs.
    pub max_rto_us: u64,
    /// Clock granularity G of RFC 6298, µs.
    pub granularity_us: u64,
}

impl Config {
    /// Defaults: port [`DATA_PORT`], version [`PROTOCOL_VERSION`], window
    /// [`WINDOW`], RTO 100 ms initially, clamped to 2 ms … 1 s.
    pub const fn new(local: u16, peer: u16, active: bool) -> Config {
        Config {
            local,
            peer,
            port: DATA_PORT,
            active,
            version_min: PROTOCOL_VERSION,
            version_max: PROTOCOL_VERSION,
            isn: 0,
            window: WINDOW as u8,
            initial_rto_us: 100_000,
            min_rto_us: 2_000,
            max_rto_us: 1_000_000,
            granularity_us: 100,
        }
    }
}

/// Why a link stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkError {
    /// No protocol version both sides speak; no data is accepted.
    VersionMismatch {
        /// The lowest and highest version this side speaks.
        ours: (u16, u16),
        /// The lowest and highest version the peer's SYN offered.
        theirs: (u16, u16),
    },
    /// The peer reset the link (RST) or restarted (SYN with a new ISN).
    PeerReset,
}

/// Connection state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// Handshake under way; payloads may be queued already.
    Connecting,
    /// Both SYNs acknowledged; `version` agreed.
    Established {
        /// The link protocol version agreed: the highest both sides speak.
        version: u16,
    },
    /// Stopped; make a new link to start again.
    Failed(LinkError),
}

/// Why [`Link::send`] kept nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SendError {
    /// [`WINDOW`] payloads are unacknowledged; try again after acks arrive.
    WindowFull,
    /// Longer than [`MAX_PAYLOAD`].
    TooLong,
    /// The link failed.
    Failed(LinkError),
}

/// Counters and estimates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Frames handed to the transport: data, acks, SYNs, retransmissions.
    pub frames_sent: u64,
    /// Frames that decoded and were for this link (from the peer, to this side).
    pub frames_received: u64,
    /// Payloads sent for the first time (resending one counts in `retransmits`).
    pub payloads_sent: u64,
    /// Payloads handed up in order.
    pub payloads_delivered: u64,
    /// All retransmissions (timeouts, duplicate acks, partial acks, SYNs).
    pub retransmits: u64,
    /// Retransmissions because the RTO ran out.
    pub timeouts: u64,
    /// Retransmissions after three duplicate acks (before the RTO).
    pub fast_retransmits: u64,
    /// Frames dropped for a bad CRC ([`FrameError::BadCrc`]).
    pub crc_errors: u64,
    /// Frames dropped for a bad COBS encoding.
    pub cobs_errors: u64,
    /// Frames dropped for being shorter than a header and a CRC.
    pub truncated: u64,
    /// Frames dropped for being longer than [`MAX_FRAME`].
    pub too_long: u64,
    /// Frames dropped for a frame format version this side does not know.
    pub unknown_version: u64,
    /// Payloads received again (already delivered, or already held): dropped, acknowledged again.
    pub duplicates_dropped: u64,
    /// Payloads too far ahead of the next expected one to hold: dropped.
    pub out_of_window: u64,
    /// Frames for another address or from another peer.
    pub foreign: u64,
    /// Frames ignored because the link failed, or malformed SYNs.
    pub refused: u64,
    /// RTT samples taken (Karn's rule: none from a retransmitted payload).
    pub rtt_samples: u64,
    /// Latest RTT sample, smoothed RTT, RTT variation, current RTO, µs.
    pub last_rtt_us: u64,
    /// Least RTT sample, µs.
    pub min_rtt_us: u64,
    /// Smoothed RTT (RFC 6298's SRTT), µs.
    pub srtt_us: u64,
    /// RTT variation (RFC 6298's RTTVAR), µs.
    pub rttvar_us: u64,
    /// Current RTO, backoff included, µs.
    pub rto_us: u64,
}

#[derive(Clone, Copy)]
struct TxSlot {
    data: [u8; MAX_PAYLOAD],
    len: u8,
    port: u8,
    sent_at: u64,
    retransmitted: bool,
}

#[derive(Clone, Copy)]
struct RxSlot {
    data: [u8; MAX_PAYLOAD],
    len: u8,
    port: u8,
    full: bool,
}

/// A payload delivered in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Delivery<'a> {
    /// The port the payload was sent to.
    pub port: u8,
    /// The payload's bytes, as sent.
    pub payload: &'a [u8],
}

/// `a - b` as a signed serial-number distance.
fn diff(a: u16, b: u16) -> i16 {
    a.wrapping_sub(b) as i16
}

/// Reliable delivery to one peer.
pub struct Link {
    cfg: Config,
    window: u16,
    failed: Option<LinkError>,
    rst_pending: bool,
    version: u16,
    // handshake
    syn_acked: bool,
    peer_isn: Option<u16>,
    synack_pending: bool,
    syn_sent_at: Option<u64>,
    syn_retransmitted: bool,
    // send side
    snd_una: u16,
    snd_nxt: u16,
    snd_end: u16,
    tx: [TxSlot; WINDOW],
    rtx_deadline: Option<u64>,
    rtx_pending: bool,
    dup_acks: u8,
    recover: Option<u16>,
    // receive side
    rcv_nxt: u16,
    rx: [RxSlot; WINDOW],
    ack_pending: bool,
    // RTO
    srtt: Option<u64>,
    rttvar: u64,
    backoff: u32,
    stats: Stats,
}

impl Link {
    /// A link on `cfg`, connecting: an active side sends its SYN at the first [`Link::poll`].
    pub fn new(cfg: Config) -> Link {
        let start = cfg.isn.wrapping_add(1);
        let mut link = Link {
            cfg,
            window: (cfg.window as usize).clamp(1, WINDOW) as u16,
            failed: None,
            rst_pending: false,
            version: 0,
            syn_acked: false,
            peer_isn: None,
            synack_pending: false,
            syn_sent_at: None,
            syn_retransmitted: false,
            snd_una: start,
            snd_nxt: start,
            snd_end: start,
            tx: [TxSlot {
                data: [0; MAX_PAYLOAD],
                len: 0,
                port: 0,
                sent_at: 0,
                retransmitted: false,
            }; WINDOW],
            rtx_deadline: None,
            rtx_pending: false,
            dup_acks: 0,
            recover: None,
            rcv_nxt: 0,
            rx: [RxSlot {
                data: [0; MAX_PAYLOAD],
                len: 0,
                port: 0,
                full: false,
            }; WINDOW],
            ack_pending: false,
            srtt: None,
            rttvar: 0,
            backoff: 0,
            stats: Stats::default(),
        };
        link.stats.rto_us = link.rto();
        link
    }

    /// The settings the link was made with.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Connecting, established (with the agreed version), or failed (and why).
    pub fn state(&self) -> State {
        match self.failed {
            Some(e) => State::Failed(e),
            None if self.established() => State::Established {
                version: self.version,
            },
            None => State::Connecting,
        }
    }

    /// Counters and RTT estimates since the link was made.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Payloads queued or in flight, not yet acknowledged.
    pub fn unacked(&self) -> usize {
        self.snd_end.wrapping_sub(self.snd_una) as usize
    }

    /// Room for more payloads before [`SendError::WindowFull`].
    pub fn send_space(&self) -> usize {
        self.window as usize - self.unacked()
    }

    /// Current retransmission timeout, µs, backoff included.
    pub fn rto(&self) -> u64 {
        let base = match self.srtt {
            None => self.cfg.initial_rto_us,
            Some(srtt) => srtt + self.cfg.granularity_us.max(4 * self.rttvar),
        }
        .clamp(self.cfg.min_rto_us, self.cfg.max_rto_us);
        base.saturating_mul(1 << self.backoff.min(MAX_BACKOFF))
            .min(self.cfg.max_rto_us)
    }

    fn established(&self) -> bool {
        self.failed.is_none() && self.syn_acked && self.peer_isn.is_some()
    }

    /// Queues `payload` for [`Config::port`].
    pub fn send(&mut self, payload: &[u8], now: u64) -> Result<(), SendError> {
        self.send_port(self.cfg.port, payload, now)
    }

    /// Queues `payload` for `port`. Nothing is kept on error.
    pub fn send_port(&mut self, port: u8, payload: &[u8], _now: u64) -> Result<(), SendError> {
        if let Some(e) = self.failed {
            return Err(SendError::Failed(e));
        }
        if payload.len() > MAX_PAYLOAD {
            return Err(SendError::TooLong);
        }
        if self.unacked() >= self.window as usize {
            return Err(SendError::WindowFull);
        }
        let slot = &mut self.tx[self.snd_end as usize % WINDOW];
        slot.data[..payload.len()].copy_from_slice(payload);
        slot.len = payload.len() as u8;
        slot.port = port;
        slot.retransmitted = false;
        self.snd_end = self.snd_end.wrapping_add(1);
        Ok(())
    }

    /// Takes one encoded frame (with or without its trailing 0x00) and returns
    /// the next payload in order, if one is ready. More may be ready after a
    /// gap is filled: take them with [`Link::recv`].
    pub fn on_frame(&mut self, bytes: &[u8], now: u64) -> Option<Delivery<'_>> {
        let mut raw = [0u8; MAX_RAW];
        match frame::decode(bytes, &mut raw) {
            Ok(f) => {
                self.handle(&f, now);
                self.recv()
            }
            Err(e) => {
                self.on_frame_error(e);
                None
            }
        }
    }

    /// Like [`Link::on_frame`] for a frame already decoded (by a
    /// [`frame::Deframer`] or a dispatcher that routes frames by source).
    pub fn on_decoded(&mut self, f: &Frame<'_>, now: u64) -> Option<Delivery<'_>> {
        self.handle(f, now);
        self.recv()
    }

    /// Counts a frame that failed to decode.
    pub fn on_frame_error(&mut self, e: FrameError) {
        let s = &mut self.stats;
        match e {
            FrameError::BadCrc => s.crc_errors += 1,
            FrameError::BadCobs => s.cobs_errors += 1,
            FrameError::Truncated => s.truncated += 1,
            FrameError::TooLong => s.too_long += 1,
            FrameError::UnknownVersion => s.unknown_version += 1,
        }
    }

    /// The next payload in order, if ready.
    pub fn recv(&mut self) -> Option<Delivery<'_>> {
        if self.failed.is_some() || self.peer_isn.is_none() {
            return None;
        }
        let i = self.rcv_nxt as usize % WINDOW;
        if !self.rx[i].full {
            return None;
        }
        self.rx[i].full = false;
        self.rcv_nxt = self.rcv_nxt.wrapping_add(1);
        self.ack_pending = true;
        self.stats.payloads_delivered += 1;
        let slot = &self.rx[i];
        Some(Delivery {
            port: slot.port,
            payload: &slot.data[..slot.len as usize],
        })
    }

    fn fail(&mut self, e: LinkError) {
        if self.failed.is_none() {
            self.failed = Some(e);
        }
        self.rtx_deadline = None;
        self.rtx_pending = false;
    }

    fn handle(&mut self, f: &Frame<'_>, now: u64) {
        let h = f.header;
        if h.dst != self.cfg.local || h.src != self.cfg.peer {
            self.stats.foreign += 1;
            return;
        }
        self.stats.frames_received += 1;
        if let Some(e) = self.failed {
            self.stats.refused += 1;
            // Tell a peer that keeps trying why.
            if h.flags.contains(Flags::SYN) && matches!(e, LinkError::VersionMismatch { .. }) {
                self.rst_pending = true;
            }
            return;
        }
        if h.flags.contains(Flags::RST) {
            let e = match parse_versions(f.payload) {
                Some(theirs) if self.negotiate(theirs).is_none() => LinkError::VersionMismatch {
                    ours: (self.cfg.version_min, self.cfg.version_max),
                    theirs,
                },
                _ => LinkError::PeerReset,
            };
            self.fail(e);
            return;
        }
        if h.flags.contains(Flags::SYN) && !self.on_syn(f) {
            return;
        }
        if h.flags.contains(Flags::ACK) {
            self.on_ack(h.ack, h.flags, f.payload.is_empty(), now);
        }
        if h.flags.contains(Flags::DATA) && !h.flags.contains(Flags::SYN) {
            self.on_data(h.seq, h.port, f.payload);
        }
    }

    fn negotiate(&self, (min, max): (u16, u16)) -> Option<u16> {
        let v = self.cfg.version_max.min(max);
        (v >= self.cfg.version_min.max(min)).then_some(v)
    }

    /// Returns false if the frame must not be processed further.
    fn on_syn(&mut self, f: &Frame<'_>) -> bool {
        let Some(theirs) = parse_versions(f.payload) else {
            self.stats.refused += 1;
            return false;
        };
        let Some(version) = self.negotiate(theirs) else {
            self.fail(LinkError::VersionMismatch {
                ours: (self.cfg.version_min, self.cfg.version_max),
                theirs,
            });
            self.rst_pending = true;
            return false;
        };
        let isn = f.header.seq;
        match self.peer_isn {
            None => {
                self.peer_isn = Some(isn);
                self.rcv_nxt = isn.wrapping_add(1);
                self.version = version;
                let w = f.payload[4].clamp(1, WINDOW as u8) as u16;
                self.window = self.window.min(w);
            }
            Some(old) if old != isn => {
                self.fail(LinkError::PeerReset);
                self.rst_pending = true;
                return false;
            }
            Some(_) => self.stats.duplicates_dropped += 1,
        }
        // Answer with our SYN (carrying the ack) until ours is acknowledged,
        // else with a plain ack.
        self.ack_pending = true;
        if !self.syn_acked {
            self.synack_pending = true;
        }
        true
    }

    fn sample_rtt(&mut self, r: u64) {
        self.stats.rtt_samples += 1;
        self.stats.last_rtt_us = r;
        self.stats.min_rtt_us = if self.stats.rtt_samples == 1 {
            r
        } else {
            self.stats.min_rtt_us.min(r)
        };
        match self.srtt {
            None => {
                self.srtt = Some(r);
                self.rttvar = r / 2;
            }
            Some(srtt) => {
                self.rttvar = (3 * self.rttvar + srtt.abs_diff(r)) / 4;
                self.srtt = Some((7 * srtt + r) / 8);
            }
        }
        self.backoff = 0;
        self.stats.srtt_us = self.srtt.unwrap_or(0);
        self.stats.rttvar_us = self.rttvar;
        self.stats.rto_us = self.rto();
    }

    fn on_ack(&mut self, ack: u16, flags: Flags, empty: bool, now: u64) {
        if !self.syn_acked {
            if ack == self.cfg.isn.wrapping_add(1) && self.syn_sent_at.is_some() {
                self.syn_acked = true;
                self.synack_pending = false;
                if !self.syn_retransmitted {
                    if let Some(t) = self.syn_sent_at {
                        self.sample_rtt(now.saturating_sub(t));
                    }
                }
            }
            return;
        }
        let advance = diff(ack, self.snd_una);
        let in_flight = diff(self.snd_nxt, self.snd_una);
        if advance > 0 && advance <= in_flight {
            // Karn: sample only if no newly acked frame was retransmitted,
            // timing the newest of them.
            let mut clean = true;
            let mut s = self.snd_una;
            while s != ack {
                clean &= !self.tx[s as usize % WINDOW].retransmitted;
                s = s.wrapping_add(1);
            }
            if clean {
                let newest = self.tx[ack.wrapping_sub(1) as usize % WINDOW].sent_at;
                self.sample_rtt(now.saturating_sub(newest));
            }
            self.snd_una = ack;
            self.dup_acks = 0;
            if let Some(r) = self.recover {
                if diff(ack, r) >= 0 {
                    self.recover = None;
                } else {
                    // Partial ack: the next frame was lost too.
                    self.rtx_pending = true;
                }
            }
            self.rtx_deadline = (self.snd_una != self.snd_nxt).then(|| now + self.rto());
        } else if advance == 0
            && in_flight > 0
            && empty
            && !flags.contains(Flags::DATA)
            && self.recover.is_none()
        {
            self.dup_acks += 1;
            if self.dup_acks >= DUP_ACK_THRESHOLD {
                self.dup_acks = 0;
                self.rtx_pending = true;
                self.recover = Some(self.snd_nxt);
                self.stats.fast_retransmits += 1;
            }
        }
    }

    fn on_data(&mut self, seq: u16, port: u8, payload: &[u8]) {
        if self.peer_isn.is_none() {
            self.stats.refused += 1;
            return;
        }
        self.ack_pending = true;
        let d = diff(seq, self.rcv_nxt);
        if d < 0 {
            self.stats.duplicates_dropped += 1;
            return;
        }
        if d as usize >= WINDOW {
            self.stats.out_of_window += 1;
            return;
        }
        let slot = &mut self.rx[seq as usize % WINDOW];
        if slot.full {
            self.stats.duplicates_dropped += 1;
            return;
        }
        slot.full = true;
        slot.port = port;
        slot.len = payload.len() as u8;
        slot.data[..payload.len()].copy_from_slice(payload);
    }

    /// When [`Link::poll`] has something to do: `Some(0)` for at once, a
    /// deadline in µs, or `None` while there is nothing to wait for.
    pub fn next_timeout(&self) -> Option<u64> {
        if self.failed.is_some() {
            return self.rst_pending.then_some(0);
        }
        if self.synack_pending || self.ack_pending || self.rtx_pending {
            return Some(0);
        }
        if !self.syn_acked && (self.cfg.active || self.peer_isn.is_some()) {
            return Some(match self.syn_sent_at {
                None => 0,
                Some(t) => t + self.rto(),
            });
        }
        if self.established() && self.snd_nxt != self.snd_end {
            return Some(0);
        }
        self.rtx_deadline
    }

    fn emit<'o>(
        &mut self,
        flags: Flags,
        port: u8,
        seq: u16,
        payload_slot: Option<usize>,
        extra: &[u8],
        out: &'o mut [u8],
    ) -> Option<&'o [u8]> {
        let header = Header {
            dst: self.cfg.peer,
            src: self.cfg.local,
            port,
            flags,
            seq,
            ack: self.rcv_nxt,
        };
        let payload = match payload_slot {
            Some(i) => &self.tx[i].data[..self.tx[i].len as usize],
            None => extra,
        };
        let n = frame::encode(&header, payload, out).ok()?;
        if flags.contains(Flags::ACK) {
            self.ack_pending = false;
        }
        self.stats.frames_sent += 1;
        Some(&out[..n])
    }

    fn versions_payload(&self) -> [u8; 5] {
        let [a, b] = self.cfg.version_min.to_le_bytes();
        let [c, d] = self.cfg.version_max.to_le_bytes();
        [a, b, c, d, self.cfg.window]
    }

    /// The next frame to transmit, encoded into `out` (at least
    /// [`MAX_FRAME`] bytes), or `None`. Call until `None`.
    pub fn poll<'o>(&mut self, now: u64, out: &'o mut [u8]) -> Option<&'o [u8]> {
        debug_assert!(out.len() >= MAX_FRAME);
        if self.failed.is_some() {
            if !self.rst_pending {
                return None;
            }
            self.rst_pending = false;
            let p = self.versions_payload();
            let ack = if self.peer_isn.is_some() {
                Flags::ACK
            } else {
                Flags::NONE
            };
            return self.emit(Flags::RST | ack, LINK_PORT, self.snd_nxt, None, &p, out);
        }
        let ack = if self.peer_isn.is_some() {
            Flags::ACK
        } else {
            Flags::NONE
        };
        // Handshake.
        if !self.syn_acked && (self.cfg.active || self.peer_isn.is_some()) {
            let due = match self.syn_sent_at {
                None => true,
                Some(t) => now >= t + self.rto(),
            };
            if due || self.synack_pending {
                if self.syn_sent_at.is_some() {
                    self.syn_retransmitted = true;
                    self.stats.retransmits += 1;
                    if due {
                        self.backoff = (self.backoff + 1).min(MAX_BACKOFF);
                    }
                }
                self.syn_sent_at = Some(now);
                self.synack_pending = false;
                let p = self.versions_payload();
                return self.emit(Flags::SYN | ack, LINK_PORT, self.cfg.isn, None, &p, out);
            }
        }
        if self.established() {
            // Retransmission timer.
            if let Some(t) = self.rtx_deadline {
                if now >= t && self.snd_una != self.snd_nxt {
                    self.stats.timeouts += 1;
                    self.backoff = (self.backoff + 1).min(MAX_BACKOFF);
                    self.recover = Some(self.snd_nxt);
                    self.dup_acks = 0;
                    self.rtx_pending = true;
                }
            }
            if self.rtx_pending {
                self.rtx_pending = false;
                if self.snd_una != self.snd_nxt {
                    let seq = self.snd_una;
                    let i = seq as usize % WINDOW;
                    self.tx[i].retransmitted = true;
                    self.stats.retransmits += 1;
                    self.rtx_deadline = Some(now + self.rto());
                    self.stats.rto_us = self.rto();
                    let port = self.tx[i].port;
                    return self.emit(Flags::DATA | Flags::ACK, port, seq, Some(i), &[], out);
                }
            }
            // New data.
            if self.snd_nxt != self.snd_end && diff(self.snd_nxt, self.snd_una) < self.window as i16
            {
                let seq = self.snd_nxt;
                let i = seq as usize % WINDOW;
                self.tx[i].sent_at = now;
                self.snd_nxt = seq.wrapping_add(1);
                if self.rtx_deadline.is_none() {
                    self.rtx_deadline = Some(now + self.rto());
                }
                self.stats.payloads_sent += 1;
                let port = self.tx[i].port;
                return self.emit(Flags::DATA | Flags::ACK, port, seq, Some(i), &[], out);
            }
        }
        if self.ack_pending && self.peer_isn.is_some() {
            return self.emit(Flags::ACK, LINK_PORT, self.snd_nxt, None, &[], out);
        }
        self.ack_pending = false;
        None
    }
}

fn parse_versions(p: &[u8]) -> Option<(u16, u16)> {
    if p.len() < 5 {
        return None;
    }
    Some((
        u16::from_le_bytes([p[0], p[1]]),
        u16::from_le_bytes([p[2], p[3]]),
    ))
}
