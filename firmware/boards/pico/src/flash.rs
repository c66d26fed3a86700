//! The QSPI flash through the boot ROM's routines: erase 4 KB sectors,
//! program 256-byte pages, and the chip's 64-bit unique id (command 0x4B).
//!
//! While the flash is being written it cannot be read, so nothing may run
//! from it: the sequence (leave execute-in-place, erase or program, flush
//! the cache, enter execute-in-place again) runs from RAM with interrupts
//! off, calling only ROM code; core 1 is not started (it waits in the ROM).
//! Execute-in-place comes back through a RAM copy of boot2, which sets the
//! fast quad read mode again (the ROM's own `flash_enter_cmd_xip` would
//! leave the slow serial read mode).

use crate::layout::{FLASH_LEN, SECTOR, XIP_BASE};
use core::ptr::{addr_of, addr_of_mut};
use motet_firmware::board::{FlashPages, StorageError};
use rp2040_hal::rom_data;

/// boot2, copied out of the flash at start (it is what re-enables quad
/// execute-in-place after a write).
static mut BOOT2_COPY: [u32; 64] = [0; 64];

/// The ROM routines the RAM sequence calls, looked up before it runs (the
/// lookup itself is ROM code, but its results are kept in RAM here).
#[derive(Clone, Copy)]
struct Rom {
    connect: unsafe extern "C" fn(),
    exit_xip: unsafe extern "C" fn(),
    erase: unsafe extern "C" fn(u32, usize, u32, u8),
    program: unsafe extern "C" fn(u32, *const u8, usize),
    flush: unsafe extern "C" fn(),
}

fn rom() -> Rom {
    Rom {
        connect: rom_data::connect_internal_flash::ptr(),
        exit_xip: rom_data::flash_exit_xip::ptr(),
        erase: rom_data::flash_range_erase::ptr(),
        program: rom_data::flash_range_program::ptr(),
        flush: rom_data::flash_flush_cache::ptr(),
    }
}

/// Copies boot2 to RAM. Call once at start, before any write.
pub fn init() {
    // SAFETY: boot2's 256 bytes at the start of flash, read while the
    // flash is in execute-in-place; nothing else uses the copy yet.
    unsafe {
        let src = XIP_BASE as *const u32;
        let dst = addr_of_mut!(BOOT2_COPY) as *mut u32;
        for i in 0..64 {
            dst.add(i).write_volatile(src.add(i).read_volatile());
        }
    }
}

enum Op {
    Erase {
        at: u32,
        len: u32,
    },
    Program {
        at: u32,
        data: *const u8,
        len: usize,
    },
    UniqueId {
        out: *mut u8,
    },
}

/// The whole write, in RAM. Interrupts are off (the caller's critical
/// section): no code in flash runs until execute-in-place is back.
#[inline(never)]
#[link_section = ".data.motet_flash"]
unsafe fn in_ram(rom: &Rom, op: &Op) {
    (rom.connect)();
    (rom.exit_xip)();
    match *op {
        Op::Erase { at, len } => (rom.erase)(at, len as usize, SECTOR, 0x20),
        Op::Program { at, data, len } => (rom.program)(at, data, len),
        Op::UniqueId { out } => unique_id_cmd(out),
    }
    (rom.flush)();
    // boot2 returns to its caller (it is entered with a return address).
    let boot2 = (addr_of!(BOOT2_COPY) as u32) | 1;
    core::arch::asm!("blx {0}", in(reg) boot2, clobber_abi("C"));
}

const IO_QSPI_SS_CTRL: u32 = 0x4001_800c;
const SSI_SR: u32 = 0x1800_0028;
const SSI_DR0: u32 = 0x1800_0060;

/// Command 0x4B (read unique id), four dummy bytes, eight id bytes, with
/// the chip select driven by hand (the SSI in its serial mode after
/// `flash_exit_xip`).
#[inline(always)]
unsafe fn unique_id_cmd(out: *mut u8) {
    let ctrl = IO_QSPI_SS_CTRL as *mut u32;
    // OUTOVER (bits 9:8): 2 drives the chip select low, 3 high.
    ctrl.write_volatile((ctrl.read_volatile() & !0x300) | 0x200);
    let total = 13usize;
    let (mut sent, mut got) = (0usize, 0usize);
    while got < total {
        let sr = (SSI_SR as *const u32).read_volatile();
        // Keep fewer than the 16-entry receive FIFO in flight.
        if sr & 0b10 != 0 && sent < total && sent - got < 14 {
            let b = if sent == 0 { 0x4B } else { 0 };
            (SSI_DR0 as *mut u32).write_volatile(b);
            sent += 1;
        }
        if sr & 0b1000 != 0 {
            let b = (SSI_DR0 as *const u32).read_volatile() as u8;
            if got >= 5 {
                out.add(got - 5).write_volatile(b);
            }
            got += 1;
        }
    }
    ctrl.write_volatile((ctrl.read_volatile() & !0x300) | 0x300);
}

fn run(op: Op) {
    let rom = rom();
    critical_section::with(|_| {
        // SAFETY: interrupts are off; the sequence and all it calls are in
        // RAM or ROM; the ranges were checked by the callers.
        unsafe { in_ram(&rom, &op) }
    });
}

/// The flash chip's 64-bit unique id (the board's uid).
pub fn unique_id() -> u64 {
    let mut id = [0u8; 8];
    run(Op::UniqueId {
        out: id.as_mut_ptr(),
    });
    u64::from_be_bytes(id)
}

/// A handle on the flash (offsets from its start; every handle reaches
/// the same chip; used from the background only).
#[derive(Clone, Copy, Debug)]
pub struct QspiFlash;

fn range(at: u32, len: usize) -> Result<(), StorageError> {
    match at.checked_add(len as u32) {
        Some(end) if end <= FLASH_LEN => Ok(()),
        _ => Err(StorageError::OutOfRange),
    }
}

impl FlashPages for QspiFlash {
    const SECTOR: u32 = SECTOR;

    fn erase(&mut self, at: u32) -> Result<(), StorageError> {
        if !at.is_multiple_of(SECTOR) {
            return Err(StorageError::OutOfRange);
        }
        range(at, SECTOR as usize)?;
        run(Op::Erase { at, len: SECTOR });
        Ok(())
    }

    fn program(&mut self, at: u32, data: &[u8]) -> Result<(), StorageError> {
        range(at, data.len())?;
        // The ROM programs whole 256-byte pages from a RAM buffer: the
        // bytes around `data` in its pages are programmed as 0xFF, which
        // leaves them as they are (programming only clears bits).
        let mut page = [0xFFu8; crate::layout::PAGE as usize];
        let mut done = 0usize;
        while done < data.len() {
            let addr = at + done as u32;
            let base = addr & !(crate::layout::PAGE - 1);
            let off = (addr - base) as usize;
            let n = (page.len() - off).min(data.len() - done);
            page.fill(0xFF);
            page[off..off + n].copy_from_slice(&data[done..done + n]);
            run(Op::Program {
                at: base,
                data: page.as_ptr(),
                len: page.len(),
            });
            done += n;
        }
        Ok(())
    }

    fn read(&self, at: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        range(at, buf.len())?;
        let p = (XIP_BASE + at) as *const u8;
        for (i, b) in buf.iter_mut().enumerate() {
            // SAFETY: inside the flash, checked above (execute-in-place).
            *b = unsafe { p.add(i).read_volatile() };
        }
        Ok(())
    }
}
