//! The interrupts the firmware uses (QEMU's mps2-an500 wiring).

use cortex_m::interrupt::InterruptNumber;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum Irq {
    Uart0Rx = 0,
    Uart0Tx = 1,
    Timer0 = 8,
    Timer1 = 9,
}

// SAFETY: the numbers are the machine's external interrupt lines, all
// below its 32.
unsafe impl InterruptNumber for Irq {
    fn number(self) -> u16 {
        self as u16
    }
}

/// Entries in the vector table after the 16 exceptions.
pub const LINES: usize = 32;

/// One entry of the interrupt vector table.
#[derive(Clone, Copy)]
pub union Vector {
    pub handler: unsafe extern "C" fn(),
    pub reserved: usize,
}

extern "C" {
    fn DefaultHandler();
}

/// A table with `DefaultHandler` everywhere (a binary replaces the lines it
/// uses).
pub const fn default_vectors() -> [Vector; LINES] {
    [Vector {
        handler: DefaultHandler,
    }; LINES]
}
