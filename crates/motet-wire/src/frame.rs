//! Framing: addressing, ports, sequence numbers, a CRC-32C and COBS byte stuffing.
//!
//! A frame before stuffing (all integers little-endian):
//!
//! | byte | field |
//! |---|---|
//! | 0 | format version (high nibble, [`FORMAT_VERSION`]) and flags (low nibble, [`Flags`]) |
//! | 1–2 | destination address (u16) |
//! | 3–4 | source address (u16) |
//! | 5 | port: the service routine the payload is for |
//! | 6–7 | sequence number (u16) |
//! | 8–9 | acknowledgement number (u16): next sequence number expected from the peer |
//! | 10.. | payload, 0 to [`MAX_PAYLOAD`] bytes |
//! | last 4 | CRC-32C (Castagnoli) over bytes 0..10+payload |
//!
//! The whole is COBS-encoded (no 0x00 inside) and followed by one 0x00
//! delimiter, so a receiver finds frame boundaries in any byte stream and
//! resynchronises at the next 0x00 after garbage. The payload length is implied
//! by the frame length. Overhead: 10 header + 4 CRC + 1 COBS + 1 delimiter = 16
//! bytes per frame ([`OVERHEAD`]); the largest frame is [`MAX_FRAME`] = 208 bytes.
//!
//! Why CRC-32C rather than CRC-16/CCITT: frames are up to 206 bytes (1648 bits)
//! before stuffing. CRC-32C has Hamming distance 6 up to 5243 bits and catches
//! every burst up to 32 bits, against HD 4 and 16-bit bursts for CRC-16. More
//! important in practice, USB full-speed and CAN-FD already check each packet
//! with their own CRC, so the errors that reach this layer are not bit flips but
//! lost, repeated or spliced chunks (a CDC buffer overrun, a transport that
//! drops a 64-byte packet, a resynchronisation mid-frame). Those behave like
//! random data, which a 16-bit check passes once in 65 536 and a 32-bit check
//! once in 4.3·10⁹. Two more bytes per frame (about 1 % of a full frame) buy
//! that. CRC-32C is also the polynomial of iSCSI/ext4/SCTP, with hardware on many
//! MCUs, and is computed here from a 1 KiB table.
//!
//! Transports: USB full-speed CDC carries the stuffed byte stream as is (a
//! 208-byte frame is four 64-byte bulk packets; a short packet or the 0x00 ends
//! nothing by itself, the delimiter does). A CAN-FD transport splits the stuffed
//! stream into 64-byte CAN frames on one identifier per sender; CAN keeps them
//! in order per identifier, and the 0x00 delimiter marks the end of the motet
//! frame, so no fragment header is needed (a lost CAN frame shows up here as a
//! bad CRC or bad COBS and is repaired by the link's retransmission).

use crate::MAX_MESSAGE;

/// Frame format version carried in the high nibble of byte 0.
pub const FORMAT_VERSION: u8 = 1;
/// Largest payload: one encoded message.
pub const MAX_PAYLOAD: usize = MAX_MESSAGE;
/// Header bytes before the payload.
pub const HEADER_LEN: usize = 10;
/// CRC bytes after the payload.
pub const CRC_LEN: usize = 4;
/// Largest frame before COBS stuffing.
pub const MAX_RAW: usize = HEADER_LEN + MAX_PAYLOAD + CRC_LEN;
/// Largest COBS-encoded frame without its delimiter (one code byte per 254 bytes).
pub const MAX_ENCODED: usize = MAX_RAW + MAX_RAW / 254 + 1;
/// Largest frame on the wire, delimiter included: 208 bytes, four USB
/// full-speed bulk packets or four CAN-FD frames.
pub const MAX_FRAME: usize = MAX_ENCODED + 1;
/// Bytes a frame adds to its payload on the wire (header, CRC, COBS code byte,
/// delimiter) for payloads up to [`MAX_PAYLOAD`].
pub const OVERHEAD: usize = HEADER_LEN + CRC_LEN + 2;

/// Address of every node: multicast to all.
pub const BROADCAST: u16 = 0xFFFF;
/// First group multicast address.
pub const GROUP_FIRST: u16 = 0xFFF0;
/// Last group multicast address.
pub const GROUP_LAST: u16 = 0xFFFE;

/// True for the broadcast address and the group multicast addresses.
pub const fn is_multicast(addr: u16) -> bool {
    addr >= GROUP_FIRST
}

