//! CMSDK APB UART: UART0 carries the node's link (interrupt-driven, with
//! byte rings), UART1 the console.

use core::ptr::{read_volatile, write_volatile};

const DATA: u32 = 0x00;
const STATE: u32 = 0x04;
const CTRL: u32 = 0x08;
const INTCLEAR: u32 = 0x0C;
const BAUDDIV: u32 = 0x10;

const TX_FULL: u32 = 1 << 0;
const RX_FULL: u32 = 1 << 1;
const TX_EN: u32 = 1 << 0;
const RX_EN: u32 = 1 << 1;
const TX_INT: u32 = 1 << 2;
const RX_INT: u32 = 1 << 3;

#[derive(Clone, Copy)]
pub struct Uart {
    base: u32,
}

impl Uart {
    pub const UART0: Uart = Uart { base: 0x4000_4000 };
    pub const UART1: Uart = Uart { base: 0x4000_5000 };

    fn read(&self, off: u32) -> u32 {
        // SAFETY: a register of a CMSDK UART this board has.
        unsafe { read_volatile((self.base + off) as *const u32) }
    }

    fn write(&self, off: u32, v: u32) {
        // SAFETY: as above.
        unsafe { write_volatile((self.base + off) as *mut u32, v) }
    }

    /// Enables the UART; with `interrupts`, RX and TX interrupts too.
    pub fn init(&self, interrupts: bool) {
        // QEMU's model needs a divider of at least 16 and ignores the rate.
        self.write(BAUDDIV, 16);
        let ints = if interrupts { TX_INT | RX_INT } else { 0 };
        self.write(CTRL, TX_EN | RX_EN | ints);
    }

    pub fn tx_full(&self) -> bool {
        self.read(STATE) & TX_FULL != 0
    }

    pub fn write_byte(&self, b: u8) {
        self.write(DATA, b as u32);
    }

    pub fn write_blocking(&self, b: u8) {
        while self.tx_full() {}
        self.write_byte(b);
    }

    pub fn read_byte(&self) -> Option<u8> {
        (self.read(STATE) & RX_FULL != 0).then(|| self.read(DATA) as u8)
    }

    /// Clears the UART's interrupt (RX and TX).
    pub fn clear(&self) {
        self.write(INTCLEAR, 0b11);
    }
}
