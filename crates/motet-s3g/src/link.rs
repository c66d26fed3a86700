//! The host's end of the serial line: one command at a time, its reply
//! read back, the protocol's retries, and flow control on the bot's
//! action buffer.
//!
//! S3G carries no sequence numbers, so a lost reply to an action cannot be
//! told from a lost action: resending might run it twice. The link
//! resends only what the bot said it discarded (0x80, 0x83, 0x8C) or had
//! no room for (0x82), and queries, which change nothing; an action whose
//! reply never comes or comes corrupted stops the run with an error.

use crate::command::{Command, CommandError};
use crate::decoder::{Decoded, Decoder};
use crate::packet::{encode, PacketError};
use crate::reply::{Reply, ReplyCode, ShortReply};
use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

/// Why the link gave up.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The serial port failed.
    #[error("serial port: {0}")]
    Io(#[from] std::io::Error),
    /// The command could not be encoded.
    #[error(transparent)]
    Command(#[from] CommandError),
    /// The payload could not be framed.
    #[error(transparent)]
    Packet(#[from] PacketError),
    /// No reply at all.
    #[error("the bot stopped answering: no reply to command {code} ({name}) within {waited_s:.1} s{tries}",
        tries = if *.tries > 1 { format!(", {} tries", .tries) } else { String::new() })]
    Silent {
        /// The command.
        code: u8,
        /// Its name.
        name: &'static str,
        /// Seconds waited for the last try.
        waited_s: f64,
        /// How many times it was sent.
        tries: u32,
    },
    /// An action's reply arrived unreadable: the bot may or may not have
    /// queued it.
    #[error("the reply to command {code} ({name}) arrived corrupted (CRC mismatch): S3G cannot tell whether the bot queued it, so motet stops rather than risk running it twice")]
    LostActionReply {
        /// The command.
        code: u8,
        /// Its name.
        name: &'static str,
    },
    /// A query's replies arrived corrupted every time.
    #[error(
        "the replies to command {code} ({name}) arrived corrupted (CRC mismatch) {tries} times"
    )]
    Garbled {
        /// The command.
        code: u8,
        /// Its name.
        name: &'static str,
        /// How many times it was sent.
        tries: u32,
    },
    /// The bot refused with a code that is not retried.
    #[error("the bot answered command {code} ({name}) with {reply}")]
    Refused {
        /// The command.
        code: u8,
        /// Its name.
        name: &'static str,
        /// The reply code.
        reply: ReplyCode,
    },
    /// Discarded every time.
    #[error("the bot discarded command {code} ({name}) {tries} times, last with {reply}")]
    TooManyRetries {
        /// The command.
        code: u8,
        /// Its name.
        name: &'static str,
        /// The last reply code.
        reply: ReplyCode,
        /// Tries.
        tries: u32,
    },
    /// A reply shorter than its answer.
    #[error("the reply to command {code} ({name}): {error}")]
    Short {
        /// The command.
        code: u8,
        /// Its name.
        name: &'static str,
        /// What was missing.
        error: ShortReply,
    },
}

/// How long to wait for more after a frame that failed its CRC.
const AFTER_BAD_FRAME: Duration = Duration::from_millis(50);

/// What the link saw, for the run's report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Packets written, resends included.
    pub packets: u64,
    /// Actions the bot took.
    pub actions: u64,
    /// Resends after 0x80, 0x83 or 0x8C, or of a query after a bad reply.
    pub resends: u64,
    /// 0x82 replies (each followed by waiting for room).
    pub buffer_full: u64,
    /// Buffer-size queries.
    pub polls: u64,
    /// Reply frames with a bad CRC.
    pub crc_errors: u64,
    /// Bytes skipped between replies.
    pub noise_bytes: u64,
}

/// Timing of the link.
#[derive(Debug, Clone, Copy)]
pub struct LinkConfig {
    /// How long a reply may take.
    pub reply_timeout: Duration,
    /// Sends of one command before giving up.
    pub tries: u32,
    /// Sends of a query that met silence (no reply frame at all) before
    /// giving up: a bot that says nothing twice is gone.
    pub silent_tries: u32,
    /// Pause between buffer-size polls while the buffer is full.
    pub poll_interval: Duration,
}

impl Default for LinkConfig {
    fn default() -> LinkConfig {
        LinkConfig {
            reply_timeout: Duration::from_secs(2),
            tries: 5,
            silent_tries: 2,
            poll_interval: Duration::from_millis(5),
        }
    }
}

/// A bot on a byte stream whose reads time out (a serial port).
pub struct Link<P> {
    port: P,
    decoder: Decoder,
    config: LinkConfig,
    /// Free bytes in the bot's action buffer as last known, less the
    /// actions sent since.
    free: u32,
    stats: LinkStats,
}

fn name(code: u8) -> &'static str {
    crate::command::describe(code).map_or("?", |d| d.1)
}

impl<P: Read + Write> Link<P> {
    /// A link on a port; reads on it must time out after a short while.
    pub fn new(port: P, config: LinkConfig) -> Link<P> {
        Link {
            port,
            decoder: Decoder::new(),
            config,
            free: 0,
            stats: LinkStats::default(),
        }
    }

    /// What the link saw so far.
    pub fn stats(&self) -> LinkStats {
        let mut s = self.stats;
        s.crc_errors = self.decoder.crc_errors;
        s.noise_bytes = self.decoder.skipped;
        s
    }

