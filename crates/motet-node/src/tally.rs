//! A running account of what a node's outputs did: steps per channel, tool
//! changes, and a CRC-32C over every output with its exact time. Two nodes
//! that ran the same trajectory the same way have the same tally, so a board
//! (or an emulated one) can be checked against the simulator without sending
//! every step back.

use crate::board::Board;
use crate::node::MAX_CHANNELS;
use motet_wire::frame::Crc32c;
use motet_wire::NodeMessage;

// `NodeMessage::Tally` carries one count per channel.
const _: () = assert!(MAX_CHANNELS == 8);

/// Steps per channel, tool changes and the CRC of all of them in order.
#[derive(Clone, Copy, Debug)]
pub struct StepTally {
    pub steps: [u32; MAX_CHANNELS],
    pub tool_changes: u32,
    crc: Crc32c,
}

impl Default for StepTally {
    fn default() -> Self {
        StepTally {
            steps: [0; MAX_CHANNELS],
            tool_changes: 0,
            crc: Crc32c::new(),
        }
    }
}

impl StepTally {
    /// A step: channel, direction and the time's bits go into the CRC.
    pub fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        if let Some(c) = self.steps.get_mut(channel as usize) {
            *c = c.wrapping_add(1);
        }
        self.crc.update(&[channel, forward as u8]);
        self.crc.update(&at_us.to_bits().to_le_bytes());
    }

    /// A tool change: output (with the top bit set, so it never reads as a
    /// step), value and time.
    pub fn tool(&mut self, output: u8, value: f32, at_us: f64) {
        self.tool_changes = self.tool_changes.wrapping_add(1);
        self.crc.update(&[0x80 | output]);
        self.crc.update(&value.to_bits().to_le_bytes());
        self.crc.update(&at_us.to_bits().to_le_bytes());
    }

    /// The CRC so far.
    pub fn crc(&self) -> u32 {
        self.crc.finish()
    }

    /// As the node reports it.
    pub fn message(&self) -> NodeMessage {
        NodeMessage::Tally {
            steps: self.steps,
            tool_changes: self.tool_changes,
            crc: self.crc(),
        }
    }
}

/// A board that tallies what passes through it on the way to `inner`.
pub struct Tallying<'a, B: Board> {
    pub inner: &'a mut B,
    pub tally: &'a mut StepTally,
}

impl<B: Board> Board for Tallying<'_, B> {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        self.tally.step(channel, forward, at_us);
        self.inner.step(channel, forward, at_us);
    }

    fn set_tool(&mut self, output: u8, value: f32, at_us: f64) {
        self.tally.tool(output, value, at_us);
        self.inner.set_tool(output, value, at_us);
    }
}
