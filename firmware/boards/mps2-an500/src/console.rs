//! UART1 as a console for people: boot lines and diagnostics (the emulator
//! writes it to a file or a terminal). Polled: it never waits on an
//! interrupt, so a panic can still print.

use crate::uart::Uart;
use core::fmt::Write;

pub struct Console(pub Uart);

impl Write for Console {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for b in s.bytes() {
            self.0.write_blocking(b);
        }
        Ok(())
    }
}

/// Prints a line on the console.
pub fn line(args: core::fmt::Arguments<'_>) {
    let mut c = Console(Uart::UART1);
    let _ = c.write_fmt(args);
    let _ = c.write_str("\n");
}
