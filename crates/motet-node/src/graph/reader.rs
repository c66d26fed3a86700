//! TrajectoryReader: the node's planned trajectory as a motion stream.

use super::declare::{live, Declaration, Domain, Param};
use heapless::Deque;
use motet_trajectory::{Segment, MAX_AXES};

use super::component::{Kind, ParamError};
use super::io::Ctx;
use super::port::{Port, PortSpec, Unit};

/// Outputs the planned position of one machine axis at the frame's time, read
/// from the segment queue passed into the frame. The output is absolute; an
/// INCREMENTAL mapping transmits its changes (so planned motion and hand input
/// mix on one channel), an ABSOLUTE mapping the position itself. Before the
/// first segment the axis sits at that segment's start, after the last at its
/// end; with an empty queue it holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryReader {
    /// The machine axis it reads, an index into the trajectory's point (the `axis` parameter).
    pub axis: u8,
}

impl TrajectoryReader {
    /// Port 0: the `position` output (any quantity).
    pub const OUT: u8 = 0;
    /// `set_param` id of the `axis` parameter.
    pub const AXIS: u8 = 0;

    /// A reader of `axis` (clamped to the last axis).
    pub fn new(axis: u8) -> TrajectoryReader {
        TrajectoryReader {
            axis: axis.min(MAX_AXES as u8 - 1),
        }
    }

    /// Planned position of `axis` at `t_us`, if the queue holds any segment.
    pub fn position<const Q: usize>(
        segments: &Deque<Segment, Q>,
        axis: usize,
        t_us: f64,
    ) -> Option<f64> {
        let mut last = None;
        for seg in segments.iter() {
            if t_us < seg.t0 {
                return Some(seg.start[axis]);
            }
            if t_us < seg.t1() {
                return Some(seg.position_at(t_us)[axis]);
            }
            last = Some(seg.end[axis]);
        }
        last
    }
}

impl Kind for TrajectoryReader {
    const DECL: Declaration = Declaration {
        name: "trajectory_reader",
        input: None,
        params: &[Param::new(
            "axis",
            "",
            0.0,
            Domain::Index(motet_trajectory::MAX_AXES as u8),
        )
        .doc("machine axis index")],
        live: &[live("axis", Self::AXIS)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "the node's planned trajectory, one machine axis",
        build: |a| Ok(TrajectoryReader::new(a.get(0) as u8).into()),
    };

    const PORTS: &'static [PortSpec] = &[PortSpec::output("position", Unit::Any)];
    const PHASE: super::component::Phase = super::component::Phase::Input;

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        if let Some(p) = Self::position(ctx.segments, self.axis as usize, ctx.now_us) {
            ports[0].value = p;
        }
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::AXIS => {
                if !(0.0..MAX_AXES as f64).contains(&v) || v != super::math::floor(v) {
                    return Err(ParamError::BadValue);
                }
                self.axis = v as u8;
            }
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }
}
