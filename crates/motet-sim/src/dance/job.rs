//! A job planned for the machine, run alongside the graph: its segments
//! reach the node (see [`super::job_feed`]) and its tool events say when the
//! render's pen is down.

use super::DanceError;
use motet_host::Machine;
use motet_planner::{Command, Located, Planned, Planner};
use motet_trajectory::Point;

/// A job planned for the machine, to run alongside the graph.
#[derive(Clone, Debug)]
pub struct PlannedJob {
    /// Everything the planner emitted, in order.
    pub items: Vec<Planned>,
    /// When the last item ends, µs.
    pub end_us: f64,
}

impl PlannedJob {
    /// Plans `commands` on `machine` from its start point at time 0.
    pub fn plan(
        machine: &Machine,
        commands: &[Located<Command>],
    ) -> Result<PlannedJob, DanceError> {
        let mut planner = Planner::new(machine.limits(), machine.start, 0.0);
        let mut items = Vec::new();
        for c in commands {
            planner
                .push(&c.item)
                .map_err(|error| DanceError::Plan { loc: c.loc, error })?;
            while let Some(item) = planner.pop() {
                items.push(item);
            }
        }
        planner.finish();
        while let Some(item) = planner.pop() {
            items.push(item);
        }
        Ok(PlannedJob {
            items,
            end_us: planner.clock(),
        })
    }

    /// The planned segments.
    pub fn segments(&self) -> impl Iterator<Item = &motet_trajectory::Segment> {
        self.items.iter().filter_map(|i| match i {
            Planned::Segment(s) => Some(s),
            _ => None,
        })
    }

    /// The planned position at `t_us`: the segment covering it (before the
    /// first, the first's start; after the last, the last's end).
    pub fn position_at(&self, t_us: f64) -> Option<Point> {
        let mut last = None;
        for s in self.segments() {
            if t_us < s.t0 {
                return Some(last.unwrap_or(s.start));
            }
            if t_us < s.t1() {
                return Some(s.position_at(t_us));
            }
            last = Some(s.end);
        }
        last
    }

    /// Whether tool 0 (the pen) is on at `t_us`, by its planned events.
    pub(super) fn tool_on(&self, t_us: f64) -> bool {
        let mut on = false;
        for i in &self.items {
            if let Planned::Event(e) = i {
                if e.tool == 0 && e.time <= t_us {
                    on = e.value > 0.0;
                }
            }
        }
        on
    }

    /// Whether the job switches tool 0 at all (else it cannot say when the
    /// pen is down).
    pub(super) fn has_tool_events(&self) -> bool {
        self.items
            .iter()
            .any(|i| matches!(i, Planned::Event(e) if e.tool == 0))
    }
}
