//! Element chains (Gestalt): the mechanical parts between a joint and its motor,
//! composed to give steps per joint unit.

use serde::{Deserialize, Serialize};

/// The quantity flowing between elements of a chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Unit {
    /// A linear joint's position, or a belt's or screw's travel.
    Millimetre,
    /// A rotary joint's angle.
    Degree,
    /// A shaft's turns, between a pulley, screw or gear and the motor.
    Revolution,
    /// The motor's full steps (what a [`Element::Stepper`] gives).
    FullStep,
    /// The driver's microsteps (what a [`Element::Microstep`] gives).
    Microstep,
    /// A quadrature encoder's counts, four a line (what an
    /// [`Element::Encoder`] gives): a servo's chain ends in them.
    Count,
}

impl Unit {
    /// Plural English name, as chain errors print it ("millimetres").
    pub fn name(self) -> &'static str {
        match self {
            Unit::Millimetre => "millimetres",
            Unit::Degree => "degrees",
            Unit::Revolution => "revolutions",
            Unit::FullStep => "full steps",
            Unit::Microstep => "microsteps",
            Unit::Count => "encoder counts",
        }
    }
}

/// One mechanical part of an actuator's chain, listed from the joint toward the
/// motor's step input.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Element {
    /// Belt and pulley: millimetres to revolutions; the belt moves one
    /// circumference (π × pitch diameter, or belt pitch × teeth) per revolution.
    Pulley {
        /// Belt travel per pulley revolution, mm.
        circumference: f64,
    },
    /// Leadscrew: millimetres to revolutions, `lead` mm per revolution.
    Leadscrew {
        /// Travel per screw revolution, mm (pitch × starts).
        lead: f64,
    },
    /// Gear or reduction: `ratio` input revolutions per output revolution.
    Gear {
        /// Motor-side revolutions per joint-side revolution (5 for a 5:1
        /// reduction).
        ratio: f64,
    },
    /// Stepper motor: revolutions to full steps, `step_angle` degrees per step.
    Stepper {
        /// Degrees per full step (1.8 for a 200-step motor).
        step_angle: f64,
    },
    /// Microstepping driver: `divisions` microsteps per full step.
    Microstep {
        /// Microsteps per full step, `1..=256`.
        divisions: u32,
    },
    /// Reverses the direction of motion.
    Invert,
    /// A quadrature encoder on the motor: revolutions to counts, four a
    /// line (×4 decoding). A chain that ends in one is a servo's.
    Encoder {
        /// Lines (slots) per revolution, `1..=1_000_000`.
        lines: u32,
    },
}

impl Element {
    /// Its name as machine files spell it in an actuator's `chain`
    /// (`pulley`, `leadscrew`, `gear`, `stepper`, `microstep`, `invert`).
    pub fn name(&self) -> &'static str {
        match self {
            Element::Pulley { .. } => "pulley",
            Element::Leadscrew { .. } => "leadscrew",
            Element::Gear { .. } => "gear",
            Element::Stepper { .. } => "stepper",
            Element::Microstep { .. } => "microstep",
            Element::Invert => "invert",
            Element::Encoder { .. } => "encoder",
        }
    }

    /// The unit this element takes and the one it gives, with the factor between.
    fn convert(&self, input: Unit) -> Result<(Unit, f64), ChainErrorKind> {
        let need = |want: Unit, out: Unit, factor: f64| {
            if input == want {
                Ok((out, factor))
            } else {
                Err(ChainErrorKind::WrongInput {
                    expected: want,
                    got: input,
                })
            }
        };
        let positive = |v: f64, what: &'static str| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(ChainErrorKind::BadValue { what })
            }
        };
        match *self {
            Element::Pulley { circumference } => need(
                Unit::Millimetre,
                Unit::Revolution,
                1.0 / positive(circumference, "circumference")?,
            ),
            Element::Leadscrew { lead } => need(
                Unit::Millimetre,
                Unit::Revolution,
                1.0 / positive(lead, "lead")?,
            ),
            Element::Gear { ratio } => {
                let ratio = positive(ratio, "ratio")?;
                match input {
                    // An angle in degrees is a fraction of a revolution.
                    Unit::Degree => Ok((Unit::Revolution, ratio / 360.0)),
                    _ => need(Unit::Revolution, Unit::Revolution, ratio),
                }
            }
            Element::Stepper { step_angle } => {
                let per_rev = 360.0 / positive(step_angle, "step_angle")?;
                match input {
                    Unit::Degree => Ok((Unit::FullStep, per_rev / 360.0)),
                    _ => need(Unit::Revolution, Unit::FullStep, per_rev),
                }
            }
            Element::Microstep { divisions } => {
                if divisions == 0 || divisions > 256 {
                    return Err(ChainErrorKind::BadValue { what: "divisions" });
                }
                need(Unit::FullStep, Unit::Microstep, divisions as f64)
            }
            Element::Invert => Ok((input, -1.0)),
            Element::Encoder { lines } => {
                if lines == 0 || lines > 1_000_000 {
                    return Err(ChainErrorKind::BadValue { what: "lines" });
                }
                let per_rev = 4.0 * lines as f64;
                match input {
                    Unit::Degree => Ok((Unit::Count, per_rev / 360.0)),
                    _ => need(Unit::Revolution, Unit::Count, per_rev),
                }
            }
        }
    }
}