/// Frame flags, the low nibble of byte 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Flags(u8);

impl Flags {
    /// The acknowledgement number is valid.
    pub const ACK: Flags = Flags(0x01);
    /// Connection request: the payload carries the protocol version range
    /// and the sequence number is the sender's initial sequence number.
    pub const SYN: Flags = Flags(0x02);
    /// The sender refuses or has forgotten the connection.
    pub const RST: Flags = Flags(0x04);
    /// The payload is sequenced: the receiver delivers it in order, once, and acknowledges it.
    pub const DATA: Flags = Flags(0x08);
    /// No flags.
    pub const NONE: Flags = Flags(0);

    /// Flags from the low nibble of `bits`.
    pub const fn from_bits(bits: u8) -> Flags {
        Flags(bits & 0x0F)
    }
    /// The flags as the header's low nibble carries them.
    pub const fn bits(self) -> u8 {
        self.0
    }
    /// Whether every flag of `other` is set.
    pub const fn contains(self, other: Flags) -> bool {
        self.0 & other.0 == other.0
    }
    /// Both sets of flags (as `|`).
    pub const fn union(self, other: Flags) -> Flags {
        Flags(self.0 | other.0)
    }
}

impl core::ops::BitOr for Flags {
    type Output = Flags;
    fn bitor(self, rhs: Flags) -> Flags {
        self.union(rhs)
    }
}

/// Everything in a frame but its payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Header {
    /// Destination address ([`HOST_ADDRESS`](crate::service::HOST_ADDRESS), a node's, or a
    /// multicast one).
    pub dst: u16,
    /// Source address: the sender's.
    pub src: u16,
    /// Service port of the payload (see [`crate::service::port`]); the link's own frames use port
    /// 0.
    pub port: u8,
    /// What the frame carries: data, an acknowledgement, a SYN or an RST.
    pub flags: Flags,
    /// Sequence number of this frame's payload (with [`Flags::DATA`]) or the
    /// initial sequence number (with [`Flags::SYN`]); serial-number arithmetic
    /// modulo 2¹⁶.
    pub seq: u16,
    /// With [`Flags::ACK`]: every sequence number before this one was received.
    pub ack: u16,
}

/// A decoded frame; the payload borrows the caller's buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame<'a> {
    /// The frame's header.
    pub header: Header,
    /// The payload bytes (borrowed from the decode buffer).
    pub payload: &'a [u8],
}

/// Why bytes are not a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameError {
    /// The checksum does not match.
    BadCrc,
    /// Longer than [`MAX_FRAME`], or the output buffer is too small.
    TooLong,
    /// Not valid COBS: a zero inside, or a block that runs past the end.
    BadCobs,
    /// Shorter than a header and a CRC.
    Truncated,
    /// The CRC is good but the format version is not [`FORMAT_VERSION`].
    UnknownVersion,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FrameError::BadCrc => "frame CRC mismatch",
            FrameError::TooLong => "frame too long",
            FrameError::BadCobs => "invalid COBS encoding",
            FrameError::Truncated => "frame truncated",
            FrameError::UnknownVersion => "unknown frame format version",
        })
    }
}

const CRC32C_POLY: u32 = 0x82F6_3B78; // reflected 0x1EDC6F41

const fn crc_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ CRC32C_POLY
            } else {
                c >> 1
            };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

static CRC_TABLE: [u32; 256] = crc_table();

/// Running CRC-32C (reflected, init and final XOR 0xFFFFFFFF).
#[derive(Clone, Copy, Debug)]
pub struct Crc32c(u32);

impl Default for Crc32c {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32c {
    /// A CRC over no bytes yet.
    pub const fn new() -> Crc32c {
        Crc32c(0xFFFF_FFFF)
    }
    /// Takes `bytes` in, after those already taken.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut c = self.0;
        for &b in bytes {
            c = CRC_TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
        }
        self.0 = c;
    }
    /// The CRC of every byte taken.
    pub const fn finish(self) -> u32 {
        self.0 ^ 0xFFFF_FFFF
    }
}

/// CRC-32C of `bytes`; `crc32c(b"123456789") == 0xE306_9283`.
pub fn crc32c(bytes: &[u8]) -> u32 {
    let mut c = Crc32c::new();
    c.update(bytes);
    c.finish()
}

