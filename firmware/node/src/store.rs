//! The node's identity (uid, address) in two flash sectors, written to
//! each in turn: a record carries a sequence number and a CRC, the newest
//! valid one wins, so a save cut short by a power loss leaves the previous
//! record readable.
//!
//! The firmware version is not taken from the record: a board reports the
//! version of the image it runs (its build's), whatever the record says.

use crate::board::{FlashPages, Region};
use motet_node::storage::{Persisted, StorageError, Store};
use motet_wire::frame::crc32c;
use motet_wire::service::Version;

const MAGIC: [u8; 4] = *b"MTID";
/// magic, sequence, uid, address, version, CRC-32C of the bytes before it.
const RECORD: usize = 4 + 4 + 8 + 2 + 6 + 4;

fn encode(seq: u32, p: &Persisted) -> [u8; RECORD] {
    let mut r = [0u8; RECORD];
    r[0..4].copy_from_slice(&MAGIC);
    r[4..8].copy_from_slice(&seq.to_le_bytes());
    r[8..16].copy_from_slice(&p.uid.to_le_bytes());
    r[16..18].copy_from_slice(&p.address.to_le_bytes());
    r[18..20].copy_from_slice(&p.firmware.major.to_le_bytes());
    r[20..22].copy_from_slice(&p.firmware.minor.to_le_bytes());
    r[22..24].copy_from_slice(&p.firmware.patch.to_le_bytes());
    let crc = crc32c(&r[..RECORD - 4]);
    r[RECORD - 4..].copy_from_slice(&crc.to_le_bytes());
    r
}

fn decode(r: &[u8; RECORD]) -> Option<(u32, Persisted)> {
    if r[0..4] != MAGIC || crc32c(&r[..RECORD - 4]).to_le_bytes() != r[RECORD - 4..] {
        return None;
    }
    let u16_at = |i: usize| u16::from_le_bytes([r[i], r[i + 1]]);
    let mut uid = [0u8; 8];
    uid.copy_from_slice(&r[8..16]);
    Some((
        u32::from_le_bytes([r[4], r[5], r[6], r[7]]),
        Persisted {
            uid: u64::from_le_bytes(uid),
            address: u16_at(16),
            firmware: Version {
                major: u16_at(18),
                minor: u16_at(20),
                patch: u16_at(22),
            },
        },
    ))
}

/// The identity store over two sectors of `region`.
pub struct FlashStore<F: FlashPages> {
    flash: F,
    region: Region,
    /// The running image's version, reported whatever a record holds.
    firmware: Version,
    /// Sector (0 or 1) and sequence number of the newest record.
    newest: Option<(u32, u32)>,
}

impl<F: FlashPages> FlashStore<F> {
    pub fn new(flash: F, region: Region, firmware: Version) -> Self {
        FlashStore {
            flash,
            region,
            firmware,
            newest: None,
        }
    }

    fn sector(&self, i: u32) -> u32 {
        self.region.start + i * F::SECTOR
    }

    fn read(&self, i: u32) -> Option<(u32, Persisted)> {
        let mut r = [0u8; RECORD];
        self.flash.read(self.sector(i), &mut r).ok()?;
        decode(&r)
    }
}

impl<F: FlashPages> Store for FlashStore<F> {
    fn load(&mut self) -> Option<Persisted> {
        let a = self.read(0);
        let b = self.read(1);
        let (i, (seq, p)) = match (a, b) {
            (Some(a), Some(b)) => {
                // Sequence numbers wrap: the newer is less than 2³¹ ahead.
                if (b.0.wrapping_sub(a.0) as i32) > 0 {
                    (1, b)
                } else {
                    (0, a)
                }
            }
            (Some(a), None) => (0, a),
            (None, Some(b)) => (1, b),
            (None, None) => return None,
        };
        self.newest = Some((i, seq));
        Some(Persisted {
            firmware: self.firmware,
            ..p
        })
    }

