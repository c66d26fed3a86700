//! The emulated board as the node application sees it (`Board`): UART0
//! through byte rings filled and drained by its interrupts, Timer0's ticks,
//! the emulated flash, the FPGA's LED and button, SysTick for sleeping, and
//! a system reset into the bootloader.

use crate::flash::EmulatedFlash;
use crate::irq::Irq;
use crate::layout::{BOARD, LAYOUT, TICKS_PER_US, UID_ADDR};
use crate::uart::Uart;
use crate::{console, timer};
use core::cell::RefCell;
use core::ptr::{addr_of_mut, read_volatile, write_volatile};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};
use cortex_m::interrupt::Mutex;
use cortex_m::peripheral::{syst::SystClkSource, NVIC, SCB, SYST};
use heapless::spsc::{Consumer, Producer, Queue};
use heapless::Deque;
use motet_firmware::board::{Board, Inputs, Layout, Ticks};

const FPGAIO_LED: u32 = 0x4002_8000;
const FPGAIO_BUTTON: u32 = 0x4002_8008;

static mut RX_QUEUE: Queue<u8, 2048> = Queue::new();
/// The RX ring's producer half, owned by the UART0 RX interrupt once set.
static mut RX_PRODUCER: Option<Producer<'static, u8>> = None;
static TX_RING: Mutex<RefCell<Deque<u8, 4096>>> = Mutex::new(RefCell::new(Deque::new()));

/// A frame delimiter arrived since the main loop last read the link: a
/// sleeping loop wakes for whole frames, not for every byte.
static FRAME_END: AtomicBool = AtomicBool::new(false);

/// Bytes lost because the RX ring was full.
pub static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
/// Frames not sent because the TX ring had no room (no host reading).
pub static TX_DROPPED: AtomicU32 = AtomicU32::new(0);

/// UART0's receive interrupt: bytes into the RX ring.
pub fn on_uart0_rx() {
    Uart::UART0.clear();
    // SAFETY: set in `Mps2::new` before the interrupt was unmasked; only
    // this interrupt uses it afterwards.
    let producer = unsafe { (*addr_of_mut!(RX_PRODUCER)).as_mut() };
    let Some(p) = producer else {
        return;
    };
    while let Some(b) = Uart::UART0.read_byte() {
        if p.enqueue(b).is_err() {
            RX_DROPPED.store(RX_DROPPED.load(Relaxed) + 1, Relaxed);
        }
        if b == 0 {
            FRAME_END.store(true, Relaxed);
        }
    }
}

/// Moves TX ring bytes into the UART while it takes them.
fn pump(cs: &cortex_m::interrupt::CriticalSection) {
    let mut ring = TX_RING.borrow(cs).borrow_mut();
    while !Uart::UART0.tx_full() {
        match ring.pop_front() {
            Some(b) => Uart::UART0.write_byte(b),
            None => break,
        }
    }
}

/// UART0's transmit interrupt: the next bytes of the TX ring.
pub fn on_uart0_tx() {
    Uart::UART0.clear();
    cortex_m::interrupt::free(pump);
}

/// SysTick ends a sleep: one shot.
pub fn on_systick() {
    // SAFETY: SysTick's control register; stopping it is all this does.
    unsafe { (*SYST::PTR).csr.write(0) };
}

pub struct Mps2 {
    rx: Consumer<'static, u8>,
    syst: SYST,
}

impl Mps2 {
    /// Sets up the link UART, its rings and interrupts, the console and the
    /// timers. Call once.
    pub fn new(syst: SYST) -> Mps2 {
        timer::init();
        Uart::UART1.init(false);
        // SAFETY: called once, before the UART interrupts are unmasked:
        // nothing else holds the queue.
        let (producer, consumer) = unsafe { (*addr_of_mut!(RX_QUEUE)).split() };
        unsafe { *addr_of_mut!(RX_PRODUCER) = Some(producer) };
        Uart::UART0.init(true);
        // SAFETY: the handlers these lines reach are set in the binary's
        // vector table; priorities are set before unmasking.
        unsafe {
            let mut p = cortex_m::Peripherals::steal();
            p.NVIC.set_priority(Irq::Timer1, 0);
            p.NVIC.set_priority(Irq::Uart0Rx, 0x80);
            p.NVIC.set_priority(Irq::Uart0Tx, 0x80);
            NVIC::unmask(Irq::Uart0Rx);
            NVIC::unmask(Irq::Uart0Tx);
        }
        Mps2 { rx: consumer, syst }
    }
}

