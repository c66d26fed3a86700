//! The Teensy 4.1's pins: what each motet output and input is wired to.
//!
//! | pin | what | chip |
//! |---|---|---|
//! | 2, 3 | channel 0 step, direction | GPIO4 bits 4, 5 |
//! | 4, 5 | channel 1 step, direction | GPIO4 bits 6, 8 |
//! | 6, 7 | channel 2 step, direction | GPIO2 bits 10, 17 |
//! | 8, 9 | channel 3 step, direction | GPIO2 bits 16, 11 |
//! | 10, 12 | encoder 0, phases A and B | QuadTimer 1, inputs 0 and 1 |
//! | 11 | drivers' enable (EN, low: enabled), all channels | GPIO2 bit 2 |
//! | 13 | LED (on the board) | GPIO2 bit 3 |
//! | 14, 15 | analog 0, 1 (A0, A1) | ADC1 inputs 7, 8 |
//! | 28, 29 | tool 0, tool 1 (PWM, 50 Hz for servos) | FlexPWM3 submodule 1, outputs B and A |
//! | 32 | pairing button (to ground; pulled up) | GPIO2 bit 12 |
//!
//! Step and direction pairs sit on consecutive pins 2–9 as common Teensy
//! CNC boards wire them; the step pins are driven through the fast GPIO
//! ports (GPIO6–9, one store to `DR_SET` or `DR_CLEAR` per edge).

/// A pin driven or read as GPIO: its Teensy number and its place on the
/// chip (GPIO1–4, as the reference manual names the ports).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpioPin {
    pub pin: u8,
    pub port: u8,
    pub bit: u8,
}

impl GpioPin {
    pub const fn mask(&self) -> u32 {
        1 << self.bit
    }

    /// The fast port's registers (GPIO6–9 mirror GPIO1–4 on the CPU's
    /// tightly coupled bus).
    pub const fn fast_base(&self) -> u32 {
        0x4200_0000 + (self.port as u32 - 1) * 0x4000
    }

    /// `DR_SET`: a 1 bit raises the pin, the others stay.
    pub const fn set_addr(&self) -> u32 {
        self.fast_base() + 0x84
    }

    /// `DR_CLEAR`: a 1 bit lowers the pin, the others stay.
    pub const fn clear_addr(&self) -> u32 {
        self.fast_base() + 0x88
    }
}

const fn gpio(pin: u8, port: u8, bit: u8) -> GpioPin {
    GpioPin { pin, port, bit }
}

/// Step outputs, one per channel.
pub const STEP: [GpioPin; 4] = [gpio(2, 4, 4), gpio(4, 4, 6), gpio(6, 2, 10), gpio(8, 2, 16)];
/// Direction outputs, one per channel (high: forward).
pub const DIR: [GpioPin; 4] = [gpio(3, 4, 5), gpio(5, 4, 8), gpio(7, 2, 17), gpio(9, 2, 11)];
/// The drivers' enable input, shared (low: enabled).
pub const ENABLE: GpioPin = gpio(11, 2, 2);
pub const LED: GpioPin = gpio(13, 2, 3);
pub const BUTTON: GpioPin = gpio(32, 2, 12);

/// A FlexPWM output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PwmPin {
    pub pin: u8,
    pub module: u8,
    pub submodule: u8,
    /// Output A (false) or B (true) of the submodule.
    pub b: bool,
}

/// Tool outputs: both on one submodule, so both run at its 50 Hz.
pub const TOOLS: [PwmPin; 2] = [
    PwmPin {
        pin: 28,
        module: 3,
        submodule: 1,
        b: true,
    },
    PwmPin {
        pin: 29,
        module: 3,
        submodule: 1,
        b: false,
    },
];

/// Quadrature encoder inputs: QuadTimer 1 counter 0 counts with its input
/// 0 as phase A and input 1 as phase B.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncoderPins {
    pub a: u8,
    pub b: u8,
    pub qtimer: u8,
    pub input_a: u8,
    pub input_b: u8,
}

pub const ENCODERS: [EncoderPins; 1] = [EncoderPins {
    a: 10,
    b: 12,
    qtimer: 1,
    input_a: 0,
    input_b: 1,
}];

/// Analog inputs: Teensy pin and ADC1 input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnalogPin {
    pub pin: u8,
    pub adc_input: u8,
}

