//! One node's simulated plant as the board a node process polls
//! (`motet node --sim --plant FILE --plant-node NAME`): its servo motors,
//! encoders, switches and sensors, and its heaters' thermal blocks, each
//! integrated up to the node's every read and drive.

use crate::servo::ServoPlants;
use motet_host::thermal::NodeHeat;
use motet_host::Machine;
use motet_node::Board;

/// Node `k`'s servos and heaters.
pub struct NodePlant {
    servos: ServoPlants,
    heat: NodeHeat,
}

impl NodePlant {
    /// Node `k` of `machine` at its start, its heaters cold and off.
    pub fn of_node(machine: &Machine, k: usize) -> NodePlant {
        NodePlant {
            servos: ServoPlants::of_node(machine, k, &machine.start, 0.0),
            heat: NodeHeat::of_node(machine, k),
        }
    }

    /// Whether the node has anything to simulate.
    pub fn is_empty(&self) -> bool {
        !self.servos.any() && self.heat.is_empty()
    }
}

impl Board for NodePlant {
    fn step(&mut self, _: u8, _: bool, _: f64) {}
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
    fn encoder(&mut self, channel: u8, at_us: f64) -> Option<i64> {
        self.servos.encoder(channel, at_us)
    }
    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        // Servo channels and heater outputs never share a number.
        self.servos.drive(channel, duty, at_us);
        self.heat.drive(channel, duty, at_us);
    }
    fn limit(&mut self, channel: u8, at_us: f64) -> bool {
        self.servos.limit(channel, at_us)
    }
    fn sensor(&mut self, index: u8, at_us: f64) -> Option<f32> {
        Board::sensor(&mut self.servos, index, at_us)
    }
    fn temperature(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.heat.read(index, at_us)
    }
}