impl Header {
    /// The 10 header bytes.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let [d0, d1] = self.dst.to_le_bytes();
        let [s0, s1] = self.src.to_le_bytes();
        let [q0, q1] = self.seq.to_le_bytes();
        let [a0, a1] = self.ack.to_le_bytes();
        [
            (FORMAT_VERSION << 4) | self.flags.bits(),
            d0,
            d1,
            s0,
            s1,
            self.port,
            q0,
            q1,
            a0,
            a1,
        ]
    }

    fn from_bytes(b: &[u8]) -> Header {
        Header {
            flags: Flags::from_bits(b[0]),
            dst: u16::from_le_bytes([b[1], b[2]]),
            src: u16::from_le_bytes([b[3], b[4]]),
            port: b[5],
            seq: u16::from_le_bytes([b[6], b[7]]),
            ack: u16::from_le_bytes([b[8], b[9]]),
        }
    }
}

/// COBS encoder writing into a slice.
struct CobsWriter<'a> {
    out: &'a mut [u8],
    code_at: usize,
    pos: usize,
    code: u8,
}

impl<'a> CobsWriter<'a> {
    fn new(out: &'a mut [u8]) -> Result<Self, FrameError> {
        if out.is_empty() {
            return Err(FrameError::TooLong);
        }
        Ok(CobsWriter {
            out,
            code_at: 0,
            pos: 1,
            code: 1,
        })
    }

    fn close_block(&mut self) -> Result<(), FrameError> {
        self.out[self.code_at] = self.code;
        self.code_at = self.pos;
        self.pos += 1;
        self.code = 1;
        if self.code_at >= self.out.len() {
            return Err(FrameError::TooLong);
        }
        Ok(())
    }

    fn push(&mut self, b: u8) -> Result<(), FrameError> {
        if b == 0 {
            return self.close_block();
        }
        *self.out.get_mut(self.pos).ok_or(FrameError::TooLong)? = b;
        self.pos += 1;
        self.code += 1;
        if self.code == 0xFF {
            self.close_block()?;
        }
        Ok(())
    }

    fn extend(&mut self, bytes: &[u8]) -> Result<(), FrameError> {
        bytes.iter().try_for_each(|&b| self.push(b))
    }

    /// Writes the last code byte and the delimiter; returns the length.
    fn finish(self) -> Result<usize, FrameError> {
        self.out[self.code_at] = self.code;
        *self.out.get_mut(self.pos).ok_or(FrameError::TooLong)? = 0;
        Ok(self.pos + 1)
    }
}

/// Encodes a frame into `out` (COBS, with the trailing 0x00 delimiter) and
/// returns the bytes used. `out` of [`MAX_FRAME`] bytes always suffices.
pub fn encode(header: &Header, payload: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    if payload.len() > MAX_PAYLOAD {
        return Err(FrameError::TooLong);
    }
    let head = header.to_bytes();
    let mut crc = Crc32c::new();
    crc.update(&head);
    crc.update(payload);
    let crc = crc.finish().to_le_bytes();
    let mut w = CobsWriter::new(out)?;
    w.extend(&head)?;
    w.extend(payload)?;
    w.extend(&crc)?;
    w.finish()
}

/// Undoes COBS from `src` into `dst`; returns the decoded length. `src` holds
/// no delimiter. `dst` may not be shorter than the decoded bytes.
fn cobs_decode(src: &[u8], dst: &mut [u8]) -> Result<usize, FrameError> {
    let mut i = 0;
    let mut o = 0;
    while i < src.len() {
        let code = src[i] as usize;
        if code == 0 {
            return Err(FrameError::BadCobs);
        }
        i += 1;
        let n = code - 1;
        let block = src.get(i..i + n).ok_or(FrameError::BadCobs)?;
        if block.contains(&0) {
            return Err(FrameError::BadCobs);
        }
        dst.get_mut(o..o + n)
            .ok_or(FrameError::TooLong)?
            .copy_from_slice(block);
        o += n;
        i += n;
        if code != 0xFF && i < src.len() {
            *dst.get_mut(o).ok_or(FrameError::TooLong)? = 0;
            o += 1;
        }
    }
    Ok(o)
}

