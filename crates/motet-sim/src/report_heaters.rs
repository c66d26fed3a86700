//! The report's figures of heaters a node drives: each heat-up's
//! overshoot and settling, the waits on the timeline, and a trip.

use serde::Serialize;

/// One target of a heater, from its setting to the next.
#[derive(Clone, Debug, Default, Serialize)]
pub struct HeatUpReport {
    /// °C.
    pub target_c: f64,
    /// The reading when it was set, °C.
    pub from_c: f64,
    /// When it was set, s.
    pub at_s: f64,
    /// How long after it was set the reading entered the ready window for
    /// good (null: outside it at the end), s.
    pub settle_s: Option<f64>,
    /// Most the reading went past the target once it got there, °C.
    pub overshoot_c: f64,
    /// |reading − target| at the target's end, °C.
    pub final_error_c: f64,
}

/// A heater a node drives, over the job, from its samples.
#[derive(Clone, Debug, Default, Serialize)]
pub struct HeaterReport {
    /// Its name in the machine file.
    pub name: String,
    /// The node that drives it.
    pub node: String,
    /// Its highest target, °C.
    pub max_c: f64,
    /// Its ready window either side of the target, °C.
    pub window_c: f64,
    /// The largest overshoot of any heat-up, °C.
    pub max_overshoot_c: f64,
    /// The longest settling of any heat-up that settled, s.
    pub longest_settle_s: f64,
    /// Targets it was given (the first ones' figures in `heat_ups`).
    pub heat_up_count: u64,
    /// The first targets' figures.
    pub heat_ups: Vec<HeatUpReport>,
    /// The last reading and target, °C.
    pub final_c: Option<f64>,
    /// The target at the end, °C.
    pub final_target_c: Option<f64>,
    /// Waits on the timeline for it (M109, M190, M191), and their length, s.
    pub waits: u64,
    /// Seconds of them.
    pub wait_s: f64,
    /// Samples the host got, and those lost on the node.
    pub samples: u64,
    /// Lost on the node.
    pub samples_dropped: u64,
    /// Why the node tripped it (runaway, a lost sensor), if it did.
    pub runaway: Option<String>,
    /// Its plot beside `path.png`.
    pub plot: Option<String>,
}

/// The summary's lines for the heaters.
pub fn summary(heaters: &[HeaterReport]) -> String {
    let mut s = String::new();
    for h in heaters {
        let settle = if h.longest_settle_s > 0.0 {
            format!("{:.1} s", h.longest_settle_s)
        } else {
            "-".into()
        };
        s += &format!(
            "  heater {:<8} on {:<8} {} target(s), overshoot {:.2} °C max, settled within ±{} °C in {} at most, {} wait(s) {:.1} s",
            h.name, h.node, h.heat_up_count, h.max_overshoot_c, h.window_c, settle, h.waits, h.wait_s
        );
        if let (Some(r), Some(t)) = (h.final_c, h.final_target_c) {
            s += &format!(", ends at {r:.1} °C (target {t:.0})");
        }
        s += "\n";
        if let Some(r) = &h.runaway {
            s += &format!("    tripped: {r}\n");
        }
    }
    s
}