/// What is wrong with a chain (see [`ChainError`] for where).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ChainErrorKind {
    /// The element cannot take what the elements before it give: a
    /// microstep driver before the stepper, two pulleys in a row, a linear
    /// joint straight into a stepper.
    WrongInput {
        /// The unit the element takes.
        expected: Unit,
        /// The unit the chain gives it (the joint's unit for the first).
        got: Unit,
    },
    /// A value that must be a positive finite number is not, or a
    /// microstep's `divisions` is outside `1..=256`.
    BadValue {
        /// The element's field at fault (`lead`, `divisions`, ...).
        what: &'static str,
    },
    /// The chain does not end at the motor's steps.
    Incomplete {
        /// The unit the last element gives (the joint's own for an empty
        /// chain).
        ends_in: Unit,
    },
}

/// Why a chain is impossible, and at which element (0-based).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainError {
    /// 0-based position of the element at fault in the chain; for
    /// [`ChainErrorKind::Incomplete`], the chain's length (the missing end).
    /// Displayed 1-based, as a user counts the machine file's list.
    pub index: usize,
    /// What is wrong there.
    pub kind: ChainErrorKind,
}

impl core::fmt::Display for ChainError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.kind {
            ChainErrorKind::WrongInput { expected, got } => write!(
                f,
                "element {} takes {} but the chain gives it {}",
                self.index + 1,
                expected.name(),
                got.name()
            ),
            ChainErrorKind::BadValue { what } => {
                write!(
                    f,
                    "element {}: {} must be a positive number",
                    self.index + 1,
                    what
                )
            }
            ChainErrorKind::Incomplete { ends_in } => write!(
                f,
                "the chain ends in {}; it must end at a stepper (optionally followed by microstep) or an encoder",
                ends_in.name()
            ),
        }
    }
}

/// A validated chain: how many motor steps (or, for a servo's, encoder
/// counts) one joint unit is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ElementChain {
    /// Signed: negative when the chain inverts.
    pub steps_per_unit: f64,
}

impl ElementChain {
    /// Whether `elements` end in an encoder: the chain of a servo, whose
    /// `steps_per_unit` are encoder counts.
    pub fn is_servo(elements: &[Element]) -> bool {
        matches!(elements.last(), Some(Element::Encoder { .. }))
    }
}

