//! How long a frame occupies a CAN bus.

use crate::slcan::CanFrame;

/// How long frames take on the bus: the arbitration and acknowledgement
/// bits at the nominal rate, a CAN-FD frame's data phase (with the bit-rate
/// switch) at the data rate. Stuff bits are not counted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BusTiming {
    /// Nominal (arbitration) bit rate, bits per second.
    pub nominal_bps: f64,
    /// Data-phase bit rate, bits per second.
    pub data_bps: f64,
}

impl BusTiming {
    /// CAN-FD at 1 Mbit/s nominal and 5 Mbit/s data, as common FD
    /// controllers and transceivers run.
    pub const FD_1M_5M: BusTiming = BusTiming {
        nominal_bps: 1e6,
        data_bps: 5e6,
    };

    /// Time `f` occupies the bus, µs, with the interframe space.
    pub fn frame_us(&self, f: &CanFrame) -> f64 {
        let n = f.data.len() as f64;
        let id_bits = if f.extended { 31.0 } else { 12.0 };
        // ACK slot and delimiter, end of frame, interframe space.
        let tail = 12.0;
        if f.fd {
            // SOF, id, RRS/IDE/FDF/res/BRS; then ESI, DLC, data, stuff
            // count, CRC (17 bits up to 16 bytes, 21 beyond), delimiter.
            let head = 1.0 + id_bits + 5.0;
            let crc = if n <= 16.0 { 17.0 } else { 21.0 };
            let data = 1.0 + 4.0 + 8.0 * n + 4.0 + crc + 1.0;
            let data_rate = if f.brs {
                self.data_bps
            } else {
                self.nominal_bps
            };
            1e6 * ((head + tail) / self.nominal_bps + data / data_rate)
        } else {
            // SOF, id, RTR/IDE/r0, DLC, data, CRC 15 and delimiter.
            let bits = 1.0 + id_bits + 3.0 + 4.0 + 8.0 * n + 16.0 + tail;
            1e6 * bits / self.nominal_bps
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_times() {
        let t = BusTiming::FD_1M_5M;
        // (frame, µs): bits at 1 and 5 Mbit/s, interframe space included.
        let cases = [
            (CanFrame::standard(0x10, &[0; 8]), 112.0),
            (CanFrame::standard(0x10, &[]), 48.0),
            (CanFrame::fd(0x10, false, &[0; 64]), 30.0 + 543.0 / 5.0),
            (CanFrame::fd(0x10, false, &[0; 8]), 30.0 + 91.0 / 5.0),
            (
                CanFrame {
                    brs: false,
                    ..CanFrame::fd(0x10, false, &[0; 8])
                },
                30.0 + 91.0,
            ),
            (CanFrame::fd(0x10, true, &[0; 8]), 49.0 + 91.0 / 5.0),
        ];
        for (f, want) in cases {
            assert!(
                (t.frame_us(&f) - want).abs() < 1e-9,
                "{f:?}: {}",
                t.frame_us(&f)
            );
        }
    }
}
