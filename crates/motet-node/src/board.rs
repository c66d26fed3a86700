//! What a node drives: the board's step/direction pins and tool outputs,
//! and, for closed loops, its encoders, drive outputs, sensors and limit
//! switches.

/// The hardware a node runs on. Firmware implements it with timers and pins; the
/// simulator implements it with a simulated plant.
///
/// The closed-loop methods have default bodies (no encoder, no sensor, no
/// switch, a drive that goes nowhere), so a board without them compiles
/// unchanged; a servo or sensor configured on such a board faults at its
/// first tick (`SensorLost`), before anything moves. Each takes the host
/// time it happens at: a simulated plant integrates its motor up to it, a
/// board reads (or latched) its counter then.
pub trait Board {
    /// Take one step on `channel` at host time `at_us`. `forward` is the state of
    /// the direction output (after inversion).
    fn step(&mut self, channel: u8, forward: bool, at_us: f64);

    /// Set tool output `output` to `value` at host time `at_us`.
    fn set_tool(&mut self, output: u8, value: f32, at_us: f64);

    /// The quadrature count of `channel`'s encoder at host time `at_us`
    /// (×4 decoding: four counts a line); `None`: it gives no reading.
    fn encoder(&mut self, channel: u8, at_us: f64) -> Option<i64> {
        let _ = (channel, at_us);
        None
    }

    /// Set `channel`'s drive (a motor's PWM and direction) to `duty`,
    /// −1 to 1, from host time `at_us`; positive turns the motor the way its
    /// encoder counts up.
    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        let _ = (channel, duty, at_us);
    }

    /// Whether a limit switch of `channel` is open at host time `at_us`
    /// (normally closed switches: tripped, or a broken wire).
    fn limit(&mut self, channel: u8, at_us: f64) -> bool {
        let _ = (channel, at_us);
        false
    }

    /// Temperature sensor `index` at host time `at_us`, °C; `None`: no
    /// reading.
    fn temperature(&mut self, index: u8, at_us: f64) -> Option<f32> {
        let _ = (index, at_us);
        None
    }

    /// Sensor `index` (an accelerometer, a load cell) at host time
    /// `at_us`, in its own unit; `None`: no reading.
    fn sensor(&mut self, index: u8, at_us: f64) -> Option<f32> {
        let _ = (index, at_us);
        None
    }
}
