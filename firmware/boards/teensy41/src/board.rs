//! The Teensy 4.1 as the node application sees it (`Board`): USB CDC
//! through the rings of [`usb`](crate::usb), GPT1's ticks, the QSPI flash
//! through the ROM, the LED and the button, the graph's inputs, SysTick for
//! sleeping, and a system reset into the bootloader.

use crate::flash::NorFlash;
use crate::inputs::GraphInputs;
use crate::layout::{BOARD, LAYOUT, TICKS_PER_US};
use crate::pinmap::{GpioPin, ANALOG, BUTTON, DIR, ENABLE, LED, STEP};
use crate::pins::TeensyPins;
use crate::{timer, usb};
use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicU32, Ordering::Relaxed};
use cortex_m::peripheral::{syst::SystClkSource, NVIC, SCB, SYST};
use heapless::spsc::{Consumer, Producer};
use motet_firmware::board::{Board, Inputs, Layout, Ticks};
use teensy4_bsp::board::T41Resources;
use teensy4_bsp::hal::adc::ResolutionBits;
use teensy4_bsp::hal::iomuxc::{self, gpio::Pin as GpioPad, Config, Hysteresis, PullKeeper};
use teensy4_bsp::pins::common as p;
use teensy4_bsp::ral::Interrupt;

/// Frames not sent: no host configured the device, or it stopped reading.
pub static TX_DROPPED: AtomicU32 = AtomicU32::new(0);

/// Core clock cycles per tick (600 MHz over the 24 MHz ticks).
const CYCLES_PER_TICK: u32 = 25;

const IOMUXC_GPR: u32 = 0x400A_C000;
const OCOTP_CFG0: u32 = 0x401F_4410;
const OCOTP_CFG1: u32 = 0x401F_4420;
const CCGR2: u32 = 0x400F_C070;
/// CCM_CCGR2's OCOTP gate (CG6).
const OCOTP_GATE: u32 = 0b11 << 12;

/// The pin table's GPIO entries are the pads' GPIO (checked at build time
/// against the pad types): a wrong port or bit fails the build.
macro_rules! pad_is {
    ($pad:ty, $port:literal, $pin:expr) => {
        const _: () =
            assert!($pin.port == $port && <$pad as GpioPad<$port>>::OFFSET == $pin.bit as u32);
    };
}
pad_is!(p::P2, 4, STEP[0]);
pad_is!(p::P4, 4, STEP[1]);
pad_is!(p::P6, 2, STEP[2]);
pad_is!(p::P8, 2, STEP[3]);
pad_is!(p::P3, 4, DIR[0]);
pad_is!(p::P5, 4, DIR[1]);
pad_is!(p::P7, 2, DIR[2]);
pad_is!(p::P9, 2, DIR[3]);
pad_is!(p::P11, 2, ENABLE);
pad_is!(p::P13, 2, LED);
pad_is!(p::P32, 2, BUTTON);
// And the analog entries are the pads' ADC1 inputs.
const _: () = assert!(
    <p::P14 as iomuxc::adc::Pin<1>>::INPUT == ANALOG[0].adc_input as u32
        && <p::P15 as iomuxc::adc::Pin<1>>::INPUT == ANALOG[1].adc_input as u32
);

fn r32(addr: u32) -> u32 {
    // SAFETY: a register of the chip, read.
    unsafe { read_volatile(addr as *const u32) }
}

fn w32(addr: u32, v: u32) {
    // SAFETY: a register of the chip this board owns.
    unsafe { write_volatile(addr as *mut u32, v) }
}

/// Moves `pin` to its fast port (GPIO6–9) as an output or input.
fn fast(pin: &GpioPin, output: bool) {
    let gpr = IOMUXC_GPR + 0x68 + (pin.port as u32 - 1) * 4;
    w32(gpr, r32(gpr) | pin.mask());
    let gdir = pin.fast_base() + 0x04;
    let v = r32(gdir);
    w32(
        gdir,
        if output {
            v | pin.mask()
        } else {
            v & !pin.mask()
        },
    );
}

