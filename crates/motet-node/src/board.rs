//! What a node drives: the board's step/direction pins and tool outputs.

/// The hardware a node runs on. Firmware implements it with timers and pins; the
/// simulator implements it with a simulated plant.
pub trait Board {
    /// Take one step on `channel` at host time `at_us`. `forward` is the state of
    /// the direction output (after inversion).
    fn step(&mut self, channel: u8, forward: bool, at_us: f64);

    /// Set tool output `output` to `value` at host time `at_us`.
    fn set_tool(&mut self, output: u8, value: f32, at_us: f64);
}
