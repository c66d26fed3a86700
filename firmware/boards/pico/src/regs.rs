//! The RP2040 registers the step interrupt and the main loop touch on
//! every round, by address (RP2040 datasheet, chapter 2): one load or
//! store each, where the HAL's typed access would add nothing but calls.

/// TIMER: the free-running 1 MHz counter and its alarms.
pub const TIMER_ALARM0: u32 = 0x4005_4010;
pub const TIMER_ALARM1: u32 = 0x4005_4014;
/// Write 1 to a bit: that alarm disarmed.
pub const TIMER_ARMED: u32 = 0x4005_4020;
/// The counter's low word, read without latching the high word.
pub const TIMER_RAWL: u32 = 0x4005_4028;
/// Raw interrupts; write 1 to a bit to clear it.
pub const TIMER_INTR: u32 = 0x4005_4034;
pub const TIMER_INTE: u32 = 0x4005_4038;

/// SIO: the GPIO outputs, one store sets or clears any of them.
pub const SIO_GPIO_IN: u32 = 0xd000_0004;
pub const SIO_GPIO_OUT_SET: u32 = 0xd000_0014;
pub const SIO_GPIO_OUT_CLR: u32 = 0xd000_0018;

/// PWM slice `n`'s compare register (A: low half, B: high half).
pub const fn pwm_cc(slice: u8) -> u32 {
    0x4005_0000 + slice as u32 * 0x14 + 0x0c
}

/// ADC control (EN 0, START_ONCE 2, READY 8, AINSEL 14:12) and result.
pub const ADC_CS: u32 = 0x4004_c000;
pub const ADC_RESULT: u32 = 0x4004_c004;

/// Watchdog control (TRIGGER: bit 31) and what a watchdog reset resets.
pub const WATCHDOG_CTRL: u32 = 0x4005_8000;
pub const PSM_WDSEL: u32 = 0x4001_0008;
/// Everything but the two oscillators (PSM bits 0 and 1).
pub const PSM_WDSEL_ALL_BUT_OSC: u32 = 0x0001_fffc;

#[inline(always)]
pub fn read(addr: u32) -> u32 {
    // SAFETY: callers pass the RP2040 register addresses above.
    unsafe { (addr as *const u32).read_volatile() }
}

#[inline(always)]
pub fn write(addr: u32, v: u32) {
    // SAFETY: as in `read`.
    unsafe { (addr as *mut u32).write_volatile(v) }
}

/// IO_BANK0: GPIO `n`'s function select (FUNCSEL, bits 4:0).
pub const fn gpio_ctrl(n: u8) -> u32 {
    0x4001_4004 + 8 * n as u32
}
pub const FUNC_PWM: u32 = 4;
pub const FUNC_SIO: u32 = 5;
pub const FUNC_NULL: u32 = 0x1f;

/// PADS_BANK0: GPIO `n`'s pad (OD 7, IE 6, DRIVE 5:4, PUE 3, PDE 2,
/// SCHMITT 1, SLEWFAST 0).
pub const fn pad(n: u8) -> u32 {
    0x4001_c004 + 4 * n as u32
}
pub const PAD_OD: u32 = 1 << 7;
pub const PAD_IE: u32 = 1 << 6;
pub const PAD_DRIVE_4MA: u32 = 1 << 4;
pub const PAD_PUE: u32 = 1 << 3;
pub const PAD_SCHMITT: u32 = 1 << 1;

pub const SIO_GPIO_OE_SET: u32 = 0xd000_0024;
