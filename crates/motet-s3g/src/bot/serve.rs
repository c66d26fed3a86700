//! The simulated bot on a byte stream (a pseudo-terminal): packets in,
//! replies out, faults injected as asked, the points it runs reported.

use super::faults::Faults;
use super::{Bot, Executed};
use crate::decoder::{Decoded, Decoder};
use crate::packet::encode;
use crate::reply::{Reply, ReplyCode};
use std::io::{ErrorKind, Read, Write};

/// What the bot's line saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LineStats {
    /// Good packets received.
    pub packets: u64,
    /// Frames with a bad CRC received.
    pub crc_errors: u64,
    /// Replies sent.
    pub replies: u64,
    /// Faults injected.
    pub faults: u64,
}

/// The bot and its line.
pub struct Served {
    /// The bot.
    pub bot: Bot,
    faults: Faults,
    decoder: Decoder,
    /// What the line saw.
    pub stats: LineStats,
}

impl Served {
    /// A bot with faults.
    pub fn new(bot: Bot, faults: Faults) -> Served {
        Served {
            bot,
            faults,
            decoder: Decoder::new(),
            stats: LineStats::default(),
        }
    }

    /// Handles bytes that arrived at `now` (µs on the bot's clock); the
    /// bytes to send back are appended to `out`.
    pub fn on_bytes(&mut self, bytes: &[u8], now: f64, out: &mut Vec<u8>) {
        let mut found = Vec::new();
        self.decoder.push(bytes, &mut found);
        for d in found {
            let reply = match d {
                Decoded::CrcMismatch { .. } => {
                    self.stats.crc_errors += 1;
                    Some(Reply::new(ReplyCode::CrcMismatch, vec![]))
                }
                Decoded::Packet(p) => {
                    self.stats.packets += 1;
                    self.packet(&p, now)
                }
            };
            if let Some(r) = reply {
                self.send(&r, out);
            }
        }
    }

    /// The reply to one good packet, faults applied; `None` when silent.
    fn packet(&mut self, p: &[u8], now: f64) -> Option<Reply> {
        let n = self.stats.packets;
        let f = self.faults;
        if f.silent_after.is_some_and(|s| n > s) {
            self.stats.faults += 1;
            return None;
        }
        let fault = |code| Some(Reply::new(code, vec![]));
        if f.cancel_after.is_some_and(|s| n > s) {
            self.stats.faults += 1;
            return fault(ReplyCode::Cancelled);
        }
        let is_action = p[0] >= 128;
        if Faults::hits(f.crc, n) {
            self.stats.faults += 1;
            return fault(ReplyCode::CrcMismatch);
        }
        if Faults::hits(f.generic, n) {
            self.stats.faults += 1;
            return fault(ReplyCode::Generic);
        }
        if is_action && Faults::hits(f.full, n) {
            self.stats.faults += 1;
            return fault(ReplyCode::BufferFull);
        }
        Some(self.bot.on_packet(p, now))
    }

    fn send(&mut self, r: &Reply, out: &mut Vec<u8>) {
        let n = self.stats.replies + 1;
        self.stats.replies = n;
        if Faults::hits(self.faults.garbage, n) {
            // Noise with a false start whose length swallows the reply's
            // first bytes: the host's decoder must find its way back. The
            // false frame's CRC never matches what follows it here (a
            // reply's length and code byte).
            self.stats.faults += 1;
            out.extend_from_slice(&[0x00, 0xFF, 0xD5, 0x03, 0x17]);
        }
        let Ok(mut bytes) = encode(&r.payload()) else {
            return;
        };
        let query_reply = r.code == ReplyCode::Success && !r.body.is_empty();
        let ack = r.code == ReplyCode::Success && r.body.is_empty();
        if (query_reply && Faults::hits(self.faults.reply_crc, n))
            || (ack && Faults::hits(self.faults.ack_crc, n))
        {
            self.stats.faults += 1;
            if let Some(c) = bytes.last_mut() {
                *c ^= 0x5A;
            }
        }
        out.extend_from_slice(&bytes);
    }
}

/// Runs a bot on a port until `keep_going` says stop: `now` gives the
/// bot's clock in µs, `report` gets each point as it is run.
pub fn serve<P: Read + Write>(
    served: &mut Served,
    port: &mut P,
    now: &mut dyn FnMut() -> f64,
    report: &mut dyn FnMut(&Executed, &Served) -> std::io::Result<()>,
    keep_going: &mut dyn FnMut(&Served) -> bool,
) -> std::io::Result<()> {
    let mut buf = [0u8; 256];
    let mut out = Vec::new();
    while keep_going(served) {
        let n = match port.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                ) =>
            {
                0
            }
            Err(e) => return Err(e),
        };
        let t = now();
        served.on_bytes(&buf[..n], t, &mut out);
        if !out.is_empty() {
            port.write_all(&out)?;
            port.flush()?;
            out.clear();
        }
        served.bot.advance(t);
        let new: Vec<Executed> = served.bot.executed.drain(..).collect();
        for e in &new {
            report(e, served)?;
        }
    }
    Ok(())
}
