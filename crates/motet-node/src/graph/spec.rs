//! Components from their wire description ([`motet_wire::message::GraphKind`]
//! and its construction values), shared by the node (which builds graphs from
//! messages) and the host (which validates a graph file before sending it).

use motet_wire::message::GraphKind;

use super::channel::GraphChannel;
use super::component::Component;
use super::filters::{ScalingFilter1D, ScalingFilter2D, ThresholdGenerator};
use super::generators::{
    CircleGenerator, PathLength2D, PathLength3D, PositionGenerator, VelocityGenerator,
    WaveGenerator1D, WaveGenerator2D,
};
use super::homing::Homing;
use super::inputs::{AnalogInput, Button, ButtonMode, Encoder, StreamInput};
use super::io::MAX_HW;
use super::kinematics::{CoreXY, FiveBarForward, PolarToCartesian};
use super::port::Mode;
use super::reader::TrajectoryReader;
use super::recorder::{FourTrackPlayer, FourTrackRecorder};

/// Every kind, in wire order.
pub const KINDS: [GraphKind; 22] = [
    GraphKind::AnalogInput,
    GraphKind::Button,
    GraphKind::Encoder,
    GraphKind::StreamInput,
    GraphKind::ScalingFilter1D,
    GraphKind::ScalingFilter2D,
    GraphKind::ThresholdGenerator,
    GraphKind::CoreXY,
    GraphKind::PolarToCartesian,
    GraphKind::FiveBarForward,
    GraphKind::VelocityGenerator,
    GraphKind::PositionGenerator,
    GraphKind::WaveGenerator1D,
    GraphKind::WaveGenerator2D,
    GraphKind::CircleGenerator,
    GraphKind::PathLength2D,
    GraphKind::PathLength3D,
    GraphKind::FourTrackRecorder,
    GraphKind::FourTrackPlayer,
    GraphKind::Homing,
    GraphKind::TrajectoryReader,
    GraphKind::Channel,
];

/// Number of construction values a kind takes (the most; trailing ones may be
/// left out and take their defaults) and how many are required.
pub fn arity(kind: GraphKind) -> (usize, usize) {
    use GraphKind::*;
    match kind {
        AnalogInput => (8, 1),
        Button => (3, 1),
        Encoder => (2, 1),
        StreamInput => (1, 1),
        ScalingFilter1D | ScalingFilter2D => (2, 0),
        ThresholdGenerator => (2, 2),
        CoreXY | PolarToCartesian | FourTrackRecorder => (0, 0),
        FiveBarForward => (6, 5),
        VelocityGenerator | PositionGenerator => (1, 0),
        WaveGenerator1D | WaveGenerator2D => (4, 1),
        CircleGenerator => (2, 2),
        PathLength2D | PathLength3D => (1, 0),
        FourTrackPlayer => (1, 0),
        Homing => (3, 1),
        TrajectoryReader => (1, 0),
        Channel => (7, 0),
    }
}

fn hw(v: f64) -> Option<u8> {
    (v.is_finite() && v >= 0.0 && v < MAX_HW as f64 && v == libm::floor(v)).then_some(v as u8)
}

fn flag(v: f64) -> Option<bool> {
    (!v.is_nan()).then_some(v != 0.0)
}