impl ElementChain {
    /// Composes `elements` (listed from the joint toward the motor) for a
    /// joint measured in `joint_unit`. The chain must end in full steps or
    /// microsteps; the error names the first element that does not fit.
    pub fn new(joint_unit: Unit, elements: &[Element]) -> Result<ElementChain, ChainError> {
        let mut unit = joint_unit;
        let mut factor = 1.0;
        for (index, e) in elements.iter().enumerate() {
            let (out, k) = e.convert(unit).map_err(|kind| ChainError { index, kind })?;
            unit = out;
            factor *= k;
        }
        match unit {
            Unit::FullStep | Unit::Microstep | Unit::Count => Ok(ElementChain {
                steps_per_unit: factor,
            }),
            ends_in => Err(ChainError {
                index: elements.len(),
                kind: ChainErrorKind::Incomplete { ends_in },
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    #[test]
    fn chains_give_steps_per_unit() {
        // (joint unit, chain, expected steps per unit)
        let cases: &[(Unit, &[Element], f64)] = &[
            // GT2 belt, 20 teeth, 1.8° stepper, 16 microsteps: 80 steps/mm.
            (
                Unit::Millimetre,
                &[
                    Element::Pulley {
                        circumference: 40.0,
                    },
                    Element::Stepper { step_angle: 1.8 },
                    Element::Microstep { divisions: 16 },
                ],
                80.0,
            ),
            // 8 mm lead screw: 400 steps/mm.
            (
                Unit::Millimetre,
                &[
                    Element::Leadscrew { lead: 8.0 },
                    Element::Stepper { step_angle: 1.8 },
                    Element::Microstep { divisions: 16 },
                ],
                400.0,
            ),
            // Pulley by pitch diameter, inverted.
            (
                Unit::Millimetre,
                &[
                    Element::Pulley {
                        circumference: PI * 10.0,
                    },
                    Element::Invert,
                    Element::Stepper { step_angle: 0.9 },
                ],
                -400.0 / (PI * 10.0),
            ),
            // Turntable: 5:1 reduction, 1.8° motor, 8 microsteps: 5*200*8/360 steps/°.
            (
                Unit::Degree,
                &[
                    Element::Gear { ratio: 5.0 },
                    Element::Stepper { step_angle: 1.8 },
                    Element::Microstep { divisions: 8 },
                ],
                5.0 * 200.0 * 8.0 / 360.0,
            ),
            // Extruder drive gear with a 3:1 reduction.
            (
                Unit::Millimetre,
                &[
                    Element::Pulley {
                        circumference: PI * 7.5,
                    },
                    Element::Gear { ratio: 3.0 },
                    Element::Stepper { step_angle: 1.8 },
                    Element::Microstep { divisions: 16 },
                ],
                3.0 * 3200.0 / (PI * 7.5),
            ),
            // A servo: 5 mm lead, 1000-line encoder ×4: 800 counts/mm.
            (
                Unit::Millimetre,
                &[
                    Element::Leadscrew { lead: 5.0 },
                    Element::Encoder { lines: 1000 },
                ],
                800.0,
            ),
        ];
        for (unit, chain, want) in cases {
            let got = ElementChain::new(*unit, chain).unwrap().steps_per_unit;
            assert!(
                (got - want).abs() < 1e-9 * want.abs(),
                "{chain:?}: {got} != {want}"
            );
        }
    }

    #[test]
    fn impossible_chains_are_refused() {
        let cases: &[(Unit, &[Element], usize)] = &[
            // Microstep before the stepper.
            (
                Unit::Millimetre,
                &[
                    Element::Pulley {
                        circumference: 40.0,
                    },
                    Element::Microstep { divisions: 16 },
                ],
                1,
            ),
            // No stepper at all.
            (
                Unit::Millimetre,
                &[Element::Pulley {
                    circumference: 40.0,
                }],
                1,
            ),
            // Two pulleys in a row.
            (
                Unit::Millimetre,
                &[
                    Element::Pulley {
                        circumference: 40.0,
                    },
                    Element::Pulley {
                        circumference: 40.0,
                    },
                ],
                1,
            ),
            // Linear joint straight into a stepper.
            (Unit::Millimetre, &[Element::Stepper { step_angle: 1.8 }], 0),
            // Zero lead.
            (
                Unit::Millimetre,
                &[
                    Element::Leadscrew { lead: 0.0 },
                    Element::Stepper { step_angle: 1.8 },
                ],
                0,
            ),
            // Negative step angle.
            (Unit::Degree, &[Element::Stepper { step_angle: -1.8 }], 0),
            // Empty chain.
            (Unit::Millimetre, &[], 0),
            // An encoder with no lines, and one after the stepper.
            (
                Unit::Millimetre,
                &[
                    Element::Leadscrew { lead: 5.0 },
                    Element::Encoder { lines: 0 },
                ],
                1,
            ),
            (
                Unit::Millimetre,
                &[
                    Element::Leadscrew { lead: 5.0 },
                    Element::Stepper { step_angle: 1.8 },
                    Element::Encoder { lines: 1000 },
                ],
                2,
            ),
        ];
        for (unit, chain, index) in cases {
            let err = ElementChain::new(*unit, chain).unwrap_err();
            assert_eq!(err.index, *index, "{chain:?}: {err}");
        }
    }
}
