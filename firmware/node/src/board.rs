//! What a board gives the node application: the board trait.
//!
//! A board crate implements three traits, and nothing else in the firmware
//! touches hardware:
//!
//! - [`Board`]: the background side: the link (a UART, or USB CDC), the
//!   free-running tick counter the µs clock is read from, flash pages, the
//!   LED and the button, the graph's inputs, sleeping and restarting.
//! - [`Pins`]: the interrupt side, used only from the step timer's
//!   interrupt: step, direction and tool outputs, and the timer's compare.
//! - [`FlashPages`]: erase and program sectors of the board's flash, for
//!   the node's identity, the bootloader's request and the firmware slots
//!   laid out by [`Layout`].
//!
//! The board's interrupt handler calls
//! [`StepInterrupt::run`](crate::interrupt::StepInterrupt::run) with its
//! `Pins`; its `main` hands the queue's producer and the `Board` to
//! [`app::run`](crate::app::run). `docs/firmware.md` walks through a new
//! board.

use motet_node::graph::MAX_HW;
pub use motet_node::storage::StorageError;

/// Ticks of the board's free-running counter; wraps at 2³².
pub type Ticks = u32;

/// The fixed-point time tolerance of a board without a floating-point
/// unit, µs ([`Board::FIXED_TIME_US`]): a twentieth of a 1 µs timer tick
/// (docs/firmware.md), the Pico's and its benchmark's.
pub const NO_FPU_FIXED_TIME_US: f64 = 0.05;

/// The background side of a board. Every method is called from the main
/// loop only.
pub trait Board {
    /// The board's name in firmware images (`mps2-an500`, `teensy41`,
    /// `pico`): an image naming another board is refused.
    const NAME: &'static str;
    /// Counter ticks per µs. The µs clock, the step times and the pulse
    /// widths are all counted in these ticks.
    const TICKS_PER_US: u32;
    /// Step/direction channels with pins (at most `motet_node::MAX_CHANNELS`).
    const CHANNELS: u8;
    /// Tool outputs (PWM or servo) with pins (at most `motet_node::MAX_TOOLS`).
    const TOOLS: u8;
    /// The fastest step rate one channel gets, steps/s: what the board
    /// promises the host (`Info::max_step_hz`), from the measured cost of
    /// the step engine (docs/firmware.md).
    const MAX_STEP_HZ: u32;
    /// Where the identity, the boot request and the firmware slots are.
    const LAYOUT: Layout;
    /// A board without a floating-point unit solves its steps in
    /// fixed-point time, each within this many µs of its exact time
    /// (`motet_node::Node::use_fixed_time`); 0 (the default): exactly, in
    /// `f64`.
    const FIXED_TIME_US: f64 = 0.0;

    type Flash: FlashPages;

    /// The chip's unique id (fuses, OTP, or the flash chip's id).
    fn uid(&self) -> u64;
    /// The free-running counter (the same one [`Pins::now`] reads).
    fn ticks(&self) -> Ticks;
    /// Moves received link bytes into `buf`; returns how many (0: none now).
    fn link_read(&mut self, buf: &mut [u8]) -> usize;
    /// Queues `bytes` for sending. May wait for room; a USB board with no
    /// host attached drops them, as a cable would.
    fn link_write(&mut self, bytes: &[u8]);
    /// Waits until everything written has left (before a restart).
    fn link_flush(&mut self);
    /// The board's flash, for the identity store, the firmware staging area
    /// and the boot request. A handle: each one reaches the same flash.
    fn flash(&self) -> Self::Flash;
    fn set_led(&mut self, on: bool);
    /// The button's level (pressed: true); the application finds the edges.
    fn button(&mut self) -> bool;
    /// Reads the motion-stream graph's inputs (encoder counts, analog
    /// readings, digital levels) into `inputs`. Boards without an
    /// input leave it as it is.
    fn read_inputs(&mut self, inputs: &mut Inputs);
    /// Makes the step interrupt run soon (pending it): operations were
    /// queued while it may have had nothing to wait for.
    fn kick_steps(&mut self);
    /// Sleeps until an interrupt (link, step timer) or until tick `until`,
    /// whichever comes first. A board may return early.
    fn sleep_until(&mut self, until: Ticks);
    /// Restarts the chip into its bootloader (after [`Board::link_flush`]).
    fn restart(&mut self) -> !;
    /// A line of diagnostics for a person (a debug UART); none by default.
    fn console(&mut self, _line: core::fmt::Arguments<'_>) {}
}

/// The interrupt side: what the step interrupt drives. Implementations are
/// a few register writes each; they run for every step.
pub trait Pins {
    /// The free-running counter, as [`Board::ticks`].
    fn now(&self) -> Ticks;
    /// Step output of `channel` high (the driver steps on this edge).
    fn step_high(&mut self, channel: u8);
    fn step_low(&mut self, channel: u8);
    fn set_dir(&mut self, channel: u8, forward: bool);
    /// Tool output `output` at `duty` of full scale (PWM duty, or a servo's
    /// travel), 0..=65535.
    fn set_tool(&mut self, output: u8, duty: u16);
    /// Interrupt again at tick `at` (at once if it has passed).
    fn arm(&mut self, at: Ticks);
    /// No interrupt until [`Board::kick_steps`].
    fn disarm(&mut self);
}

/// A board's flash, by offset from the start of the part the firmware
/// manages. Erased bytes read 0xFF; programming only clears bits, so a
/// sector is erased before it is written again.
pub trait FlashPages {
    /// Erase unit, bytes (a power of two).
    const SECTOR: u32;
    /// Erases the sector starting at `at` (a multiple of [`Self::SECTOR`]).
    fn erase(&mut self, at: u32) -> Result<(), StorageError>;
    /// Programs `data` at `at` into erased flash.
    fn program(&mut self, at: u32, data: &[u8]) -> Result<(), StorageError>;
    fn read(&self, at: u32, buf: &mut [u8]) -> Result<(), StorageError>;
}

/// A range of flash, by offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub start: u32,
    pub len: u32,
}

impl Region {
    pub const fn end(&self) -> u32 {
        self.start + self.len
    }
}

/// Where things are in a board's flash (offsets for [`FlashPages`]), and
/// what a runnable application looks like to the bootloader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Two sectors: the identity record, written to each in turn.
    pub identity: Region,
    /// One sector: the application's request to the bootloader.
    pub request: Region,
    /// The installed image: its header at the start, its payload at
    /// `app.start + app_header` (where the application is linked).
    pub app: Region,
    /// Room for the header before the payload in the application slot.
    pub app_header: u32,
    /// The address the CPU runs the payload at (the application's link
    /// address: its vector table).
    pub app_exec: u32,
    /// Where the application's stack may start (the initial stack pointer
    /// in its vector table must lie in this RAM).
    pub ram: (u32, u32),
    /// Where an upload is written before the bootloader installs it.
    pub staging: Region,
}

/// The graph's inputs as a board reads them: encoder counts, analog
/// readings in the units the graph's `AnalogInput` expects (raw ADC counts),
/// digital levels (true: pressed or active).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inputs {
    pub encoders: [i64; MAX_HW],
    pub analog: [f32; MAX_HW],
    pub digital: [bool; MAX_HW],
}
