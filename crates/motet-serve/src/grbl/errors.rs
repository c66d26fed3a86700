//! grbl's numbered errors and alarms, and which one a motet error is.

/// `error:N` codes grbl 1.1 uses, by name.
pub mod code {
    /// G-code words consist of a letter and a value; the letter is missing.
    pub const EXPECTED_LETTER: u8 = 1;
    /// Numeric value format is not valid or missing an expected value.
    pub const BAD_NUMBER: u8 = 2;
    /// `$` statement not recognised or supported.
    pub const INVALID_STATEMENT: u8 = 3;
    /// Negative value received for an expected positive value.
    pub const NEGATIVE: u8 = 4;
    /// Homing cycle is not enabled via settings.
    pub const HOMING_DISABLED: u8 = 5;
    /// `$` command that needs the machine idle.
    pub const NOT_IDLE: u8 = 8;
    /// G-code locked out during alarm or jog state.
    pub const LOCKED: u8 = 9;
    /// Max characters per line exceeded.
    pub const OVERFLOW: u8 = 11;
    /// Jog target exceeds machine travel.
    pub const TRAVEL: u8 = 15;
    /// Jog command with no `=` or with prohibited G-code.
    pub const BAD_JOG: u8 = 16;
    /// Invalid line number (`N`).
    pub const LINE_NUMBER: u8 = 27;
    /// Unsupported or invalid G-code command.
    pub const UNSUPPORTED: u8 = 20;
    /// More than one G-code command from the same modal group.
    pub const MODAL_GROUP: u8 = 21;
    /// Feed rate has not yet been set or is undefined.
    pub const UNDEFINED_FEED: u8 = 22;
    /// Two G-code commands that both require the axis words.
    pub const AXIS_CONFLICT: u8 = 24;
    /// A G-code word was repeated in the block.
    pub const REPEATED: u8 = 25;
    /// A command that needs axis words got none.
    pub const NO_AXIS_WORDS: u8 = 26;
    /// An arc's target is invalid.
    pub const INVALID_TARGET: u8 = 33;
    /// The arc's radius does not fit its ends.
    pub const ARC_RADIUS: u8 = 34;
}

/// `ALARM:N` codes.
pub mod alarm {
    /// Motion target exceeds machine travel.
    pub const SOFT_LIMIT: u8 = 2;
    /// Reset while in motion: position may be lost (here it is not: the
    /// machine braked on its path, but grbl's senders expect the alarm).
    pub const ABORT_CYCLE: u8 = 3;
}

/// The grbl error for a G-code error motet's interpreter reported, from
/// its message (the interpreter's messages are stable and tested).
pub fn of_gcode(message: &str) -> u8 {
    let m = message.to_ascii_lowercase();
    let has = |s: &str| m.contains(s);
    if has("bad line number") {
        code::LINE_NUMBER
    } else if has("unexpected character") {
        code::EXPECTED_LETTER
    } else if has("must be positive") {
        code::NEGATIVE
    } else if has("same modal group") {
        code::MODAL_GROUP
    } else if has("without a feed rate") {
        code::UNDEFINED_FEED
    } else if has("twice") || has("repeated") {
        code::REPEATED
    } else if has("axis word") && has("needs") {
        code::NO_AXIS_WORDS
    } else if has("on one line") {
        code::AXIS_CONFLICT
    } else if has("radius") {
        code::ARC_RADIUS
    } else if has("circle") || has("arc") {
        code::INVALID_TARGET
    } else if has("number") || has("value") {
        code::BAD_NUMBER
    } else if has("letter") {
        code::EXPECTED_LETTER
    } else {
        code::UNSUPPORTED
    }
}
