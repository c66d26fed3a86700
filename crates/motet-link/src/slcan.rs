//! slcan (Lawicel ASCII) codec: CAN and CAN-FD frames as text lines over a
//! serial port.
//!
//! | line | meaning |
//! |---|---|
//! | `tiiiL<data>` | classic frame, 11-bit id (3 hex digits), length digit 0–8, 2 hex digits per byte |
//! | `TiiiiiiiiL<data>` | classic frame, 29-bit id (8 hex digits) |
//! | `riiiL` / `RiiiiiiiiL` | remote frame (no data) |
//! | `diiiC<data>` / `DiiiiiiiiC<data>` | CAN-FD frame, DLC code C (hex digit 0–F: 0–8, 12, 16, 20, 24, 32, 48, 64 bytes) |
//! | `biiiC<data>` / `BiiiiiiiiC<data>` | CAN-FD frame with bit-rate switch |
//! | `O` / `C` | open / close the channel |
//! | `Sn` | nominal bit rate: S0 10k, S1 20k, S2 50k, S3 100k, S4 125k, S5 250k, S6 500k, S7 800k, S8 1M |
//!
//! Every line ends with `\r`.

use std::fmt;

/// Largest standard (11-bit) identifier.
pub const MAX_STD_ID: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXT_ID: u32 = 0x1FFF_FFFF;
/// Payload length of each CAN-FD DLC code.
pub const FD_LENGTHS: [usize; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];
/// Bit rates selected by `S0`..`S8`.
pub const BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// A CAN or CAN-FD frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CanFrame {
    /// The identifier: 11 bits, or 29 if `extended`.
    pub id: u32,
    /// 29-bit extended identifier.
    pub extended: bool,
    /// CAN-FD format (up to 64 data bytes).
    pub fd: bool,
    /// CAN-FD bit-rate switch.
    pub brs: bool,
    /// Remote frame (classic only); `data` is empty and `rtr_len` gives the
    /// requested length.
    pub rtr: bool,
    /// Data length a remote frame requests, 0 to 8.
    pub rtr_len: u8,
    /// The payload: up to 8 bytes (classic) or a CAN-FD length up to 64.
    pub data: Vec<u8>,
}

impl CanFrame {
    /// A classic data frame with an 11-bit id.
    pub fn standard(id: u32, data: &[u8]) -> CanFrame {
        CanFrame {
            id,
            extended: false,
            fd: false,
            brs: false,
            rtr: false,
            rtr_len: 0,
            data: data.to_vec(),
        }
    }

    /// A CAN-FD data frame (bit-rate switch on).
    pub fn fd(id: u32, extended: bool, data: &[u8]) -> CanFrame {
        CanFrame {
            id,
            extended,
            fd: true,
            brs: true,
            rtr: false,
            rtr_len: 0,
            data: data.to_vec(),
        }
    }

    /// Arbitration order: the smaller key wins the bus. Compares the 11-bit
    /// base identifier, then RTR/SRR, IDE, the 18 extension bits and the
    /// extended RTR bit, as the bits go out on the wire (dominant = 0).
    pub fn arbitration_key(&self) -> (u32, u8, u8, u32, u8) {
        if self.extended {
            (self.id >> 18, 1, 1, self.id & 0x3FFFF, self.rtr as u8)
        } else {
            (self.id, self.rtr as u8, 0, 0, 0)
        }
    }
}

/// One slcan line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Command {
    /// `O`: open the channel; the adapter starts sending and receiving.
    Open,
    /// `C`: close the channel.
    Close,
    /// `Sn`: index into [`BITRATES`].
    Bitrate(u8),
    /// A frame to send (or one received).
    Frame(CanFrame),
}

