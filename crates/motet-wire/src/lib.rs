//! The messages a host and its nodes exchange, and their byte encoding.
//!
//! Every message a node acts on arrives as bytes through [`decode`], even when the
//! node runs in the same process as the host, so a node never depends on anything
//! a real link could not carry. Messages are encoded with postcard (varint
//! integers, little-endian floats). Framing, addressing, checksums and reliable
//! delivery wrap these bytes on real links.
#![no_std]
#![forbid(unsafe_code)]

pub mod control;
pub mod describe;
pub mod frame;
pub mod group;
pub mod heater;
pub mod image;
pub mod link;
pub mod message;
mod refusal;
pub mod service;
pub mod stream;
pub mod sync;

pub use service::{ServiceError, ServiceReply, ServiceRequest};

pub use message::{
    AxisSpan, ChannelConfig, HostMessage, NodeMessage, Refusal, SegmentMsg, ToolConfig,
    MAX_MESSAGE, MAX_STEP_RATE,
};
pub use stream::{SegmentBatch, StreamConfig};

/// Why bytes could not be turned into a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WireError {
    /// The bytes do not decode as a message of the expected kind.
    Malformed,
    /// The message does not fit in the buffer given.
    TooLong,
}

impl core::fmt::Display for WireError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            WireError::Malformed => f.write_str("malformed message"),
            WireError::TooLong => f.write_str("message too long for the buffer"),
        }
    }
}

/// Encodes `msg` into `buf`, returning the bytes used.
pub fn encode<'a, T: serde::Serialize>(
    msg: &T,
    buf: &'a mut [u8],
) -> Result<&'a mut [u8], WireError> {
    postcard::to_slice(msg, buf).map_err(|_| WireError::TooLong)
}

/// Decodes one whole message from `bytes`; trailing bytes are an error.
pub fn decode<'a, T: serde::Deserialize<'a>>(bytes: &'a [u8]) -> Result<T, WireError> {
    match postcard::take_from_bytes(bytes) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(WireError::Malformed),
    }
}
