//! The graph's inputs: a quadrature encoder on QuadTimer 1 (counter 0 in
//! quadrature mode, its 16 bits extended in software at every read), and
//! two analog inputs on ADC1, converted one after the other without
//! waiting (each read takes the finished conversion and starts the next).

use crate::pinmap::{ANALOG, ENCODERS};
use core::ptr::{read_volatile, write_volatile};
use motet_firmware::board::Inputs;

const QTIMER1: u32 = 0x401D_C000;
const CNTR: u32 = QTIMER1 + 0x0A;
const CTRL: u32 = QTIMER1 + 0x0C;
const COMP1: u32 = QTIMER1;
const FILT: u32 = QTIMER1 + 0x16;
const ENBL: u32 = QTIMER1 + 0x1E;
/// CTRL: count mode 4 (quadrature), primary source counter input 0 (phase
/// A: PCS 0), secondary source counter input 1 (phase B), roll over at 16
/// bits.
const QUADRATURE: u16 = (0b100 << 13) | (1 << 7);
/// FILT: 3 agreeing samples, 10 IPG clocks apart (200 ns at 150 MHz).
const FILTER: u16 = (3 << 8) | 10;

const ADC1: u32 = 0x400C_4000;
const HC0: u32 = ADC1;
const HS: u32 = ADC1 + 0x24;
const R0: u32 = ADC1 + 0x28;
const COCO0: u32 = 1;

/// CCM_CCGR6's QuadTimer 1 gate (CG13).
const CCGR6: u32 = 0x400F_C080;
const QTIMER1_GATE: u32 = 0b11 << 26;

fn r16(addr: u32) -> u16 {
    // SAFETY: a QuadTimer 1 register.
    unsafe { read_volatile(addr as *const u16) }
}

fn w16(addr: u32, v: u16) {
    // SAFETY: a QuadTimer 1 register.
    unsafe { write_volatile(addr as *mut u16, v) }
}

fn r32(addr: u32) -> u32 {
    // SAFETY: an ADC1 or CCM register.
    unsafe { read_volatile(addr as *const u32) }
}

fn w32(addr: u32, v: u32) {
    // SAFETY: an ADC1 or CCM register.
    unsafe { write_volatile(addr as *mut u32, v) }
}

pub struct GraphInputs {
    last_count: u16,
    encoder: i64,
    analog: [f32; ANALOG.len()],
    /// Which analog input converts now (None: none started).
    converting: Option<usize>,
}

impl GraphInputs {
    /// Starts the encoder counting (its pads muxed by `board`) and the
    /// first conversion (ADC1 set up by the caller).
    pub fn new() -> GraphInputs {
        const _: () = assert!(ENCODERS.len() == 1);
        w32(CCGR6, r32(CCGR6) | QTIMER1_GATE);
        w16(ENBL, 0);
        w16(CTRL, 0);
        w16(FILT, FILTER);
        w16(COMP1, 0xFFFF);
        w16(CNTR, 0);
        w16(CTRL, QUADRATURE);
        w16(ENBL, 1);
        let mut g = GraphInputs {
            last_count: 0,
            encoder: 0,
            analog: [0.0; ANALOG.len()],
            converting: None,
        };
        g.start(0);
        g
    }

    fn start(&mut self, i: usize) {
        w32(HC0, ANALOG[i].adc_input as u32);
        self.converting = Some(i);
    }

    /// The encoder's count since start, the analog inputs' latest
    /// readings (raw ADC counts, 10 bits).
    pub fn read(&mut self, inputs: &mut Inputs) {
        let now = r16(CNTR);
        // Reads come far more often than 32768 counts: the difference as
        // signed 16 bits is the motion since the last read.
        self.encoder += now.wrapping_sub(self.last_count) as i16 as i64;
        self.last_count = now;
        inputs.encoders[0] = self.encoder;
        if let Some(i) = self.converting {
            if r32(HS) & COCO0 != 0 {
                self.analog[i] = (r32(R0) & 0xFFF) as f32;
                self.start((i + 1) % ANALOG.len());
            }
        }
        inputs.analog[..ANALOG.len()].copy_from_slice(&self.analog);
    }
}

impl Default for GraphInputs {
    fn default() -> Self {
        Self::new()
    }
}
