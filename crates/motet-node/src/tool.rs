//! Tool outputs: a pen servo, a laser or a spindle following an event track.
//!
//! An output is either fixed (it takes each event's value at the event's time)
//! or follows the path speed: a laser set to `value` per `feed` gives
//! `value × speed / feed`, capped at `value`, refreshed every
//! [`PER_SPEED_UPDATE_US`], so ramps and corners get the same energy per
//! millimetre as the straight runs.

use motet_wire::ToolConfig;

/// How often an output that follows the path speed is refreshed, µs.
pub const PER_SPEED_UPDATE_US: f64 = 1000.0;

/// Smallest change of a speed-following output worth sending to the board.
const RESOLUTION: f32 = 1.0 / 1024.0;

#[derive(Clone, Copy, Debug, PartialEq)]
/// One tool output following an event track: fixed, or following the path speed.
pub struct ToolOutput {
    /// The board output id and the event track it follows.
    pub config: ToolConfig,
    /// The value the latest event asked for.
    value: f32,
    /// Speed at which the output reaches `value`; 0 when the output is fixed.
    feed: f32,
    /// What the board was last given.
    last: f32,
    /// Next refresh of a speed-following output; infinite when none is due.
    next_update: f64,
}

impl ToolOutput {
    /// An output at 0, fixed until an event says otherwise.
    pub fn new(config: ToolConfig) -> ToolOutput {
        ToolOutput {
            config,
            value: 0.0,
            feed: 0.0,
            last: 0.0,
            next_update: f64::INFINITY,
        }
    }

    /// The board output id.
    pub fn output(&self) -> u8 {
        self.config.output
    }

    /// When the output next needs a refresh, if it follows the speed.
    pub fn next_update(&self) -> Option<f64> {
        self.next_update.is_finite().then_some(self.next_update)
    }

    /// Takes an event's value; returns what the board should get now.
    pub fn set(&mut self, value: f32, feed: f32, time: f64, speed: Option<f64>) -> f32 {
        self.value = value;
        self.feed = feed;
        let out = self.scaled(speed);
        self.last = out;
        self.next_update = if feed > 0.0 && speed.is_some() {
            after_period(time)
        } else {
            f64::INFINITY
        };
        out
    }

    /// A refresh at `time` with the path speed then (`None` when no motion is
    /// queued at or after it). Returns a new board value if it changed.
    pub fn refresh(&mut self, time: f64, speed: Option<f64>) -> Option<f32> {
        self.next_update = if speed.is_some() {
            after_period(time)
        } else {
            f64::INFINITY
        };
        let out = self.scaled(speed);
        if (out - self.last).abs() >= RESOLUTION || (out == 0.0) != (self.last == 0.0) {
            self.last = out;
            Some(out)
        } else {
            None
        }
    }

    /// Nothing moves before `t`: the next refresh need not come earlier.
    pub fn defer(&mut self, t: f64) {
        if self.next_update.is_finite() && t > self.next_update {
            self.next_update = t;
        }
    }

    /// New motion arrived: a speed-following output that went idle resumes at `t`.
    pub fn wake(&mut self, t: f64) {
        if self.feed > 0.0 && !self.next_update.is_finite() {
            self.next_update = t;
        }
    }

    fn scaled(&self, speed: Option<f64>) -> f32 {
        if self.feed <= 0.0 {
            return self.value;
        }
        let ratio = (speed.unwrap_or(0.0) / self.feed as f64).clamp(0.0, 1.0);
        self.value * ratio as f32
    }
}

/// The next refresh after `time`; none where a period no longer changes an
/// `f64` (beyond 2⁶³ µs, reached only through a nonsensical clock model):
/// a refresh due at the same time again would keep `poll` busy for good.
fn after_period(time: f64) -> f64 {
    let next = time + PER_SPEED_UPDATE_US;
    if next > time {
        next
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by fuzzing: with host time past 2⁶³ µs a refresh was due again
    /// at the same time, and `poll` never returned.
    #[test]
    fn refreshes_always_move_on() {
        for time in [0.0, 1e6, 1e15, 1e17, 1e20, 1e300] {
            let mut t = ToolOutput::new(ToolConfig {
                output: 0,
                track: 0,
            });
            t.set(1.0, 10.0, time, Some(5.0));
            let next = t.next_update();
            assert!(
                next.is_none_or(|n| n > time),
                "set at {time}: next {next:?}"
            );
            t.refresh(time, Some(5.0));
            let next = t.next_update();
            assert!(
                next.is_none_or(|n| n > time),
                "refresh at {time}: next {next:?}"
            );
        }
    }
}