    /// Sends a query and returns the bot's answer; resent (it changes
    /// nothing) until answered, up to the configured tries.
    pub fn query(&mut self, cmd: &Command) -> Result<Reply, LinkError> {
        debug_assert!(!cmd.is_action());
        self.transact(cmd, &mut |_| Ok(()))
    }

    /// Sends an action once the bot has room for it. `idle` runs while
    /// waiting for room (the driver polls temperatures there).
    pub fn action(
        &mut self,
        cmd: &Command,
        idle: &mut dyn FnMut(&mut Link<P>) -> Result<(), LinkError>,
    ) -> Result<(), LinkError> {
        let len = cmd.encode()?.len() as u32;
        self.wait_room(len, idle)?;
        self.transact(cmd, idle)?;
        self.free = self.free.saturating_sub(len);
        self.stats.actions += 1;
        Ok(())
    }

    /// Free bytes in the action buffer, asked of the bot.
    pub fn buffer_free(&mut self) -> Result<u32, LinkError> {
        self.stats.polls += 1;
        let r = self.query(&Command::GetBufferSize)?;
        let free = r.u32().map_err(|error| LinkError::Short {
            code: 2,
            name: name(2),
            error,
        })?;
        self.free = free;
        Ok(free)
    }

    /// Polls the buffer until `len` bytes fit (the blog's flow control).
    fn wait_room(
        &mut self,
        len: u32,
        idle: &mut dyn FnMut(&mut Link<P>) -> Result<(), LinkError>,
    ) -> Result<(), LinkError> {
        while self.free < len {
            if self.buffer_free()? >= len {
                break;
            }
            idle(self)?;
            std::thread::sleep(self.config.poll_interval);
        }
        Ok(())
    }

    fn transact(
        &mut self,
        cmd: &Command,
        idle: &mut dyn FnMut(&mut Link<P>) -> Result<(), LinkError>,
    ) -> Result<Reply, LinkError> {
        let payload = cmd.encode()?;
        let packet = encode(&payload)?;
        let code = payload[0];
        let (mut tries, mut silences) = (0, 0);
        loop {
            tries += 1;
            self.port.write_all(&packet)?;
            self.port.flush()?;
            self.stats.packets += 1;
            let crc_before = self.decoder.crc_errors;
            let reply = self.read_reply()?;
            let reply = match reply {
                Some(r) => r,
                None if cmd.is_action() && self.decoder.crc_errors > crc_before => {
                    return Err(LinkError::LostActionReply {
                        code,
                        name: name(code),
                    })
                }
                None if self.decoder.crc_errors == crc_before => {
                    silences += 1;
                    if cmd.is_action() || silences >= self.config.silent_tries {
                        return Err(LinkError::Silent {
                            code,
                            name: name(code),
                            waited_s: self.config.reply_timeout.as_secs_f64(),
                            tries,
                        });
                    }
                    self.stats.resends += 1;
                    continue;
                }
                None if tries >= self.config.tries => {
                    return Err(LinkError::Garbled {
                        code,
                        name: name(code),
                        tries,
                    })
                }
                None => {
                    self.stats.resends += 1;
                    continue;
                }
            };
            match reply.code {
                ReplyCode::Success => return Ok(reply),
                ReplyCode::BufferFull => {
                    // Discarded for want of room: wait for it, then send
                    // again (not a try: the bot is only busy).
                    self.stats.buffer_full += 1;
                    tries -= 1;
                    self.free = 0;
                    let len = payload.len() as u32;
                    self.wait_room(len, idle)?;
                }
                c if c.discarded_retry() && tries < self.config.tries => {
                    self.stats.resends += 1;
                }
                c if c.discarded_retry() => {
                    return Err(LinkError::TooManyRetries {
                        code,
                        name: name(code),
                        reply: c,
                        tries,
                    })
                }
                c => {
                    return Err(LinkError::Refused {
                        code,
                        name: name(code),
                        reply: c,
                    })
                }
            }
        }
    }

    /// The next good reply packet, or `None` when none came in time, or
    /// when a frame failed its CRC and nothing followed it for
    /// [`AFTER_BAD_FRAME`] (the bot sends one reply per packet: waiting
    /// longer is waiting for nothing).
    fn read_reply(&mut self) -> Result<Option<Reply>, LinkError> {
        let deadline = Instant::now() + self.config.reply_timeout;
        let mut buf = [0u8; 64];
        let mut found = Vec::new();
        let mut bad_at: Option<Instant> = None;
        while Instant::now() < deadline {
            if bad_at.is_some_and(|t| t.elapsed() > AFTER_BAD_FRAME) && !self.decoder.in_frame() {
                break;
            }
            let n = match self.port.read(&mut buf) {
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) =>
                {
                    0
                }
                Err(e) => return Err(e.into()),
            };
            self.decoder.push(&buf[..n], &mut found);
            if let Some(p) = found.iter().find_map(|d| match d {
                Decoded::Packet(p) => Some(p),
                Decoded::CrcMismatch { .. } => None,
            }) {
                return Ok(Some(Reply::from_payload(p)));
            }
            if !found.is_empty() {
                bad_at = Some(Instant::now());
            }
            found.clear();
        }
        // A partial frame left now would swallow the next reply's start.
        self.decoder.reset();
        Ok(None)
    }
}