pub const ANALOG: [AnalogPin; 2] = [
    AnalogPin {
        pin: 14,
        adc_input: 7,
    },
    AnalogPin {
        pin: 15,
        adc_input: 8,
    },
];

/// Every pin the firmware uses, with what for (for the consistency checks
/// and the documentation).
pub fn all() -> impl Iterator<Item = (u8, &'static str)> {
    let steps = STEP.iter().map(|p| (p.pin, "step"));
    let dirs = DIR.iter().map(|p| (p.pin, "direction"));
    let tools = TOOLS.iter().map(|p| (p.pin, "tool"));
    let enc = ENCODERS
        .iter()
        .flat_map(|e| [(e.a, "encoder A"), (e.b, "encoder B")]);
    let analog = ANALOG.iter().map(|p| (p.pin, "analog"));
    let single = [
        (ENABLE.pin, "enable"),
        (LED.pin, "LED"),
        (BUTTON.pin, "button"),
    ];
    steps
        .chain(dirs)
        .chain(tools)
        .chain(enc)
        .chain(analog)
        .chain(single)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// The Teensy 4.1's digital pins and their GPIO port and bit (PJRC's
    /// pin table), for the pins this board uses.
    const TEENSY41_GPIO: &[(u8, u8, u8)] = &[
        (2, 4, 4),
        (3, 4, 5),
        (4, 4, 6),
        (5, 4, 8),
        (6, 2, 10),
        (7, 2, 17),
        (8, 2, 16),
        (9, 2, 11),
        (10, 2, 0),
        (11, 2, 2),
        (12, 2, 1),
        (13, 2, 3),
        (14, 1, 18),
        (15, 1, 19),
        (28, 3, 18),
        (29, 4, 31),
        (32, 2, 12),
    ];

    #[test]
    fn no_pin_is_used_twice() {
        let mut seen: HashMap<u8, &str> = HashMap::new();
        for (pin, what) in all() {
            if let Some(before) = seen.insert(pin, what) {
                panic!("pin {pin} is both {before} and {what}");
            }
        }
    }

    #[test]
    fn no_gpio_bit_is_driven_twice() {
        let mut seen = HashMap::new();
        for p in STEP.iter().chain(&DIR).chain([&ENABLE, &LED, &BUTTON]) {
            assert!(
                seen.insert((p.port, p.bit), p.pin).is_none(),
                "GPIO{}.{} twice",
                p.port,
                p.bit
            );
        }
    }

    #[test]
    fn every_channel_has_step_and_direction() {
        assert_eq!(STEP.len(), DIR.len());
        for (ch, (s, d)) in STEP.iter().zip(&DIR).enumerate() {
            assert_ne!(s.pin, d.pin, "channel {ch}");
        }
    }

    #[test]
    fn gpio_pins_match_the_teensy_pin_table() {
        for p in STEP.iter().chain(&DIR).chain([&ENABLE, &LED, &BUTTON]) {
            let row = TEENSY41_GPIO.iter().find(|r| r.0 == p.pin);
            assert_eq!(
                row.map(|r| (r.1, r.2)),
                Some((p.port, p.bit)),
                "pin {}",
                p.pin
            );
        }
    }

    #[test]
    fn fast_port_registers() {
        let cases = [
            (STEP[0], 0x4200_C084, 0x4200_C088), // GPIO4 → GPIO9
            (STEP[2], 0x4200_4084, 0x4200_4088), // GPIO2 → GPIO7
        ];
        for (p, set, clear) in cases {
            assert_eq!(
                (p.set_addr(), p.clear_addr()),
                (set, clear),
                "pin {}",
                p.pin
            );
        }
        assert_eq!(STEP[3].mask(), 1 << 16);
    }

    #[test]
    fn the_led_is_the_boards() {
        assert_eq!(LED.pin, 13);
    }

    #[test]
    fn counts_fit_the_node() {
        assert!(STEP.len() <= motet_node::MAX_CHANNELS);
        assert!(TOOLS.len() <= motet_node::MAX_TOOLS);
        assert!(ENCODERS.len() <= motet_node::graph::MAX_HW);
        assert!(ANALOG.len() <= motet_node::graph::MAX_HW);
    }
}
