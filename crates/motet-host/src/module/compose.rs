//! Composition: modules ordered from the tool to the workpiece become a
//! kinematic chain, and the chain a machine's axes, tools and heaters.
//!
//! Module `i` of `n` (1 the tool end) places its own frame in the frame of
//! module `i + 1` by its placement `Pᵢ` (its joint at 0), so
//! `T = Pₙ · … · P₁` takes the tool's frame to the workpiece's, and module
//! `i`'s joint moves along (or turns about) `Wᵢ · dᵢ` in the workpiece
//! frame, `Wᵢ = Pₙ · … · Pᵢ`'s rotation and `dᵢ` its declared axis.
//! A translational module whose direction is ±x, ±y or ±z of the workpiece
//! becomes that cartesian axis (the opposite way: an inverted chain), a
//! rotary one about ±x, ±y or ±z becomes `a`, `b` or `c`; a tool module a
//! tool, a heater module a heater. What does not fit that rule stays
//! unresolved, with the reason, for the viability check to name.

use super::math::{self, Htm};
use motet_wire::describe::{ChannelSpec, Description, ModuleKind};
use motet_wire::service::Version;

/// How close to a workpiece axis a joint's direction must be (the cosine's
/// distance from 1): a description is read in `f32`.
pub const ALIGNED: f64 = 1e-4;

/// A module as the bus (or a file) gave it.
#[derive(Clone, Debug, PartialEq)]
pub struct ModuleAt {
    /// Its node's unique id.
    pub uid: u64,
    /// Its firmware, when known.
    pub firmware: Option<Version>,
    /// What it says of itself.
    pub description: Description,
}

/// What a module became in the machine.
#[derive(Clone, Debug, PartialEq)]
pub enum Role {
    /// A machine axis (`x`, `y`, `z`, `a`, `b`, `c`); `inverted` when the
    /// joint moves the opposite way.
    Axis {
        /// The axis's name.
        axis: &'static str,
        /// The joint runs against the axis.
        inverted: bool,
    },
    /// A tool (named after the module).
    Tool,
    /// A heater (named after the module).
    Heater,
    /// A sensor or an input: part of the machine, moving nothing.
    Passive,
    /// None of the above, and why (for the viability check to say).
    Unresolved(String),
}

/// One module in its place.
#[derive(Clone, Debug, PartialEq)]
pub struct Composed {
    /// Its place, 1 at the tool.
    pub order: usize,
    /// The module.
    pub module: ModuleAt,
    /// What it became.
    pub role: Role,
    /// Its joint's direction (or rotation axis) in the workpiece frame,
    /// for axis modules.
    pub direction: Option<[f64; 3]>,
}

impl Composed {
    /// The module's name.
    pub fn name(&self) -> &str {
        self.module.description.identity.name.as_str()
    }
}

/// A chain of modules and what it makes.
#[derive(Clone, Debug, PartialEq)]
pub struct Composition {
    /// The modules, tool first.
    pub modules: Vec<Composed>,
    /// The tool frame in the workpiece frame with every joint at 0.
    pub task: Htm,
}

impl Composition {
    /// The tool point (the tool frame's origin) in the workpiece frame
    /// with every joint at 0, mm.
    pub fn tool_point(&self) -> [f64; 3] {
        math::apply(&self.task, [0.0; 3])
    }

    /// The module that became axis `name`, if one did (the first, when
    /// several claim it).
    pub fn axis_module(&self, name: &str) -> Option<&Composed> {
        self.modules
            .iter()
            .find(|m| matches!(m.role, Role::Axis { axis, .. } if axis == name))
    }

    /// The machine's axes in motet's order (x, y, z, a, b, c), each with
    /// its module; an axis claimed twice is listed once.
    pub fn axes(&self) -> Vec<(&'static str, &Composed)> {
        ["x", "y", "z", "a", "b", "c"]
            .into_iter()
            .filter_map(|a| self.axis_module(a).map(|m| (a, m)))
            .collect()
    }
}

/// Composes `modules`, ordered from the tool to the workpiece.
pub fn compose(modules: &[ModuleAt]) -> Composition {
    let n = modules.len();
    let placements: Vec<Htm> = modules
        .iter()
        .map(|m| math::from_wire(&m.description.placement.htm))
        .collect();
    // W[i] = P[n-1] · … · P[i], from the workpiece end inwards.
    let mut w = vec![math::IDENTITY; n + 1];
    for i in (0..n).rev() {
        w[i] = math::mul(&w[i + 1], &placements[i]);
    }
    let composed = modules
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let d = &m.description;
            let axis = d.placement.joint.vector().map(f64::from);
            let direction = d.kind.is_axis().then(|| math::rotate(&w[i], axis));
            Composed {
                order: i + 1,
                module: m.clone(),
                role: role(d, direction),
                direction,
            }
        })
        .collect();
    Composition {
        modules: composed,
        task: w[0],
    }
}

/// Which workpiece axis `v` is along: its index (0 x, 1 y, 2 z) and
/// whether it points the other way.
pub fn aligned(v: [f64; 3]) -> Option<(usize, bool)> {
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    (0..3).find_map(|k| {
        let c = v[k] / len;
        (c.abs() > 1.0 - ALIGNED).then_some((k, c < 0.0))
    })
}

fn role(d: &Description, direction: Option<[f64; 3]>) -> Role {
    match d.kind {
        ModuleKind::StepperAxis | ModuleKind::ServoAxis | ModuleKind::Rotary => {
            let v = direction.unwrap_or_default();
            let rotary = d.kind == ModuleKind::Rotary;
            match aligned(v) {
                Some((k, inverted)) => Role::Axis {
                    axis: if rotary {
                        ["a", "b", "c"][k]
                    } else {
                        ["x", "y", "z"][k]
                    },
                    inverted,
                },
                None => Role::Unresolved(format!(
                    "its joint {} ({}) in the workpiece frame, along none of its axes: motet composes {}",
                    if rotary { "turns about" } else { "moves along" },
                    v.map(motet_planner::ranges::rounded).join(", "),
                    if rotary {
                        "rotary modules about x, y or z (a, b, c)"
                    } else {
                        "translational modules along x, y or z (a cartesian machine)"
                    }
                )),
            }
        }
        ModuleKind::Tool => Role::Tool,
        ModuleKind::Heater => Role::Heater,
        ModuleKind::Sensor | ModuleKind::Input => Role::Passive,
    }
}

/// The channels of a module that drive its joint.
pub fn joint_channels(d: &Description) -> impl Iterator<Item = &ChannelSpec> {
    d.channels
        .iter()
        .filter(|c| c.drives.as_str() == "joint")
        .map(|c| &c.spec)
        .filter(|s| matches!(s, ChannelSpec::Step { .. } | ChannelSpec::Servo { .. }))
}
