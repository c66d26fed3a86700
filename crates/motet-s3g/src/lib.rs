//! S3G, the serial protocol of MakerBot bots and their Sailfish firmware,
//! for motet: packets (framing, CRC-8, a decoder that finds its way back
//! after noise), the host commands and replies a print needs, X3G command
//! streams (what `gpx` writes), a host driver that runs motet's plan on a
//! bot as queued points with durations, and a simulated bot that executes
//! the packets.
//!
//! Facts from the protocol's documentation as `gpx` implements it: a packet
//! is `0xD5`, the payload's length, the payload, then the CRC-8
//! (Dallas/Maxim) of the payload; integers are little-endian; payload byte
//! 0 is the command, 0–127 queries answered at once, 128–255 actions the
//! bot acknowledges and queues.

pub mod bot;
pub mod check;
pub mod command;
pub mod crc8;
pub mod decoder;
pub mod driver;
pub mod link;
pub mod packet;
pub mod points;
pub mod reply;
pub mod stream;
pub mod tool;

pub use command::{Command, CommandError};
pub use decoder::{Decoded, Decoder};
pub use packet::{encode, PacketError, MAX_PAYLOAD, START};
pub use reply::{Reply, ReplyCode};
