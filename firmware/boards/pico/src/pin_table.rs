//! Which GPIO does what on the Pico (docs/firmware.md has the wiring).
//!
//! Step and direction pins sit in pairs on GP2–GP9, the tool outputs on the
//! two channels of one PWM slice, the analog inputs on the ADC's pins.
//! GP0/GP1 stay free for a debug UART; GP23–GP25 are the board's (power
//! supply mode, VBUS sense, LED).

/// Step/direction channels.
pub const CHANNELS: usize = 4;
/// Tool outputs.
pub const TOOLS: usize = 2;
// Within the node's `MAX_CHANNELS` and `MAX_TOOLS`.
const _: () = assert!(CHANNELS <= 8 && TOOLS <= 4);

/// GPIO of each channel's step output.
pub const STEP: [u8; CHANNELS] = [2, 4, 6, 8];
/// GPIO of each channel's direction output (high: forward).
pub const DIR: [u8; CHANNELS] = [3, 5, 7, 9];
/// GPIO of each tool output (PWM).
pub const TOOL: [u8; TOOLS] = [14, 15];
/// The PWM slice the tool outputs share (its channels A and B).
pub const TOOL_SLICE: u8 = 7;
/// GPIO of each analog input, and its ADC input (GP26–GP29 are ADC0–3).
pub const ANALOG: [u8; 2] = [26, 27];
/// The pairing button: to ground, with the pin's pull-up.
pub const BUTTON: u8 = 22;
/// The on-board LED.
pub const LED: u8 = 25;

/// The PWM slice and channel (0: A, 1: B) a GPIO drives.
pub const fn pwm_of(gpio: u8) -> (u8, u8) {
    ((gpio / 2) % 8, gpio % 2)
}

/// The ADC input a GPIO is wired to, if any.
pub const fn adc_of(gpio: u8) -> Option<u8> {
    if gpio >= 26 && gpio <= 29 {
        Some(gpio - 26)
    } else {
        None
    }
}

/// Masks for the SIO set/clear registers (one store per edge).
pub const fn masks<const N: usize>(pins: [u8; N]) -> [u32; N] {
    let mut m = [0; N];
    let mut i = 0;
    while i < N {
        m[i] = 1 << pins[i];
        i += 1;
    }
    m
}

pub const STEP_MASK: [u32; CHANNELS] = masks(STEP);
pub const DIR_MASK: [u32; CHANNELS] = masks(DIR);