/// Why a line was rejected.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SlcanError {
    /// A line with no command letter.
    Empty,
    /// A command letter slcan does not have (the byte).
    UnknownCommand(u8),
    /// Fewer characters than the command needs.
    Truncated,
    /// A character that should be a hex digit is not.
    BadHex(usize),
    /// An identifier beyond 11 bits (`t`, `r`, `d`, `b`) or 29 bits (upper
    /// case).
    IdOutOfRange(u32),
    /// A length digit beyond 8 (classic) or a data length that is not a DLC
    /// length.
    BadLength(usize),
    /// Characters after the data.
    Trailing,
    /// `Sn` with `n` beyond 8.
    BadBitrate(u8),
    /// A frame that cannot be written (remote CAN-FD, too much data).
    Unencodable,
}

impl fmt::Display for SlcanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "slcan: {self:?}")
    }
}

impl std::error::Error for SlcanError {}

/// The DLC code for a CAN-FD payload length, if it is one.
pub fn fd_dlc(len: usize) -> Option<u8> {
    FD_LENGTHS.iter().position(|&l| l == len).map(|i| i as u8)
}

/// The smallest CAN-FD length holding `len` bytes (`None` past 64).
pub fn fd_round_up(len: usize) -> Option<usize> {
    FD_LENGTHS.iter().copied().find(|&l| l >= len)
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

fn push_hex(out: &mut Vec<u8>, v: u32, digits: usize) {
    for i in (0..digits).rev() {
        out.push(HEX[((v >> (4 * i)) & 0xF) as usize]);
    }
}

/// Encodes one line, `\r` included.
pub fn encode(cmd: &Command) -> Result<Vec<u8>, SlcanError> {
    let mut out = Vec::new();
    match cmd {
        Command::Open => out.push(b'O'),
        Command::Close => out.push(b'C'),
        Command::Bitrate(n) => {
            if *n as usize >= BITRATES.len() {
                return Err(SlcanError::BadBitrate(*n));
            }
            out.push(b'S');
            out.push(b'0' + n);
        }
        Command::Frame(f) => {
            let max = if f.extended { MAX_EXT_ID } else { MAX_STD_ID };
            if f.id > max {
                return Err(SlcanError::IdOutOfRange(f.id));
            }
            let letter = match (f.fd, f.brs, f.rtr) {
                (false, _, false) => b't',
                (false, _, true) => b'r',
                (true, false, false) => b'd',
                (true, true, false) => b'b',
                (true, _, true) => return Err(SlcanError::Unencodable),
            };
            out.push(if f.extended {
                letter.to_ascii_uppercase()
            } else {
                letter
            });
            push_hex(&mut out, f.id, if f.extended { 8 } else { 3 });
            let code = if f.rtr {
                if f.rtr_len > 8 || !f.data.is_empty() {
                    return Err(SlcanError::Unencodable);
                }
                f.rtr_len
            } else if f.fd {
                fd_dlc(f.data.len()).ok_or(SlcanError::BadLength(f.data.len()))?
            } else {
                if f.data.len() > 8 {
                    return Err(SlcanError::BadLength(f.data.len()));
                }
                f.data.len() as u8
            };
            out.push(HEX[code as usize]);
            for &b in &f.data {
                push_hex(&mut out, b as u32, 2);
            }
        }
    }
    out.push(b'\r');
    Ok(out)
}

fn hex_digit(line: &[u8], at: usize) -> Result<u32, SlcanError> {
    let c = *line.get(at).ok_or(SlcanError::Truncated)?;
    (c as char).to_digit(16).ok_or(SlcanError::BadHex(at))
}

fn hex(line: &[u8], at: usize, digits: usize) -> Result<u32, SlcanError> {
    (at..at + digits).try_fold(0u32, |v, i| Ok(v << 4 | hex_digit(line, i)?))
}

/// Decodes one line (a trailing `\r` is allowed).
pub fn decode(line: &[u8]) -> Result<Command, SlcanError> {
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    let (&c, rest) = line.split_first().ok_or(SlcanError::Empty)?;
    let simple = |cmd: Command| {
        if rest.is_empty() {
            Ok(cmd)
        } else {
            Err(SlcanError::Trailing)
        }
    };
    let (fd, brs, rtr) = match c.to_ascii_lowercase() {
        _ if c == b'O' => return simple(Command::Open),
        _ if c == b'C' => return simple(Command::Close),
        _ if c == b'S' => {
            let n = hex_digit(line, 1)? as u8;
            if n as usize >= BITRATES.len() {
                return Err(SlcanError::BadBitrate(n));
            }
            return if line.len() == 2 {
                Ok(Command::Bitrate(n))
            } else {
                Err(SlcanError::Trailing)
            };
        }
        b't' => (false, false, false),
        b'r' => (false, false, true),
        b'd' => (true, false, false),
        b'b' => (true, true, false),
        _ => return Err(SlcanError::UnknownCommand(c)),
    };
    let extended = c.is_ascii_uppercase();
    let id_digits = if extended { 8 } else { 3 };
    let id = hex(line, 1, id_digits)?;
    let max = if extended { MAX_EXT_ID } else { MAX_STD_ID };
    if id > max {
        return Err(SlcanError::IdOutOfRange(id));
    }
    let code = hex_digit(line, 1 + id_digits)? as usize;
    let len = if fd {
        FD_LENGTHS[code]
    } else if code > 8 {
        return Err(SlcanError::BadLength(code));
    } else {
        code
    };
    let start = 2 + id_digits;
    let data_len = if rtr { 0 } else { len };
    let need = start + 2 * data_len;
    if line.len() < need {
        return Err(SlcanError::Truncated);
    }
    if line.len() > need {
        return Err(SlcanError::Trailing);
    }
    let data = (0..data_len)
        .map(|i| hex(line, start + 2 * i, 2).map(|v| v as u8))
        .collect::<Result<Vec<u8>, _>>()?;
    Ok(Command::Frame(CanFrame {
        id,
        extended,
        fd,
        brs,
        rtr,
        rtr_len: if rtr { len as u8 } else { 0 },
        data,
    }))
}

/// Splits an slcan byte stream into lines at `\r`. Adapter replies of a lone
/// `\r` (ok) or BEL 0x07 (error) come out as empty lines and `[0x07]`.
#[derive(Clone, Debug, Default)]
pub struct LineSplitter {
    buf: Vec<u8>,
}

impl LineSplitter {
    /// Feeds bytes; every complete line (without `\r`) goes to `out`.
    pub fn push(&mut self, bytes: &[u8], out: &mut impl FnMut(Vec<u8>)) {
        for &b in bytes {
            match b {
                b'\r' => out(std::mem::take(&mut self.buf)),
                0x07 => {
                    self.buf.clear();
                    out(vec![0x07]);
                }
                _ => self.buf.push(b),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        // (line, command)
        let ext = |id, data: &[u8]| CanFrame {
            extended: true,
            fd: false,
            ..CanFrame::standard(id, data)
        };
        let cases: Vec<(&str, Command)> = vec![
            ("O\r", Command::Open),
            ("C\r", Command::Close),
            ("S6\r", Command::Bitrate(6)),
            ("S0\r", Command::Bitrate(0)),
            (
                "t1232AABB\r",
                Command::Frame(CanFrame::standard(0x123, &[0xAA, 0xBB])),
            ),
            ("t7FF0\r", Command::Frame(CanFrame::standard(0x7FF, &[]))),
            (
                "t00080102030405060708\r",
                Command::Frame(CanFrame::standard(0, &[1, 2, 3, 4, 5, 6, 7, 8])),
            ),
            ("T1FFFFFFF1FF\r", Command::Frame(ext(0x1FFF_FFFF, &[0xFF]))),
            (
                "r1004\r",
                Command::Frame(CanFrame {
                    rtr: true,
                    rtr_len: 4,
                    ..CanFrame::standard(0x100, &[])
                }),
            ),
            (
                "d1019000102030405060708090A0B\r",
                Command::Frame(CanFrame {
                    brs: false,
                    ..CanFrame::fd(0x101, false, &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11])
                }),
            ),
        ];
        for (line, cmd) in &cases {
            assert_eq!(decode(line.as_bytes()).as_ref(), Ok(cmd), "decode {line:?}");
            assert_eq!(encode(cmd).unwrap(), line.as_bytes(), "encode {cmd:?}");
        }
    }

    #[test]
    fn every_fd_length_round_trips() {
        for (code, &len) in FD_LENGTHS.iter().enumerate() {
            for extended in [false, true] {
                let data: Vec<u8> = (0..len).map(|i| (i * 37) as u8).collect();
                let f = CanFrame::fd(0x12, extended, &data);
                let line = encode(&Command::Frame(f.clone())).unwrap();
                let id_digits = if extended { 8 } else { 3 };
                assert_eq!(line[0], if extended { b'B' } else { b'b' });
                assert_eq!(line[1 + id_digits], HEX[code]);
                assert_eq!(line.len(), 1 + id_digits + 1 + 2 * len + 1);
                assert_eq!(decode(&line), Ok(Command::Frame(f)));
            }
        }
        assert_eq!(fd_round_up(13), Some(16));
        assert_eq!(fd_round_up(64), Some(64));
        assert_eq!(fd_round_up(65), None);
    }

    #[test]
    fn malformed_lines() {
        let cases: &[(&str, SlcanError)] = &[
            ("", SlcanError::Empty),
            ("\r", SlcanError::Empty),
            ("x123\r", SlcanError::UnknownCommand(b'x')),
            ("t12", SlcanError::Truncated),
            ("t123", SlcanError::Truncated),
            ("t1232AA", SlcanError::Truncated),
            ("t1232AABBCC", SlcanError::Trailing),
            ("t12G0", SlcanError::BadHex(3)),
            ("t1231ZZ", SlcanError::BadHex(5)),
            ("t800", SlcanError::IdOutOfRange(0x800)),
            ("T200000000", SlcanError::IdOutOfRange(0x2000_0000)),
            ("t1239", SlcanError::BadLength(9)),
            ("d123F00", SlcanError::Truncated),
            ("S9", SlcanError::BadBitrate(9)),
            ("S", SlcanError::Truncated),
            ("S61", SlcanError::Trailing),
            ("Ox", SlcanError::Trailing),
            ("r1004AA", SlcanError::Trailing),
        ];
        for (line, err) in cases {
            assert_eq!(decode(line.as_bytes()).as_ref(), Err(err), "line {line:?}");
        }
    }

    #[test]
    fn unencodable() {
        let cases: Vec<(CanFrame, SlcanError)> = vec![
            (
                CanFrame::standard(0x800, &[]),
                SlcanError::IdOutOfRange(0x800),
            ),
            (CanFrame::standard(1, &[0; 9]), SlcanError::BadLength(9)),
            (CanFrame::fd(1, false, &[0; 13]), SlcanError::BadLength(13)),
            (
                CanFrame {
                    rtr: true,
                    ..CanFrame::fd(1, false, &[])
                },
                SlcanError::Unencodable,
            ),
        ];
        for (f, e) in cases {
            assert_eq!(encode(&Command::Frame(f)), Err(e));
        }
        assert_eq!(encode(&Command::Bitrate(9)), Err(SlcanError::BadBitrate(9)));
    }

    #[test]
    fn line_splitter() {
        let mut s = LineSplitter::default();
        let mut got = Vec::new();
        for chunk in [&b"t12"[..], b"30\rO", b"\r\r\x07S6\r"] {
            s.push(chunk, &mut |l| got.push(l));
        }
        let want: Vec<Vec<u8>> = vec![
            b"t1230".to_vec(),
            b"O".to_vec(),
            vec![],
            vec![0x07],
            b"S6".to_vec(),
        ];
        assert_eq!(got, want);
        assert_eq!(
            got.iter()
                .filter_map(|l| decode(l).ok())
                .collect::<Vec<_>>(),
            vec![
                Command::Frame(CanFrame::standard(0x123, &[])),
                Command::Open,
                Command::Bitrate(6)
            ]
        );
    }
}
