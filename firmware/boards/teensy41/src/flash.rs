//! The QSPI flash through the i.MX RT1062 boot ROM's FlexSPI NOR driver
//! (its API tree at 0x0020_001C): erase 4 KB sectors, program 256-byte
//! pages, with the FlexSPI configuration block the boot ROM itself booted
//! from (the bootloader's, at the start of flash). Reads go through the
//! FlexSPI's memory window.
//!
//! All the firmware's code runs from ITCM and its data lives in DTCM and
//! OCRAM, so nothing fetches from flash while the ROM drives it; interrupts
//! are masked during each ROM call all the same, as NXP's ROM API notes
//! ask (a sector erase takes tens of ms: flash at rest).

use crate::layout::{FACTORY, FLASH_BASE, LOADABLE, PAGE, SECTOR, WRITABLE};
use core::ptr::{addr_of_mut, read_volatile};
use core::sync::atomic::{AtomicBool, Ordering};
use motet_firmware::board::{FlashPages, Region, StorageError};

type Config = [u32; 128];

#[repr(C)]
struct NorDriver {
    version: u32,
    init: unsafe extern "C" fn(u32, *mut Config) -> i32,
    program: unsafe extern "C" fn(u32, *mut Config, u32, *const u32) -> i32,
    erase_all: usize,
    erase: unsafe extern "C" fn(u32, *mut Config, u32, u32) -> i32,
    read: usize,
    clear_cache: unsafe extern "C" fn(u32),
}

#[repr(C)]
struct ApiTree {
    version: u32,
    copyright: usize,
    run_bootloader: usize,
    reserved0: usize,
    flexspi_nor: *const NorDriver,
}

/// The ROM's pointer to its API tree.
const API_TREE: *const *const ApiTree = 0x0020_001C as *const *const ApiTree;
/// FlexSPI1, where the flash is.
const INSTANCE: u32 = 0;

/// The configuration block (512 bytes) the ROM's driver works from, copied
/// out of flash before its first use.
static mut CONFIG: Config = [0; 128];
static READY: AtomicBool = AtomicBool::new(false);

fn driver() -> &'static NorDriver {
    // SAFETY: the boot ROM's API tree, always present on the RT1062.
    unsafe { &*(**API_TREE).flexspi_nor }
}

/// Runs a ROM call with interrupts masked, the driver initialised first.
fn rom<R>(f: impl FnOnce(&NorDriver, *mut Config) -> R) -> Result<R, StorageError> {
    cortex_m::interrupt::free(|_| {
        let cfg = addr_of_mut!(CONFIG);
        let d = driver();
        if !READY.load(Ordering::Relaxed) {
            // SAFETY: the FCB the boot ROM read, 512 bytes at the start of
            // flash; copied while nothing else uses `CONFIG`.
            unsafe {
                for i in 0..128 {
                    (*cfg)[i] = read_volatile((FLASH_BASE as *const u32).add(i));
                }
                if (d.init)(INSTANCE, cfg) != 0 {
                    return Err(StorageError::Device);
                }
            }
            READY.store(true, Ordering::Relaxed);
        }
        let r = f(d, cfg);
        // SAFETY: drops FlexSPI's read buffers so the window shows what
        // was written.
        unsafe { (d.clear_cache)(INSTANCE) };
        invalidate_dcache();
        Ok(r)
    })
}

fn invalidate_dcache() {
    // SAFETY: only the data cache's contents are dropped; flash is never
    // written through the cache.
    let mut p = unsafe { cortex_m::Peripherals::steal() };
    if cortex_m::peripheral::SCB::dcache_enabled() {
        p.SCB.clean_invalidate_dcache(&mut p.CPUID);
    }
}

fn inside(r: Region, at: u32, len: usize) -> Result<(), StorageError> {
    match at.checked_add(len as u32) {
        Some(end) if at >= r.start && end <= r.end() => Ok(()),
        _ => Err(StorageError::OutOfRange),
    }
}

fn read_window(at: u32, buf: &mut [u8]) {
    let p = (FLASH_BASE + at) as *const u8;
    for (i, b) in buf.iter_mut().enumerate() {
        // SAFETY: inside the flash window, checked by the caller.
        *b = unsafe { read_volatile(p.add(i)) };
    }
}

/// A handle on the flash: reads anywhere the loader writes, erases and
/// programs the firmware's own regions only ([`WRITABLE`]).
#[derive(Clone, Copy, Debug)]
pub struct NorFlash;

impl FlashPages for NorFlash {
    const SECTOR: u32 = SECTOR;

    fn erase(&mut self, at: u32) -> Result<(), StorageError> {
        if !at.is_multiple_of(SECTOR) {
            return Err(StorageError::OutOfRange);
        }
        inside(WRITABLE, at, SECTOR as usize)?;
        // SAFETY: a sector of the firmware's own regions.
        let status = rom(|d, cfg| unsafe { (d.erase)(INSTANCE, cfg, at, SECTOR) })?;
        if status != 0 {
            return Err(StorageError::Device);
        }
        Ok(())
    }

    fn program(&mut self, at: u32, data: &[u8]) -> Result<(), StorageError> {
        inside(WRITABLE, at, data.len())?;
        let mut done = 0usize;
        while done < data.len() {
            let addr = at + done as u32;
            let page = addr & !(PAGE - 1);
            let from = (addr - page) as usize;
            let n = (PAGE as usize - from).min(data.len() - done);
            // Whole pages: 0xFF leaves the bytes outside `data` as they are.
            let mut buf = [u32::MAX; (PAGE / 4) as usize];
            // SAFETY: `buf` is PAGE bytes; viewed as bytes to fill it.
            let bytes = unsafe {
                core::slice::from_raw_parts_mut(buf.as_mut_ptr().cast::<u8>(), PAGE as usize)
            };
            bytes[from..from + n].copy_from_slice(&data[done..done + n]);
            // SAFETY: a page of the firmware's own regions, from a full
            // page buffer.
            let status = rom(|d, cfg| unsafe { (d.program)(INSTANCE, cfg, page, buf.as_ptr()) })?;
            if status != 0 {
                return Err(StorageError::Device);
            }
            done += n;
        }
        Ok(())
    }

    fn read(&self, at: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        inside(LOADABLE, at, buf.len())?;
        read_window(at, buf);
        Ok(())
    }
}

/// The factory image the Teensy loader wrote, read-only, by offset from
/// its start.
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
        inside(
            Region {
                start: 0,
                len: FACTORY.len,
            },
            at,
            buf.len(),
        )?;
        read_window(FACTORY.start + at, buf);
        Ok(())
    }
}
