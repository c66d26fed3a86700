//! Graph channels on the machine's actuators: which actuator each channel
//! drives, and the joint values its steps amount to.

use super::DanceError;
use motet_graph::{ComponentDef, GraphFile};
use motet_host::{Actuator, Machine};

/// The machine's joints as the graph channels' steps move them.
pub(super) struct Joints<'m> {
    machine: &'m Machine,
    /// For each graph channel (in the graph's order), the index of the
    /// machine actuator it drives, if any.
    actuator_of: Vec<Option<usize>>,
    /// Joint values at the machine's start point, joint units.
    start: Vec<f64>,
    /// Joint values as of the last [`Joints::update`], joint units.
    pub now: Vec<f64>,
}

impl<'m> Joints<'m> {
    /// Each of `channels` drives the actuator its `actuator` key names, else
    /// the machine's actuator of the same ordinal (none past the last); a
    /// name the machine does not have is an error naming the graph file.
    pub fn new(
        machine: &'m Machine,
        graph: &GraphFile,
        channels: &[&ComponentDef],
    ) -> Result<Joints<'m>, DanceError> {
        let mut actuator_of = Vec::new();
        for (k, c) in channels.iter().enumerate() {
            let def = c.channel.as_ref().expect("a channel");
            let a = match &def.actuator {
                Some(n) => Some(
                    machine
                        .actuators
                        .iter()
                        .position(|a| &a.name == n)
                        .ok_or_else(|| {
                            DanceError::Setup(format!(
                                "{}: channel `{}` names actuator `{n}`, which {} does not have",
                                graph.file, c.name, machine.name
                            ))
                        })?,
                ),
                None => (k < machine.actuators.len()).then_some(k),
            };
            actuator_of.push(a);
        }
        let start: Vec<f64> = machine
            .joints
            .iter()
            .map(|j| j.map.value(&machine.start, 0.0))
            .collect();
        Ok(Joints {
            machine,
            actuator_of,
            now: start.clone(),
            start,
        })
    }

    /// The actuator graph channel `k` drives.
    pub fn actuator(&self, k: usize) -> Option<&'m Actuator> {
        self.actuator_of[k].map(|a| &self.machine.actuators[a])
    }

    /// Sets [`Joints::now`] from each channel's net step count: its joint is
    /// the start value plus the steps over the actuator's steps per unit.
    pub fn update(&mut self, counts: &[i64]) {
        let machine = self.machine;
        for (a, &count) in self.actuator_of.iter().zip(counts) {
            if let Some(act) = a.map(|a| &machine.actuators[a]) {
                self.now[act.joint] = self.start[act.joint] + count as f64 / act.steps_per_unit;
            }
        }
    }
}