/// Undoes COBS in place (the output is never longer than the input).
fn cobs_decode_in_place(buf: &mut [u8]) -> Result<usize, FrameError> {
    let mut i = 0;
    let mut o = 0;
    while i < buf.len() {
        let code = buf[i] as usize;
        if code == 0 {
            return Err(FrameError::BadCobs);
        }
        i += 1;
        let n = code - 1;
        if i + n > buf.len() || buf[i..i + n].contains(&0) {
            return Err(FrameError::BadCobs);
        }
        buf.copy_within(i..i + n, o);
        o += n;
        i += n;
        if code != 0xFF && i < buf.len() {
            buf[o] = 0;
            o += 1;
        }
    }
    Ok(o)
}

/// Checks a de-stuffed frame and splits it into header and payload.
fn parse(raw: &[u8]) -> Result<Frame<'_>, FrameError> {
    if raw.len() < HEADER_LEN + CRC_LEN {
        return Err(FrameError::Truncated);
    }
    if raw.len() > MAX_RAW {
        return Err(FrameError::TooLong);
    }
    let (body, crc) = raw.split_at(raw.len() - CRC_LEN);
    let want = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if crc32c(body) != want {
        return Err(FrameError::BadCrc);
    }
    if body[0] >> 4 != FORMAT_VERSION {
        return Err(FrameError::UnknownVersion);
    }
    Ok(Frame {
        header: Header::from_bytes(body),
        payload: &body[HEADER_LEN..],
    })
}

/// Strips one trailing delimiter, rejecting anything too long to be a frame.
fn body(encoded: &[u8]) -> Result<&[u8], FrameError> {
    let encoded = encoded.strip_suffix(&[0]).unwrap_or(encoded);
    if encoded.len() > MAX_ENCODED {
        return Err(FrameError::TooLong);
    }
    Ok(encoded)
}

/// Decodes one encoded frame (with or without its trailing 0x00) into `buf`;
/// the payload borrows `buf`. A `buf` of [`MAX_RAW`] bytes always suffices.
pub fn decode<'b>(encoded: &[u8], buf: &'b mut [u8]) -> Result<Frame<'b>, FrameError> {
    let encoded = body(encoded)?;
    let n = cobs_decode(encoded, buf)?;
    parse(&buf[..n])
}

/// Decodes a frame held in `buf` in place (with or without its trailing 0x00).
pub fn decode_in_place(buf: &mut [u8]) -> Result<Frame<'_>, FrameError> {
    let len = body(buf)?.len();
    let n = cobs_decode_in_place(&mut buf[..len])?;
    parse(&buf[..n])
}

/// Finds frames in a byte stream: collects bytes up to each 0x00 delimiter and
/// decodes them in place. Bytes past [`MAX_ENCODED`] without a delimiter are
/// dropped up to the next 0x00 and reported once as [`FrameError::TooLong`];
/// empty frames (repeated delimiters) are skipped silently, so a sender may
/// also put a 0x00 before each frame to flush line noise.
#[derive(Clone, Debug)]
pub struct Deframer {
    buf: [u8; MAX_ENCODED],
    len: usize,
    discarding: bool,
}

impl Default for Deframer {
    fn default() -> Self {
        Self::new()
    }
}

impl Deframer {
    /// A deframer waiting for the start of a frame.
    pub const fn new() -> Deframer {
        Deframer {
            buf: [0; MAX_ENCODED],
            len: 0,
            discarding: false,
        }
    }

    /// Forgets a partly received frame.
    pub fn clear(&mut self) {
        self.len = 0;
        self.discarding = false;
    }

    /// Takes bytes from `input` up to and including the first delimiter that
    /// ends a frame. Returns the bytes consumed and, if a frame ended, its
    /// decoding. Call again with the rest of `input`.
    pub fn push<'s>(&'s mut self, input: &[u8]) -> (usize, Option<Result<Frame<'s>, FrameError>>) {
        for (i, &b) in input.iter().enumerate() {
            if b == 0 {
                if self.discarding {
                    self.clear();
                    return (i + 1, Some(Err(FrameError::TooLong)));
                }
                if self.len == 0 {
                    continue;
                }
                let n = self.len;
                self.len = 0;
                return (i + 1, Some(decode_in_place(&mut self.buf[..n])));
            }
            if self.discarding {
                continue;
            }
            if self.len == MAX_ENCODED {
                self.discarding = true;
                continue;
            }
            self.buf[self.len] = b;
            self.len += 1;
        }
        (input.len(), None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32c_check_value() {
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
    }

    #[test]
    fn sizes() {
        assert_eq!(MAX_RAW, 206);
        assert_eq!(MAX_FRAME, 208);
        const { assert!(MAX_FRAME <= 4 * 64) };
    }
}
