//! Packet framing: `0xD5`, length, payload, CRC-8 of the payload.

use crate::crc8::crc8;

/// The byte every packet starts with.
pub const START: u8 = 0xD5;

/// The longest payload a bot takes (its packet buffer); replies are no
/// longer either.
pub const MAX_PAYLOAD: usize = 32;

/// Why a payload cannot be framed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PacketError {
    /// Every packet carries at least its command or reply code.
    #[error("empty S3G payload")]
    Empty,
    /// Longer than [`MAX_PAYLOAD`].
    #[error("S3G payload of {0} bytes: at most {MAX_PAYLOAD}")]
    TooLong(usize),
}

/// Frames a payload into a packet.
pub fn encode(payload: &[u8]) -> Result<Vec<u8>, PacketError> {
    if payload.is_empty() {
        return Err(PacketError::Empty);
    }
    if payload.len() > MAX_PAYLOAD {
        return Err(PacketError::TooLong(payload.len()));
    }
    let mut out = Vec::with_capacity(payload.len() + 3);
    out.push(START);
    out.push(payload.len() as u8);
    out.extend_from_slice(payload);
    out.push(crc8(payload));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_and_refuses() {
        // Get buffer size, as gpx sends it: D5 01 02 CRC.
        assert_eq!(encode(&[2]).unwrap(), vec![0xD5, 1, 2, crc8(&[2])]);
        assert_eq!(encode(&[]), Err(PacketError::Empty));
        assert_eq!(encode(&[0; 33]), Err(PacketError::TooLong(33)));
    }
}
