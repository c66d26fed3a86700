//! The board a simulated node polls: its outputs collected for the plant
//! (channel and tool numbers translated to the machine's actuators and
//! tools), its servo motors and heaters integrated up to each read and drive it
//! makes.

use crate::node_plant::NodePlant;
use crate::plant::{Output, Stamped};
use crate::plant_thread::PlantSink;
use motet_node::Board;

/// Collects one node's outputs for the plant, translating its channel and tool
/// numbers to the machine's actuators and tools.
pub(crate) struct Collector<'a, P: PlantSink> {
    pub(crate) actuators: &'a [usize],
    pub(crate) tools: &'a [usize],
    pub(crate) plant: &'a mut P,
    /// The node's servo motors and heaters, answering its loops as it
    /// polls.
    pub(crate) loops: &'a mut NodePlant,
    /// Whether this is the only node, whose outputs are then in time order
    /// as they come: the plant takes them every [`HANDOVER`] outputs
    /// instead of at the frame's end, so a long frame needs no long buffer.
    pub(crate) single: bool,
}

/// Longest stretch a node with loops is polled in one call, µs.
pub(crate) const LOOP_CHUNK_US: f64 = 250_000.0;

/// Outputs a single node's collector gathers before the plant takes them.
const HANDOVER: usize = 8192;

impl<P: PlantSink> Collector<'_, P> {
    #[inline]
    fn push(&mut self, s: Stamped) {
        let out = self.plant.outputs();
        out.push(s);
        if self.single && out.len() >= HANDOVER {
            self.plant.applied(s.time);
        }
    }
}

impl<P: PlantSink> Board for Collector<'_, P> {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        let actuator = self.actuators[channel as usize];
        self.push(Stamped {
            time: at_us,
            output: Output::Step { actuator, forward },
        });
    }
    fn set_tool(&mut self, output: u8, value: f32, at_us: f64) {
        let tool = self.tools[output as usize];
        self.push(Stamped {
            time: at_us,
            output: Output::Tool { tool, value },
        });
    }
    fn encoder(&mut self, channel: u8, at_us: f64) -> Option<i64> {
        let p = self.loops.servos_mut().get_mut(channel)?;
        let count = p.read(at_us);
        let (joint, true_count) = (p.joint(), p.count());
        let actuator = self.actuators[channel as usize];
        self.push(Stamped {
            time: at_us,
            output: Output::Servo {
                actuator,
                count: true_count,
                joint,
            },
        });
        count
    }
    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        self.loops.drive(channel, duty, at_us);
    }
    fn temperature(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.loops.temperature(index, at_us)
    }
    fn limit(&mut self, channel: u8, at_us: f64) -> bool {
        self.loops.limit(channel, at_us)
    }
    fn sensor(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.loops.sensor(index, at_us)
    }
}