fn fin(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Builds a component from its kind and construction values (see
/// [`GraphKind`]); `None` when a value is missing, extra or out of range.
pub fn component(kind: GraphKind, params: &[f64]) -> Option<Component> {
    let (max, min) = arity(kind);
    if params.len() < min || params.len() > max {
        return None;
    }
    let p = |i: usize, default: f64| params.get(i).copied().unwrap_or(default);
    use GraphKind as K;
    let c: Component = match kind {
        K::AnalogInput => {
            let mut a = AnalogInput::new(hw(p(0, 0.0))?)
                .floor(fin(p(1, 0.0))?, fin(p(2, 0.0))?)
                .ceiling(fin(p(3, 1.0))?, fin(p(4, 1023.0))?);
            let (c, w) = (fin(p(5, 0.0))?, fin(p(6, 0.0))?);
            if w < 0.0 {
                return None;
            }
            a = a.deadband(c, w);
            let avg = fin(p(7, 1.0))?;
            if avg < 1.0 {
                return None;
            }
            a.averaging(avg).into()
        }
        K::Button => {
            let mode = if flag(p(1, 0.0))? {
                ButtonMode::Toggle
            } else {
                ButtonMode::Standard
            };
            let d = fin(p(2, 5.0))?;
            if !(0.0..=u16::MAX as f64).contains(&d) {
                return None;
            }
            Button::new(hw(p(0, 0.0))?, mode).debounce(d as u16).into()
        }
        K::Encoder => {
            let e = Encoder::new(hw(p(0, 0.0))?);
            if flag(p(1, 0.0))? {
                e.inverted().into()
            } else {
                e.into()
            }
        }
        K::StreamInput => StreamInput::new(hw(p(0, 0.0))?).into(),
        K::ScalingFilter1D | K::ScalingFilter2D => {
            let r = fin(p(0, 1.0))?;
            let m = if flag(p(1, 0.0))? {
                Mode::Absolute
            } else {
                Mode::Incremental
            };
            if kind == K::ScalingFilter1D {
                ScalingFilter1D::new(r, m).into()
            } else {
                ScalingFilter2D::new(r, m).into()
            }
        }
        K::ThresholdGenerator => {
            let (lo, hi) = (p(0, 0.0), p(1, 0.0));
            if lo.is_nan() || hi.is_nan() || lo > hi {
                return None;
            }
            ThresholdGenerator::new(lo, hi).into()
        }
        K::CoreXY => CoreXY.into(),
        K::PolarToCartesian => PolarToCartesian.into(),
        K::FiveBarForward => {
            let mut f = FiveBarForward::new(
                fin(p(0, 0.0))?,
                fin(p(1, 0.0))?,
                fin(p(2, 0.0))?,
                fin(p(3, 0.0))?,
                fin(p(4, 0.0))?,
            );
            f.ext = fin(p(5, 0.0))?;
            if f.l1 <= 0.0 || f.l2 <= 0.0 || f.l3 <= 0.0 || f.l4 <= 0.0 || f.l3 + f.ext <= 0.0 {
                return None;
            }
            f.into()
        }
        K::VelocityGenerator => {
            let _ = fin(p(0, 0.0))?;
            VelocityGenerator.into()
        }
        K::PositionGenerator => {
            let s = fin(p(0, 0.0))?;
            if s < 0.0 {
                return None;
            }
            PositionGenerator::new(s).into()
        }
        K::WaveGenerator1D => {
            WaveGenerator1D::new(fin(p(0, 0.0))?, fin(p(1, 0.0))?, fin(p(2, 0.0))?)
                .driven(fin(p(3, 0.0))?)
                .into()
        }
        K::WaveGenerator2D => WaveGenerator2D::new(
            fin(p(0, 0.0))?,
            fin(p(1, 0.0))?,
            fin(p(2, 0.0))?,
            fin(p(3, 0.0))?,
        )
        .into(),
        K::CircleGenerator => CircleGenerator::new(fin(p(0, 0.0))?, fin(p(1, 0.0))?).into(),
        K::PathLength2D => PathLength2D::new(fin(p(0, 1.0))?).into(),
        K::PathLength3D => PathLength3D::new(fin(p(0, 1.0))?).into(),
        K::FourTrackRecorder => FourTrackRecorder::new().into(),
        K::FourTrackPlayer => {
            let mut pl = FourTrackPlayer::new();
            let looping = flag(p(0, 0.0))?;
            let mut ports = [];
            use super::component::Kind;
            pl.set_param(
                &mut ports,
                FourTrackPlayer::LOOP,
                if looping { 1.0 } else { 0.0 },
            )
            .ok()?;
            pl.into()
        }
        K::Homing => {
            let (s, b, h) = (fin(p(0, 0.0))?, fin(p(1, 0.0))?, fin(p(2, 0.0))?);
            if s == 0.0 || b < 0.0 {
                return None;
            }
            Homing::new(s, b, h).into()
        }
        K::TrajectoryReader => {
            let a = p(0, 0.0);
            if !(0.0..motet_trajectory::MAX_AXES as f64).contains(&a) || a != libm::floor(a) {
                return None;
            }
            TrajectoryReader::new(a as u8).into()
        }
        K::Channel => {
            let mut c = GraphChannel::new();
            let f = fin(p(0, 0.0))?;
            if f < 0.0 {
                return None;
            }
            c = c.filtering(f);
            if flag(p(1, 0.0))? {
                c = c.inverted();
            }
            let rate = fin(p(2, 0.0))?;
            if rate < 0.0 {
                return None;
            }
            c = c.pulse_rate(rate);
            let (lo, hi) = (p(3, f64::NEG_INFINITY), p(4, f64::INFINITY));
            if lo.is_nan() || hi.is_nan() || lo > hi {
                return None;
            }
            c = c.limits(lo, hi);
            let port = p(5, -1.0);
            if port >= 0.0 {
                let code = p(6, 0.0);
                if !(hw(port).is_some() && (0.0..6.0).contains(&code) && code == libm::floor(code))
                {
                    return None;
                }
                c = c.output(port as u8, code as u8);
            }
            c.into()
        }
    };
    Some(c)
}

/// Adds the component `kind` with construction values `params` to `b`,
/// including values that live in ports (a velocity generator's speed).
/// Returns its index; `None` (the builder unchanged) on bad values or a full
/// builder.
pub fn add<const C: usize, const M: usize>(
    b: &mut super::GraphBuilder<C, M>,
    kind: GraphKind,
    params: &[f64],
) -> Option<u8> {
    let c = component(kind, params)?;
    let i = b.add(c).ok()?;
    if kind == GraphKind::VelocityGenerator {
        if let Some(&v) = params.first() {
            // Checked finite by `component`.
            let _ = b.set_param(i, VelocityGenerator::SPEED_PARAM, v);
        }
    }
    Some(i)
}
