//! Replies, bot to host: a response code, then the query's answer.

/// The reply's first byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplyCode {
    /// 0x80: generic packet error, packet discarded: send it again.
    Generic,
    /// 0x81: done (an action queued, a query answered).
    Success,
    /// 0x82: the action buffer is full, packet discarded: send it later.
    BufferFull,
    /// 0x83: the packet's CRC did not match, packet discarded: send it again.
    CrcMismatch,
    /// 0x84: query too big.
    QueryTooBig,
    /// 0x85: command not supported.
    NotSupported,
    /// 0x87: downstream (tool board) timeout.
    DownstreamTimeout,
    /// 0x88: tool lock timeout.
    ToolLockTimeout,
    /// 0x89: the build was cancelled on the bot.
    Cancelled,
    /// 0x8A: the bot is building from its SD card.
    BuildingFromSd,
    /// 0x8B: the bot shut down for overheating.
    Overheat,
    /// 0x8C: packet timeout, packet discarded: send it again.
    PacketTimeout,
    /// A code the protocol does not define.
    Unknown(u8),
}

impl ReplyCode {
    /// The code of a reply byte.
    pub fn from_byte(b: u8) -> ReplyCode {
        use ReplyCode::*;
        match b {
            0x80 => Generic,
            0x81 => Success,
            0x82 => BufferFull,
            0x83 => CrcMismatch,
            0x84 => QueryTooBig,
            0x85 => NotSupported,
            0x87 => DownstreamTimeout,
            0x88 => ToolLockTimeout,
            0x89 => Cancelled,
            0x8A => BuildingFromSd,
            0x8B => Overheat,
            0x8C => PacketTimeout,
            b => Unknown(b),
        }
    }

    /// The reply byte.
    pub fn byte(self) -> u8 {
        use ReplyCode::*;
        match self {
            Generic => 0x80,
            Success => 0x81,
            BufferFull => 0x82,
            CrcMismatch => 0x83,
            QueryTooBig => 0x84,
            NotSupported => 0x85,
            DownstreamTimeout => 0x87,
            ToolLockTimeout => 0x88,
            Cancelled => 0x89,
            BuildingFromSd => 0x8A,
            Overheat => 0x8B,
            PacketTimeout => 0x8C,
            Unknown(b) => b,
        }
    }

    /// Whether the bot discarded the packet and it may be sent again
    /// unchanged: it was not acted on.
    pub fn discarded_retry(self) -> bool {
        matches!(
            self,
            ReplyCode::Generic | ReplyCode::CrcMismatch | ReplyCode::PacketTimeout
        )
    }
}

impl std::fmt::Display for ReplyCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use ReplyCode::*;
        let what = match self {
            Generic => "generic packet error",
            Success => "success",
            BufferFull => "action buffer full",
            CrcMismatch => "CRC mismatch",
            QueryTooBig => "query too big",
            NotSupported => "command not supported",
            DownstreamTimeout => "downstream timeout",
            ToolLockTimeout => "tool lock timeout",
            Cancelled => "build cancelled on the bot",
            BuildingFromSd => "the bot is building from its SD card",
            Overheat => "the bot shut down for overheating",
            PacketTimeout => "packet timeout",
            Unknown(_) => "unknown reply code",
        };
        write!(f, "0x{:02X} ({what})", self.byte())
    }
}

/// A reply: its code and the answer after it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reply {
    /// The response code.
    pub code: ReplyCode,
    /// The bytes after the code.
    pub body: Vec<u8>,
}

/// A reply too short for the answer asked of it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("reply of {got} bytes where {want} were expected")]
pub struct ShortReply {
    /// Body bytes present.
    pub got: usize,
    /// Bytes needed.
    pub want: usize,
}

impl Reply {
    /// A reply from a packet's payload (never empty: the decoder refuses
    /// empty packets).
    pub fn from_payload(p: &[u8]) -> Reply {
        Reply {
            code: ReplyCode::from_byte(p.first().copied().unwrap_or(0)),
            body: p.get(1..).unwrap_or_default().to_vec(),
        }
    }

    /// A reply with a code and body.
    pub fn new(code: ReplyCode, body: Vec<u8>) -> Reply {
        Reply { code, body }
    }

    /// The payload to frame.
    pub fn payload(&self) -> Vec<u8> {
        let mut p = vec![self.code.byte()];
        p.extend_from_slice(&self.body);
        p
    }

    fn bytes<const N: usize>(&self) -> Result<[u8; N], ShortReply> {
        self.body
            .get(..N)
            .and_then(|b| b.try_into().ok())
            .ok_or(ShortReply {
                got: self.body.len(),
                want: N,
            })
    }

    /// The body as a u8.
    pub fn u8(&self) -> Result<u8, ShortReply> {
        Ok(self.bytes::<1>()?[0])
    }

    /// The body as a little-endian i16 (temperatures).
    pub fn i16(&self) -> Result<i16, ShortReply> {
        Ok(i16::from_le_bytes(self.bytes()?))
    }

    /// The body as a little-endian u16 (versions).
    pub fn u16(&self) -> Result<u16, ShortReply> {
        Ok(u16::from_le_bytes(self.bytes()?))
    }

    /// The body as a little-endian u32 (buffer size).
    pub fn u32(&self) -> Result<u32, ShortReply> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }

    /// The body as five little-endian i32 (position, steps).
    pub fn steps(&self) -> Result<[i32; 5], ShortReply> {
        let b: [u8; 20] = self.bytes()?;
        Ok(std::array::from_fn(|i| {
            i32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
        }))
    }
}