fn output<P: GpioPad<N>, const N: u8>(pad: &mut P, pin: &GpioPin) {
    w32(pin.clear_addr(), pin.mask());
    fast(pin, true);
    iomuxc::configure(
        pad,
        Config::zero()
            .set_drive_strength(iomuxc::DriveStrength::R0_6)
            .set_speed(iomuxc::Speed::Fast),
    );
    iomuxc::gpio::prepare(pad);
}

fn level(pin: &GpioPin) -> bool {
    r32(pin.fast_base() + 0x08) & pin.mask() != 0
}

pub struct Teensy41 {
    rx: Consumer<'static, u8>,
    tx: Producer<'static, u8>,
    syst: SYST,
    inputs: GraphInputs,
    uid: u64,
    _gpt: teensy4_bsp::hal::gpt::Gpt,
}

impl Teensy41 {
    /// Sets up the pins, the timer, the link and the inputs; returns the
    /// board and the step interrupt's pins. Call once; unmask the step
    /// interrupt (GPT1) afterwards.
    pub fn new(res: T41Resources, syst: SYST) -> (Teensy41, TeensyPins) {
        let T41Resources {
            mut pins,
            mut gpt1,
            flexpwm3,
            mut adc1,
            usb,
            ..
        } = res;
        timer::init(&mut gpt1);

        output(&mut pins.p2, &STEP[0]);
        output(&mut pins.p4, &STEP[1]);
        output(&mut pins.p6, &STEP[2]);
        output(&mut pins.p8, &STEP[3]);
        output(&mut pins.p3, &DIR[0]);
        output(&mut pins.p5, &DIR[1]);
        output(&mut pins.p7, &DIR[2]);
        output(&mut pins.p9, &DIR[3]);
        output(&mut pins.p13, &LED);
        // The drivers stay disabled (EN high) until the outputs are set up.
        w32(ENABLE.set_addr(), ENABLE.mask());
        output(&mut pins.p11, &ENABLE);
        w32(ENABLE.set_addr(), ENABLE.mask());

        let pull_up = Config::zero()
            .set_pull_keeper(Some(PullKeeper::Pullup100k))
            .set_hysteresis(Hysteresis::Enabled);
        fast(&BUTTON, false);
        iomuxc::configure(&mut pins.p32, pull_up);
        iomuxc::gpio::prepare(&mut pins.p32);

        // Encoder phases: QuadTimer 1's inputs 0 and 1 (ALT1 of both pads).
        iomuxc::configure(&mut pins.p10, pull_up);
        iomuxc::alternate(&mut pins.p10, 1);
        iomuxc::configure(&mut pins.p12, pull_up);
        iomuxc::alternate(&mut pins.p12, 1);

        iomuxc::flexpwm::prepare(&mut pins.p28);
        iomuxc::flexpwm::prepare(&mut pins.p29);
        let step_pins = TeensyPins::new(flexpwm3);

        adc1.set_resolution(ResolutionBits::Res10);
        adc1.calibrate();
        iomuxc::adc::prepare::<_, 1>(&mut pins.p14);
        iomuxc::adc::prepare::<_, 1>(&mut pins.p15);
        // ADC1 is read through its registers from here on (`adc1` only set
        // it up).
        let inputs = GraphInputs::new();

        w32(CCGR2, r32(CCGR2) | OCOTP_GATE);
        let uid = ((r32(OCOTP_CFG1) as u64) << 32) | r32(OCOTP_CFG0) as u64;

        let (rx, tx) = usb::init(usb);
        // SAFETY: the handlers are in the binary's vector table;
        // priorities are set before unmasking (the step interrupt first).
        unsafe {
            let mut cp = cortex_m::Peripherals::steal();
            cp.NVIC.set_priority(Interrupt::GPT1, 0);
            cp.NVIC.set_priority(Interrupt::USB_OTG1, 0x80);
            NVIC::unmask(Interrupt::USB_OTG1);
        }
        // Outputs are low and known: the drivers may take them.
        w32(ENABLE.clear_addr(), ENABLE.mask());
        (
            Teensy41 {
                rx,
                tx,
                syst,
                inputs,
                uid,
                _gpt: gpt1,
            },
            step_pins,
        )
    }
}