    fn save(&mut self, p: &Persisted) -> Result<(), StorageError> {
        if self.region.len < 2 * F::SECTOR {
            return Err(StorageError::OutOfRange);
        }
        if self.newest.is_none() {
            self.load();
        }
        let (i, seq) = match self.newest {
            Some((i, seq)) => (1 - i, seq.wrapping_add(1)),
            None => (0, 1),
        };
        let at = self.sector(i);
        self.flash.erase(at)?;
        let record = encode(seq, p);
        self.flash.program(at, &record)?;
        // Read back: a record that does not verify was not saved.
        match self.read(i) {
            Some((s, q)) if s == seq && q == *p => {
                self.newest = Some((i, seq));
                Ok(())
            }
            _ => Err(StorageError::Device),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    extern crate std;
    use super::*;
    use core::cell::RefCell;
    use std::rc::Rc;
    use std::vec;
    use std::vec::Vec;

    /// NOR flash in memory: erase sets 0xFF, programming clears bits.
    #[derive(Clone)]
    pub struct MemFlash {
        pub bytes: Rc<RefCell<Vec<u8>>>,
        pub fail_program: Rc<RefCell<bool>>,
    }

    impl MemFlash {
        pub fn new(len: usize) -> MemFlash {
            MemFlash {
                bytes: Rc::new(RefCell::new(vec![0xFF; len])),
                fail_program: Rc::new(RefCell::new(false)),
            }
        }
    }

    impl FlashPages for MemFlash {
        const SECTOR: u32 = 256;
        fn erase(&mut self, at: u32) -> Result<(), StorageError> {
            let mut b = self.bytes.borrow_mut();
            let at = at as usize;
            if at & 255 != 0 || at + 256 > b.len() {
                return Err(StorageError::OutOfRange);
            }
            b[at..at + 256].fill(0xFF);
            Ok(())
        }
        fn program(&mut self, at: u32, data: &[u8]) -> Result<(), StorageError> {
            if *self.fail_program.borrow() {
                return Err(StorageError::Device);
            }
            let mut b = self.bytes.borrow_mut();
            let at = at as usize;
            if at + data.len() > b.len() {
                return Err(StorageError::OutOfRange);
            }
            for (x, d) in b[at..at + data.len()].iter_mut().zip(data) {
                *x &= *d;
            }
            Ok(())
        }
        fn read(&self, at: u32, buf: &mut [u8]) -> Result<(), StorageError> {
            let b = self.bytes.borrow();
            let at = at as usize;
            if at + buf.len() > b.len() {
                return Err(StorageError::OutOfRange);
            }
            buf.copy_from_slice(&b[at..at + buf.len()]);
            Ok(())
        }
    }

    const V: Version = Version {
        major: 0,
        minor: 3,
        patch: 1,
    };

    fn rec(address: u16) -> Persisted {
        Persisted {
            uid: 0xfeed,
            address,
            firmware: Version::default(),
        }
    }

    #[test]
    fn the_newest_record_survives_restarts_and_a_failed_save() {
        let flash = MemFlash::new(1024);
        let region = Region {
            start: 256,
            len: 512,
        };
        let mut s = FlashStore::new(flash.clone(), region, V);
        assert_eq!(s.load(), None);
        for a in 2..7 {
            s.save(&rec(a)).unwrap();
            // A restart: a new store over the same flash.
            let mut again = FlashStore::new(flash.clone(), region, V);
            assert_eq!(
                again.load(),
                Some(Persisted {
                    firmware: V,
                    ..rec(a)
                })
            );
        }
        // The save's sector is erased, then programming fails: the record
        // before it still loads.
        *flash.fail_program.borrow_mut() = true;
        assert_eq!(s.save(&rec(9)), Err(StorageError::Device));
        *flash.fail_program.borrow_mut() = false;
        let mut again = FlashStore::new(flash.clone(), region, V);
        assert_eq!(again.load().map(|p| p.address), Some(6));
        // Outside the two sectors nothing was touched.
        assert!(flash.bytes.borrow()[..256].iter().all(|&b| b == 0xFF));
        assert!(flash.bytes.borrow()[768..].iter().all(|&b| b == 0xFF));
    }
}
