//! The emulated flash (PSRAM, see `layout`) with NOR rules: erasing a
//! sector sets its bytes to 0xFF, programming only clears bits. Code that
//! forgets an erase fails here as it would on a real part. And the factory
//! image, where the emulator loaded it, read-only.

use crate::layout::{FACTORY_ADDR, FACTORY_LEN, FLASH_BASE, FLASH_LEN, SECTOR};
use motet_firmware::board::{FlashPages, StorageError};

/// A handle on the emulated flash (every handle reaches the same bytes;
/// used from the background only).
#[derive(Clone, Copy, Debug)]
pub struct EmulatedFlash;

fn range(at: u32, len: usize, size: u32) -> Result<(), StorageError> {
    match at.checked_add(len as u32) {
        Some(end) if end <= size => Ok(()),
        _ => Err(StorageError::OutOfRange),
    }
}

impl FlashPages for EmulatedFlash {
    const SECTOR: u32 = SECTOR;

    fn erase(&mut self, at: u32) -> Result<(), StorageError> {
        if at & (SECTOR - 1) != 0 {
            return Err(StorageError::OutOfRange);
        }
        range(at, SECTOR as usize, FLASH_LEN)?;
        let p = (FLASH_BASE + at) as *mut u32;
        for i in 0..(SECTOR / 4) as usize {
            // SAFETY: inside the emulated flash, checked above.
            unsafe { p.add(i).write_volatile(u32::MAX) };
        }
        Ok(())
    }

    fn program(&mut self, at: u32, data: &[u8]) -> Result<(), StorageError> {
        range(at, data.len(), FLASH_LEN)?;
        let p = (FLASH_BASE + at) as *mut u8;
        for (i, &b) in data.iter().enumerate() {
            // SAFETY: inside the emulated flash, checked above.
            unsafe {
                let q = p.add(i);
                q.write_volatile(q.read_volatile() & b);
            }
        }
        Ok(())
    }

    fn read(&self, at: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        range(at, buf.len(), FLASH_LEN)?;
        let p = (FLASH_BASE + at) as *const u8;
        for (i, b) in buf.iter_mut().enumerate() {
            // SAFETY: inside the emulated flash, checked above.
            *b = unsafe { p.add(i).read_volatile() };
        }
        Ok(())
    }
}

/// The factory image's memory, read-only.
#[derive(Clone, Copy, Debug)]
pub struct Factory;

impl FlashPages for Factory {
    const SECTOR: u32 = SECTOR;

    fn erase(&mut self, _at: u32) -> Result<(), StorageError> {
        Err(StorageError::Device)
    }

    fn program(&mut self, _at: u32, _data: &[u8]) -> Result<(), StorageError> {
        Err(StorageError::Device)
    }

    fn read(&self, at: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        range(at, buf.len(), FACTORY_LEN)?;
        let p = (FACTORY_ADDR + at) as *const u8;
        for (i, b) in buf.iter_mut().enumerate() {
            // SAFETY: inside the factory image's memory, checked above.
            *b = unsafe { p.add(i).read_volatile() };
        }
        Ok(())
    }
}