/// SysTick ends a sleep: one shot.
pub fn on_systick() {
    // SAFETY: SysTick's control register; stopping it is all this does.
    unsafe { (*SYST::PTR).csr.write(0) };
}

impl Board for Teensy41 {
    const NAME: &'static str = BOARD;
    const TICKS_PER_US: u32 = TICKS_PER_US;
    const CHANNELS: u8 = STEP.len() as u8;
    const TOOLS: u8 = crate::pinmap::TOOLS.len() as u8;
    /// What one channel's default 2 µs pulses and lows allow; the step
    /// engine's cost (docs/firmware.md) allows more across the four.
    const MAX_STEP_HZ: u32 = 250_000;
    const LAYOUT: Layout = LAYOUT;
    type Flash = NorFlash;

    fn uid(&self) -> u64 {
        self.uid
    }

    fn ticks(&self) -> Ticks {
        timer::now()
    }

    fn link_read(&mut self, buf: &mut [u8]) -> usize {
        usb::FRAME_END.store(false, Relaxed);
        let mut n = 0;
        while n < buf.len() {
            match self.rx.dequeue() {
                Some(b) => {
                    buf[n] = b;
                    n += 1;
                }
                None => break,
            }
        }
        n
    }

    fn link_write(&mut self, bytes: &[u8]) {
        let room = self.tx.capacity() - self.tx.len();
        if !usb::CONFIGURED.load(Relaxed) || room < bytes.len() {
            // A whole frame or none: no host, or one that stopped reading.
            TX_DROPPED.fetch_add(1, Relaxed);
            return;
        }
        for &b in bytes {
            let _ = self.tx.enqueue(b);
        }
        NVIC::pend(Interrupt::USB_OTG1);
    }

    fn link_flush(&mut self) {
        // Bounded: a host that stopped reading must not hold a restart.
        let start = timer::now();
        while !self.tx.is_empty() && usb::CONFIGURED.load(Relaxed) {
            if timer::now().wrapping_sub(start) > 200_000 * TICKS_PER_US {
                break;
            }
            NVIC::pend(Interrupt::USB_OTG1);
        }
    }

    fn flash(&self) -> NorFlash {
        NorFlash
    }

    fn set_led(&mut self, on: bool) {
        let addr = if on { LED.set_addr() } else { LED.clear_addr() };
        w32(addr, LED.mask());
    }

    fn button(&mut self) -> bool {
        // To ground, pulled up: pressed reads low.
        !level(&BUTTON)
    }

    fn read_inputs(&mut self, inputs: &mut Inputs) {
        self.inputs.read(inputs);
    }

    fn kick_steps(&mut self) {
        NVIC::pend(Interrupt::GPT1);
    }

    fn sleep_until(&mut self, until: Ticks) {
        self.syst.set_clock_source(SystClkSource::Core);
        self.syst.enable_interrupt();
        loop {
            // Interrupts masked while deciding: WFI still returns on one
            // that becomes pending, and it runs once they are unmasked.
            let done = cortex_m::interrupt::free(|_| {
                let left = until.wrapping_sub(timer::now()) as i32;
                if left <= 0 || usb::FRAME_END.load(Relaxed) {
                    return true;
                }
                // SysTick counts the 600 MHz core clock, 24 bits: 28 ms.
                let cycles = (left as u32).saturating_mul(CYCLES_PER_TICK);
                self.syst.set_reload(cycles.min(0x00FF_FFFF));
                self.syst.clear_current();
                self.syst.enable_counter();
                cortex_m::asm::wfi();
                false
            });
            self.syst.disable_counter();
            if done {
                return;
            }
        }
    }

    fn restart(&mut self) -> ! {
        SCB::sys_reset()
    }
}
