//! A running account of what a node's outputs did: steps per channel, tool
//! changes, and a hash over every output with its exact time. Two nodes that
//! ran the same trajectory the same way have the same tally, so a board (or
//! an emulated one) can be checked against the simulator without sending
//! every step back.
//!
//! The hash takes each output as one 64-bit word, the time's bits with what
//! happened folded in (multiplied by a large odd constant, so that no
//! change of channel, direction or value cancels a change of time), mixed
//! in by an xor, a multiply by a large odd constant and an xor-shift: one
//! such step per output, a few instructions even on a 32-bit core, where a
//! byte-wise CRC would cost as much as the step's solve. Each step is a
//! one-to-one function of the word for a given hash so far, so any single
//! difference changes the hash.

use crate::board::Board;
use crate::node::MAX_CHANNELS;
use motet_wire::NodeMessage;

/// Where the hash starts, the constant it multiplies by, and the one what
/// happened is spread with (all odd, with bits spread across the word).
const SEED: u64 = 0x6d6f_7465_745f_7461;
const MUL: u64 = 0x9e37_79b9_7f4a_7c15;
const WHAT: u64 = 0xc2b2_ae3d_27d4_eb4f;

#[inline(always)]
fn mix(h: u64, w: u64) -> u64 {
    let h = (h ^ w).wrapping_mul(MUL);
    h ^ (h >> 29)
}

// `NodeMessage::Tally` carries one count per channel.
const _: () = assert!(MAX_CHANNELS == 8);

/// Steps per channel, tool changes and the hash of all of them in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepTally {
    /// Steps per board channel id (0..8; higher ids are hashed but not counted), either direction.
    pub steps: [u32; MAX_CHANNELS],
    /// Tool output changes handed to the board, every output together.
    pub tool_changes: u32,
    /// Hash over every output and its time, in order (see this module's description).
    pub hash: u64,
}

impl Default for StepTally {
    fn default() -> Self {
        StepTally {
            steps: [0; MAX_CHANNELS],
            tool_changes: 0,
            hash: SEED,
        }
    }
}

impl StepTally {
    /// A step: the time's bits and `channel | forward << 8`.
    #[inline]
    pub fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        if let Some(c) = self.steps.get_mut(channel as usize) {
            *c = c.wrapping_add(1);
        }
        let what = channel as u64 | (forward as u64) << 8;
        self.hash = mix(self.hash, at_us.to_bits() ^ what.wrapping_mul(WHAT));
    }

    /// A drive output: the time's bits and `channel | 2 << 16 | duty's
    /// bits << 32` (bit 17 sets it apart from steps and tool changes).
    pub fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        let what = channel as u64 | 2 << 16 | (duty.to_bits() as u64) << 32;
        self.hash = mix(self.hash, at_us.to_bits() ^ what.wrapping_mul(WHAT));
    }

    /// A tool change: the time's bits and `output | 1 << 16 | value's
    /// bits << 32` (the bit 16 sets it apart from any step).
    pub fn tool(&mut self, output: u8, value: f32, at_us: f64) {
        self.tool_changes = self.tool_changes.wrapping_add(1);
        let what = output as u64 | 1 << 16 | (value.to_bits() as u64) << 32;
        self.hash = mix(self.hash, at_us.to_bits() ^ what.wrapping_mul(WHAT));
    }

    /// As the node reports it.
    pub fn message(&self) -> NodeMessage {
        NodeMessage::Tally {
            steps: self.steps,
            tool_changes: self.tool_changes,
            hash: self.hash,
        }
    }
}

/// A board that tallies what passes through it on the way to `inner`.
pub struct Tallying<'a, B: Board> {
    /// The board the outputs go to.
    pub inner: &'a mut B,
    /// The tally they are counted in.
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

    fn encoder(&mut self, channel: u8, at_us: f64) -> Option<i64> {
        self.inner.encoder(channel, at_us)
    }

    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        self.tally.drive(channel, duty, at_us);
        self.inner.drive(channel, duty, at_us);
    }

    fn limit(&mut self, channel: u8, at_us: f64) -> bool {
        self.inner.limit(channel, at_us)
    }

    fn temperature(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.inner.temperature(index, at_us)
    }

    fn sensor(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.inner.sensor(index, at_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Outputs that differ in any one thing (channel, direction, time by one
    /// ulp, order, a tool for a step) give different hashes.
    #[test]
    fn any_difference_changes_the_hash() {
        let run = |f: &dyn Fn(&mut StepTally)| {
            let mut t = StepTally::default();
            f(&mut t);
            t.hash
        };
        let base = run(&|t| {
            t.step(0, true, 100.0);
            t.step(1, false, 100.5);
            t.tool(0, 0.5, 101.0);
        });
        let variants: [&dyn Fn(&mut StepTally); 6] = [
            &|t| {
                t.step(2, true, 100.0);
                t.step(1, false, 100.5);
                t.tool(0, 0.5, 101.0);
            },
            &|t| {
                t.step(0, false, 100.0);
                t.step(1, false, 100.5);
                t.tool(0, 0.5, 101.0);
            },
            &|t| {
                t.step(0, true, f64::from_bits(100f64.to_bits() + 1));
                t.step(1, false, 100.5);
                t.tool(0, 0.5, 101.0);
            },
            &|t| {
                t.step(1, false, 100.5);
                t.step(0, true, 100.0);
                t.tool(0, 0.5, 101.0);
            },
            &|t| {
                t.step(0, true, 100.0);
                t.step(1, false, 100.5);
                t.tool(0, 0.25, 101.0);
            },
            &|t| {
                t.step(0, true, 100.0);
                t.step(1, false, 100.5);
                t.step(0, false, 101.0);
            },
        ];
        for (i, v) in variants.iter().enumerate() {
            assert_ne!(run(*v), base, "variant {i}");
        }
    }
}
