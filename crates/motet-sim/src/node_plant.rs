//! One node's simulated plant: its servo motors, encoders, switches and
//! sensors, and its heaters' thermal blocks, each integrated up to the
//! node's every read and drive. A node process polls it as its board
//! (`motet node --sim --plant FILE --plant-node NAME`); the simulator's
//! collector answers its node's loops from it.

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

    /// Whether the node has loops to answer (servos or heaters).
    pub fn has_loops(&self) -> bool {
        self.servos.any() || !self.heat.is_empty()
    }

    /// Its servo motors.
    pub fn servos_mut(&mut self) -> &mut ServoPlants {
        &mut self.servos
    }

    /// Its heaters.
    pub fn heat(&self) -> &NodeHeat {
        &self.heat
    }

    /// Its heaters, to change (the part fan blowing on them).
    pub fn heat_mut(&mut self) -> &mut NodeHeat {
        &mut self.heat
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
