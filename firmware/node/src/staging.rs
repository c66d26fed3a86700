//! The firmware upload's staging area (`motet_node::Flash`) over flash
//! sectors: pages arrive in order from offset 0 (a page may be sent again),
//! each sector is erased when the upload first reaches it, and a page sent
//! again with other bytes rewrites its sector. The installed application
//! is elsewhere; the bootloader copies a verified image over it.

use crate::board::{FlashPages, Region};
use motet_node::storage::{Flash, StorageError};

/// Largest sector a rewrite handles (bytes kept aside while it is erased).
pub const MAX_SECTOR: usize = 4096;

pub struct Staging<F: FlashPages> {
    flash: F,
    region: Region,
    /// Bytes from the start of the region erased for this upload.
    erased_to: u32,
}

impl<F: FlashPages> Staging<F> {
    pub fn new(flash: F, region: Region) -> Self {
        Staging {
            flash,
            region,
            erased_to: 0,
        }
    }

    /// Rewrites the sector holding `[offset, offset + data.len())`, which
    /// already holds other bytes.
    fn rewrite(&mut self, offset: u32, data: &[u8]) -> Result<(), StorageError> {
        let sector = F::SECTOR as usize;
        if sector > MAX_SECTOR {
            return Err(StorageError::Device);
        }
        let base = offset - offset % F::SECTOR;
        let mut keep = [0u8; MAX_SECTOR];
        let keep = &mut keep[..sector];
        self.flash.read(self.region.start + base, keep)?;
        let at = (offset - base) as usize;
        keep[at..at + data.len()].copy_from_slice(data);
        self.flash.erase(self.region.start + base)?;
        self.flash.program(self.region.start + base, keep)
    }
}

impl<F: FlashPages> Flash for Staging<F> {
    fn capacity(&self) -> u32 {
        self.region.len
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), StorageError> {
        let end = offset
            .checked_add(data.len() as u32)
            .filter(|&e| e <= self.region.len)
            .ok_or(StorageError::OutOfRange)?;
        if offset == 0 {
            // A new upload starts over.
            self.erased_to = 0;
        }
        while self.erased_to < end {
            self.flash.erase(self.region.start + self.erased_to)?;
            self.erased_to += F::SECTOR;
        }
        // Pieces within one sector each (a page may straddle two).
        let mut at = offset;
        let mut rest = data;
        while !rest.is_empty() {
            let room = (F::SECTOR - at % F::SECTOR) as usize;
            let (piece, next) = rest.split_at(room.min(rest.len()));
            let mut old = [0u8; motet_wire::service::PAGE_SIZE];
            let old = &mut old[..piece.len().min(motet_wire::service::PAGE_SIZE)];
            let fits = old.len() == piece.len();
            let blank = fits && {
                self.flash.read(self.region.start + at, old)?;
                old.iter().all(|&b| b == 0xFF)
            };
            if blank {
                self.flash.program(self.region.start + at, piece)?;
            } else if !(fits && old == piece) {
                self.rewrite(at, piece)?;
            }
            at += piece.len() as u32;
            rest = next;
        }
        Ok(())
    }

    fn read(&self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        offset
            .checked_add(buf.len() as u32)
            .filter(|&e| e <= self.region.len)
            .ok_or(StorageError::OutOfRange)?;
        self.flash.read(self.region.start + offset, buf)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::store::tests::MemFlash;
    use std::vec::Vec;

    #[test]
    fn pages_in_order_resent_and_rewritten_read_back() {
        let flash = MemFlash::new(4096);
        // Stale bytes from an earlier upload.
        flash.bytes.borrow_mut()[1024..2048].fill(0x11);
        let region = Region {
            start: 1024,
            len: 2048,
        };
        let mut s = Staging::new(flash.clone(), region);
        let image: Vec<u8> = (0..1500u32).map(|i| (i * 13 % 251) as u8).collect();
        let pages: Vec<(u32, &[u8])> = image
            .chunks(128)
            .enumerate()
            .map(|(i, c)| (i as u32 * 128, c))
            .collect();
        for (k, &(off, page)) in pages.iter().enumerate() {
            s.write(off, page).unwrap();
            if k == 3 {
                // Sent again, the same bytes.
                s.write(off, page).unwrap();
            }
        }
        // A page sent again with other bytes, then with the right ones.
        s.write(256, &[0xAB; 128]).unwrap();
        s.write(256, pages[2].1).unwrap();
        let mut back = std::vec![0u8; image.len()];
        s.read(0, &mut back).unwrap();
        assert_eq!(back, image);
        assert_eq!(s.write(2000, &[1; 100]), Err(StorageError::OutOfRange));
        assert_eq!(s.capacity(), 2048);
        // Outside the region nothing changed.
        assert!(flash.bytes.borrow()[..1024].iter().all(|&b| b == 0xFF));
        assert!(flash.bytes.borrow()[3072..].iter().all(|&b| b == 0xFF));
    }
}
