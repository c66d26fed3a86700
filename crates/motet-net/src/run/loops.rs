//! What a run does with what nodes' closed loops send unasked: a fault
//! stops the run on its tail (every node brakes on the committed
//! trajectory, the faulted loop has already stopped driving); samples are
//! kept for the report.

use super::NetRun;
use motet_wire::NodeMessage;

impl NetRun {
    /// A fault or samples from node `k`.
    pub(super) fn on_loop_message(&mut self, k: usize, m: NodeMessage, now: u64) {
        // A heater's are the heaters' (a trip has stopped the run, naming
        // it; samples go to its trace, `NetRun::heater_traces`).
        if motet_host::heater_loop::is_heater_message(&m) {
            self.on_heater_message(k, &m, now);
            return;
        }
        if let NodeMessage::Fault {
            source,
            kind,
            at,
            value,
        } = m
        {
            let text = motet_host::loops::fault_text(
                &self.machine,
                k,
                source,
                kind,
                at,
                value,
                self.feed_t0,
            );
            self.stop(&text, now);
        } else if let NodeMessage::Samples(b) = &m {
            let mut buf = [0u8; motet_wire::MAX_MESSAGE];
            let n = motet_wire::encode(&m, &mut buf).map_or(0, |b| b.len());
            self.samples.take(&self.machine, k, b, n, now as f64);
        }
    }

    /// What the nodes' loops sent: samples per source.
    pub fn samples(&self) -> &motet_host::samples::SampleStore {
        &self.samples
    }

    /// Host time at which the trajectory starts, µs (`None` before the
    /// run streams).
    pub fn trajectory_start(&self) -> Option<f64> {
        self.feed_t0.is_finite().then_some(self.feed_t0)
    }

    /// The sensors' planned acceleration over the committed segments: what
    /// their samples are plotted against.
    pub fn sensor_plan(&self) -> &motet_host::sensor_plan::SensorPlan {
        &self.sensor_plan
    }
}
