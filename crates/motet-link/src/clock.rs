//! Clocks in µs. The link and network code never reads a clock itself: every
//! call takes `now`, or a [`Clock`] to read it from, so the same code runs on
//! the wall clock and on a simulated one (tests, fault injection, runs faster
//! than real time).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A source of the current time in µs, and how to wait for it to pass.
pub trait Clock {
    /// The time now, in µs since the clock's own origin.
    fn now_us(&self) -> u64;

    /// How long `us` µs of this clock take in real time: how long a caller
    /// may block (on a transport, in a sleep) while they pass. A clock
    /// advanced by someone else ([`SimClock`]) answers zero: the caller polls.
    fn real(&self, us: u64) -> Duration {
        Duration::from_micros(us)
    }

    /// Waits while `us` µs of this clock pass (yields once when that takes
    /// no real time).
    fn sleep_us(&self, us: u64) {
        let d = self.real(us);
        if d.is_zero() {
            std::thread::yield_now();
        } else {
            std::thread::sleep(d);
        }
    }
}

/// The wall clock since creation, optionally scaled (a simulated node or a dry
/// run may run its time faster than real time) and skewed like a crystal off
/// by `ppm` parts per million.
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    start: Instant,
    rate: f64,
    offset_us: u64,
}

impl WallClock {
    /// The unscaled wall clock, at 0 now.
    pub fn new() -> WallClock {
        WallClock::with(1.0, 0.0, 0)
    }

    /// The unscaled wall clock, at 0 at `start` (another clock's origin:
    /// a server's, for what its transports stamp).
    pub fn since(start: Instant) -> WallClock {
        WallClock {
            start,
            rate: 1.0,
            offset_us: 0,
        }
    }

    /// `scale` µs of this clock per real µs, times `1 + ppm·10⁻⁶`; starts at `offset_us`.
    pub fn with(scale: f64, ppm: f64, offset_us: u64) -> WallClock {
        WallClock {
            start: Instant::now(),
            rate: scale * (1.0 + ppm * 1e-6),
            offset_us,
        }
    }
}

impl WallClock {
    /// µs of this clock per real µs.
    pub fn rate(&self) -> f64 {
        self.rate
    }
}

impl Default for WallClock {
    fn default() -> Self {
        WallClock::new()
    }
}

impl Clock for WallClock {
    fn now_us(&self) -> u64 {
        self.offset_us + (self.start.elapsed().as_secs_f64() * 1e6 * self.rate) as u64
    }

    fn real(&self, us: u64) -> Duration {
        Duration::from_secs_f64(us as f64 * 1e-6 / self.rate)
    }
}

/// A crystal's clock against a reference (the host's, a bus's): off by
/// `ppm` parts per million and reading `offset_us` at the reference's 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Crystal {
    /// Crystal error, parts per million (positive: the clock runs fast).
    pub ppm: f64,
    /// The clock at reference time 0, µs.
    pub offset_us: u64,
}

impl Crystal {
    /// The clock's reading (whole µs) at reference time `reference_us`.
    pub fn local(&self, reference_us: f64) -> u64 {
        self.offset_us + (reference_us * (1.0 + self.ppm * 1e-6)) as u64
    }

    /// The reference time at which the clock reads `local_us` (whole µs).
    pub fn reference(&self, local_us: u64) -> u64 {
        (local_us.saturating_sub(self.offset_us) as f64 / (1.0 + self.ppm * 1e-6)) as u64
    }
}

/// A simulated clock in µs, shared by clones, advanced by whoever drives the
/// simulation ([`SimClock::set`], [`SimClock::advance`]).
#[derive(Clone, Debug, Default)]
pub struct SimClock(Arc<AtomicU64>);

impl SimClock {
    /// A simulated clock at 0.
    pub fn new() -> SimClock {
        SimClock::default()
    }

    /// The time now, µs.
    pub fn get(&self) -> u64 {
        self.0.load(Ordering::Relaxed)
    }

    /// Moves the clock to `us` µs; every handle on it sees the new time.
    /// Nothing stops it from going back: the caller keeps it monotonic.
    pub fn set(&self, us: u64) {
        self.0.store(us, Ordering::Relaxed);
    }

    /// Moves the clock `us` µs ahead.
    pub fn advance(&self, us: u64) {
        self.0.fetch_add(us, Ordering::Relaxed);
    }
}

impl Clock for SimClock {
    fn now_us(&self) -> u64 {
        self.get()
    }

    /// No real time: the simulation's driver advances this clock.
    fn real(&self, _us: u64) -> Duration {
        Duration::ZERO
    }
}

impl<C: Clock + ?Sized> Clock for &C {
    fn now_us(&self) -> u64 {
        (**self).now_us()
    }

    fn real(&self, us: u64) -> Duration {
        (**self).real(us)
    }
}

impl<C: Clock + ?Sized> Clock for Arc<C> {
    fn now_us(&self) -> u64 {
        (**self).now_us()
    }

    fn real(&self, us: u64) -> Duration {
        (**self).real(us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wall_clock_scale_and_offset() {
        // (scale, ppm, µs of the clock, real time they take)
        let cases = [
            (1.0, 0.0, 1_000_000, 1.0),
            (10.0, 0.0, 1_000_000, 0.1),
            (1.0, 1e6, 1_000_000, 0.5),
        ];
        for (scale, ppm, us, secs) in cases {
            let c = WallClock::with(scale, ppm, 5);
            assert!(
                (c.real(us).as_secs_f64() - secs).abs() < 1e-9,
                "{scale} {ppm}"
            );
            assert!(c.now_us() >= 5);
        }
    }

    #[test]
    fn sim_clock_is_shared_and_never_blocks() {
        let a = SimClock::new();
        let b = a.clone();
        a.set(100);
        b.advance(23);
        let dynamic: &dyn Clock = &a;
        assert_eq!(dynamic.now_us(), 123);
        assert_eq!(dynamic.real(1_000_000), Duration::ZERO);
        dynamic.sleep_us(1_000_000);
        assert_eq!(Arc::new(b).now_us(), 123);
    }
}
