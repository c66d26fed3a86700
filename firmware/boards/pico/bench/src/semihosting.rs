//! Output and exit through semihosting (`-semihosting`): the microbit's
//! UART is not needed for a few lines.

use core::fmt::Write;

fn call(op: u32, arg: u32) {
    // SAFETY: a semihosting request; QEMU handles it at the breakpoint.
    unsafe {
        core::arch::asm!("bkpt 0xab", inout("r0") op => _, in("r1") arg);
    }
}

/// Prints a line on QEMU's standard output.
pub fn line(args: core::fmt::Arguments<'_>) {
    let mut s: heapless::String<320> = heapless::String::new();
    let _ = s.write_fmt(args);
    let _ = s.push_str("\n\0");
    // SYS_WRITE0: a NUL-terminated string.
    call(0x04, s.as_ptr() as u32);
}

/// Ends QEMU (SYS_EXIT, ADP_Stopped_ApplicationExit).
pub fn exit() -> ! {
    call(0x18, 0x20026);
    loop {
        cortex_m::asm::wfi();
    }
}
