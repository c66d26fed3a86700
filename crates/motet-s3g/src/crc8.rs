//! The packet checksum: CRC-8 Dallas/Maxim (polynomial 0x31 reflected,
//! 0x8C; initial value 0; no final xor), over the payload only.

use crc::{Crc, CRC_8_MAXIM_DOW};

const CRC8: Crc<u8> = Crc::<u8>::new(&CRC_8_MAXIM_DOW);

/// The CRC of a payload, as the packet's last byte carries it.
pub fn crc8(payload: &[u8]) -> u8 {
    CRC8.checksum(payload)
}

#[cfg(test)]
mod tests {
    use super::crc8;

    /// The bit-by-bit loop of the protocol's documentation (and the
    /// Freesteel blog's `crc`), to check the table-driven crate against.
    fn by_bits(payload: &[u8]) -> u8 {
        let mut b = 0u8;
        for &c in payload {
            b ^= c;
            for _ in 0..8 {
                b = if b & 1 != 0 { (b >> 1) ^ 0x8C } else { b >> 1 };
            }
        }
        b
    }

    #[test]
    fn matches_the_documented_loop() {
        let cases: [&[u8]; 5] = [b"", b"\x02", b"123456789", b"\x14\x1c\x00", &[0xff; 32]];
        for c in cases {
            assert_eq!(crc8(c), by_bits(c), "{c:02x?}");
        }
        // The catalogue's check value for CRC-8/MAXIM-DOW.
        assert_eq!(crc8(b"123456789"), 0xA1);
    }
}
