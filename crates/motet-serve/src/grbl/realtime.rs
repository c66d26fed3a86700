//! Real-time bytes: taken out of the byte stream wherever they come and
//! acted on at once, never part of a line; and the overrides they set.

/// A real-time command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Realtime {
    /// `0x18`: soft reset.
    Reset,
    /// `?`: status report.
    Status,
    /// `~`: cycle start / resume.
    Resume,
    /// `!`: feed hold.
    Hold,
    /// `0x84`: safety door (acted on as a feed hold).
    Door,
    /// `0x85`: jog cancel.
    JogCancel,
    /// `0x90`…`0x94`: feed override reset, +10, −10, +1, −1 %.
    Feed(i8),
    /// `0x95`…`0x97`: rapid override 100, 50, 25 %.
    Rapid(u8),
    /// `0x99`…`0x9D`: spindle override reset, +10, −10, +1, −1 %.
    Spindle(i8),
    /// `0x9E`, `0xA0`, `0xA1`: spindle stop, coolant toggles (reported,
    /// not acted on).
    Toggle,
}

/// Reset marker for [`Realtime::Feed`] and [`Realtime::Spindle`].
pub const RESET: i8 = 0;

/// The real-time command `b` is, if any. Other bytes from 0x80 up are
/// dropped (grbl ignores them too).
pub fn classify(b: u8) -> Option<Realtime> {
    Some(match b {
        0x18 => Realtime::Reset,
        b'?' => Realtime::Status,
        b'~' => Realtime::Resume,
        b'!' => Realtime::Hold,
        0x84 => Realtime::Door,
        0x85 => Realtime::JogCancel,
        0x90 => Realtime::Feed(RESET),
        0x91 => Realtime::Feed(10),
        0x92 => Realtime::Feed(-10),
        0x93 => Realtime::Feed(1),
        0x94 => Realtime::Feed(-1),
        0x95 => Realtime::Rapid(100),
        0x96 => Realtime::Rapid(50),
        0x97 => Realtime::Rapid(25),
        0x99 => Realtime::Spindle(RESET),
        0x9A => Realtime::Spindle(10),
        0x9B => Realtime::Spindle(-10),
        0x9C => Realtime::Spindle(1),
        0x9D => Realtime::Spindle(-1),
        0x9E | 0xA0 | 0xA1 => Realtime::Toggle,
        _ => return None,
    })
}

/// Whether `b` is dropped from the line stream without meaning anything.
pub fn ignored(b: u8) -> bool {
    b >= 0x80
}

/// Feed, rapid and spindle overrides, percent, as grbl bounds them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Overrides {
    /// Feed: 10…200 %.
    pub feed: u8,
    /// Rapid: 25, 50 or 100 %.
    pub rapid: u8,
    /// Spindle (tool power): 10…200 %.
    pub spindle: u8,
}

impl Default for Overrides {
    fn default() -> Self {
        Overrides {
            feed: 100,
            rapid: 100,
            spindle: 100,
        }
    }
}

fn step(v: u8, by: i8) -> u8 {
    if by == RESET {
        100
    } else {
        (i16::from(v) + i16::from(by)).clamp(10, 200) as u8
    }
}

impl Overrides {
    /// Applies one override byte.
    pub fn apply(&mut self, r: Realtime) {
        match r {
            Realtime::Feed(by) => self.feed = step(self.feed, by),
            Realtime::Spindle(by) => self.spindle = step(self.spindle, by),
            Realtime::Rapid(p) => self.rapid = p,
            _ => {}
        }
    }
}