impl Board for Mps2 {
    const NAME: &'static str = BOARD;
    const TICKS_PER_US: u32 = TICKS_PER_US;
    const CHANNELS: u8 = 8;
    const TOOLS: u8 = 4;
    /// What one channel gets with its default 2 µs pulses and lows
    /// (docs/firmware.md gives the measured interrupt cost per step).
    const MAX_STEP_HZ: u32 = 250_000;
    const LAYOUT: Layout = LAYOUT;
    type Flash = EmulatedFlash;

    fn uid(&self) -> u64 {
        // SAFETY: the uid word the emulator writes, in RAM.
        let uid = unsafe { read_volatile(UID_ADDR as *const u64) };
        if uid == 0 {
            // No uid given on the emulator's command line.
            0x6d70_7332_0000_0001
        } else {
            uid
        }
    }

    fn ticks(&self) -> Ticks {
        timer::now()
    }

    fn link_read(&mut self, buf: &mut [u8]) -> usize {
        FRAME_END.store(false, Relaxed);
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
        cortex_m::interrupt::free(|cs| {
            {
                let mut ring = TX_RING.borrow(cs).borrow_mut();
                if ring.capacity() - ring.len() < bytes.len() {
                    // A whole frame or none: a host that reads again gets
                    // it resent by the link, not half of it.
                    TX_DROPPED.store(TX_DROPPED.load(Relaxed) + 1, Relaxed);
                    return;
                }
                for &b in bytes {
                    let _ = ring.push_back(b);
                }
            }
            pump(cs);
        });
    }

    fn link_flush(&mut self) {
        // Bounded: a terminal nobody reads must not hold a restart back.
        let start = timer::now();
        while cortex_m::interrupt::free(|cs| !TX_RING.borrow(cs).borrow().is_empty()) {
            if timer::now().wrapping_sub(start) > 200_000 * TICKS_PER_US {
                break;
            }
            cortex_m::interrupt::free(pump);
        }
    }

    fn flash(&self) -> EmulatedFlash {
        EmulatedFlash
    }

    fn set_led(&mut self, on: bool) {
        // SAFETY: the FPGA IO block's LED register.
        unsafe { write_volatile(FPGAIO_LED as *mut u32, on as u32) }
    }

    fn button(&mut self) -> bool {
        // SAFETY: the FPGA IO block's button register (QEMU has no way to
        // press it: pair by SetAddress, the node alone on its link).
        unsafe { read_volatile(FPGAIO_BUTTON as *const u32) & 1 != 0 }
    }

    fn read_inputs(&mut self, _inputs: &mut Inputs) {
        // The emulated board has no encoder or ADC: the graph's inputs come
        // from the host (GraphInput).
    }

    fn kick_steps(&mut self) {
        NVIC::pend(Irq::Timer1);
    }

    fn sleep_until(&mut self, until: Ticks) {
        self.syst.set_clock_source(SystClkSource::Core);
        self.syst.enable_interrupt();
        loop {
            // Interrupts masked while deciding: WFI still returns on one
            // that becomes pending, and it runs once they are unmasked.
            let done = cortex_m::interrupt::free(|_| {
                let left = until.wrapping_sub(timer::now()) as i32;
                if left <= 0 || FRAME_END.load(Relaxed) {
                    return true;
                }
                // SysTick counts the 25 MHz core clock, 24 bits: 0.67 s.
                self.syst.set_reload((left as u32).min(0x00FF_FFFF));
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

    fn console(&mut self, line: core::fmt::Arguments<'_>) {
        console::line(line);
    }
}
