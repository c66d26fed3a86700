//! Where a drawing (an SVG or a photo) goes on the machine: fitted to the
//! x/y travel with a margin, scaled, rotated, moved. The same options serve
//! `motet run --fit/--scale/--rotate/--origin` and any program that loads
//! jobs through [`crate::JobOptions`].
//!
//! The rule, in order:
//!
//! 1. The drawing is read as without placement (an SVG at the document's
//!    own size with its bottom-left page corner at x 0, y 0; a photo fitted
//!    to the travel less 10 mm and centred). Its *box* is the bounding box
//!    of every point the tool goes to (drawn strokes, not the page: blank
//!    page borders and stroke widths do not count).
//! 2. **Rotate** by [`Placement::rotate_deg`], counter-clockwise (from +x
//!    towards +y, as the machine sees it) about the box's centre.
//! 3. **Scale** by [`Placement::scale`], or **fit**: the largest factor that
//!    fits the rotated box into the x/y travel less
//!    [`Placement::fit_margin_mm`] on every side, keeping the aspect ratio.
//! 4. **Move**: a fitted drawing is centred in the travel; with
//!    [`Placement::origin`] the placed box's lower-left corner (least x,
//!    least y) lands there; otherwise the lower-left corner stays where it
//!    was in step 1 (scaling grows the drawing up and right from it).
//!
//! Fitting chooses both the size and the place, so `fit_margin_mm` with
//! `scale` or with `origin` is refused. A placed point beyond the travel by
//! at most [`PLACEMENT_TOLERANCE_MM`] (float noise, a drawing that touches
//! its own edge by a few micrometres) is put on the travel's edge and
//! counted in [`Placed::clamps`]; farther is an error naming the flags.
//! G-code jobs are not placed: their coordinates are the machine's
//! (arcs, relative moves and other axes make a transform unsound), so any
//! placement on one is refused.

use motet_host::Clamps;
use motet_planner::ranges::number;

/// Margin of `--fit` without a value, mm.
pub const DEFAULT_FIT_MARGIN_MM: f64 = 10.0;

/// How far a placed point may lie beyond the x/y travel and still be put on
/// its edge, mm: well under a pen's or a laser spot's width, far above
/// float noise.
pub const PLACEMENT_TOLERANCE_MM: f64 = 0.01;

/// Where a drawing goes on the machine (see the module docs for the order).
/// The default places nothing: jobs are read exactly as without it.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Placement {
    /// Fit the drawing into the x/y travel less this margin on every side,
    /// mm (≥ 0), keeping its aspect ratio, centred (`--fit [MARGIN_MM]`).
    pub fit_margin_mm: Option<f64>,
    /// Scale factor (> 0; `--scale S`).
    pub scale: Option<f64>,
    /// Rotation, degrees counter-clockwise about the drawing's centre
    /// (`--rotate DEG`); 0 for none.
    pub rotate_deg: f64,
    /// Machine x, y (mm) of the placed drawing's lower-left corner
    /// (`--origin X,Y`).
    pub origin: Option<[f64; 2]>,
}

/// What placing a drawing did, for the summary and the report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    /// The scale factor applied (the one fitting chose, with a fit).
    pub scale: f64,
    /// The rotation applied, degrees counter-clockwise.
    pub rotate_deg: f64,
    /// The placed drawing's bounding box, machine mm: least x, y.
    pub min: [f64; 2],
    /// Greatest x, y.
    pub max: [f64; 2],
    /// Points beyond the travel by at most [`PLACEMENT_TOLERANCE_MM`], put on
    /// its edge.
    pub clamps: Clamps,
}

/// A placement that cannot be used, naming the field and its flag.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlacementError {
    /// A value out of its range (scale ≤ 0, a negative margin, NaN, ∞).
    #[error("placement {field} (`{flag}`) must be {expected}, not {}", number(*.value))]
    Invalid {
        /// The [`Placement`] field.
        field: &'static str,
        /// The `motet run` flag that sets it.
        flag: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// `--origin` text that is not `X,Y`.
    #[error("placement origin (`--origin`) must be X,Y in mm (two numbers, e.g. 10,20), not `{text}`: {why}")]
    Origin {
        /// The text given.
        text: String,
        /// What is wrong with it.
        why: String,
    },
    /// Two options that each decide the same thing.
    #[error("placement {first} (`{first_flag}`) and {second} (`{second_flag}`) cannot be combined: {why}")]
    Conflict {
        /// One field.
        first: &'static str,
        /// Its flag.
        first_flag: &'static str,
        /// The other field.
        second: &'static str,
        /// Its flag.
        second_flag: &'static str,
        /// Why not.
        why: &'static str,
    },
    /// A fit margin that leaves no room.
    #[error("placement fit_margin_mm (`--fit`) {} mm leaves nothing of the {} × {} mm x/y travel to draw on (it must be under half the shorter side)", number(*.margin_mm), number(*.width_mm), number(*.height_mm))]
    MarginTooLarge {
        /// The margin given, mm.
        margin_mm: f64,
        /// Width of the x travel, mm.
        width_mm: f64,
        /// Height of the y travel, mm.
        height_mm: f64,
    },
    /// A fit asked of a drawing with no width and no height (one point).
    #[error("placement fit_margin_mm (`--fit`): the drawing has no size to fit (all its points are one point)")]
    NothingToFit,
    /// The job is G-code.
    #[error("placement (`--fit`, `--scale`, `--rotate`, `--origin`) applies to SVG and photo jobs; a G-code job's coordinates are the machine's and are not placed")]
    NotADrawing,
    /// The machine has no x or no y axis, or no finite travel on it.
    #[error("placement needs x and y axes with a finite travel; this machine {0}")]
    NoArea(String),
    /// The placed drawing leaves the travel by more than
    /// [`PLACEMENT_TOLERANCE_MM`].
    #[error("the placed drawing spans {axis} {lo:.3}..{hi:.3} mm, beyond the {axis} travel {}..{} mm; {hint}", number(*.min), number(*.max))]
    Beyond {
        /// `x` or `y`.
        axis: &'static str,
        /// Least placed coordinate, mm.
        lo: f64,
        /// Greatest placed coordinate, mm.
        hi: f64,
        /// The travel's low end, mm.
        min: f64,
        /// Its high end, mm.
        max: f64,
        /// What to change, naming the flags.
        hint: &'static str,
    },
}

impl Placement {
    /// A placement that fits the drawing with `margin_mm` on every side.
    pub fn fit(margin_mm: f64) -> Placement {
        Placement {
            fit_margin_mm: Some(margin_mm),
            ..Placement::default()
        }
    }

    /// Whether every field is at its default: the job is read exactly as
    /// without placement.
    pub fn is_identity(&self) -> bool {
        self.fit_margin_mm.is_none()
            && self.scale.is_none()
            && self.rotate_deg == 0.0
            && self.origin.is_none()
    }

    /// Checks every value and combination before any job is read.
    pub fn check(&self) -> Result<(), PlacementError> {
        if let Some(m) = self.fit_margin_mm {
            if !(m >= 0.0 && m.is_finite()) {
                return Err(invalid(
                    "fit_margin_mm",
                    "--fit",
                    m,
                    "a finite number of mm ≥ 0",
                ));
            }
        }
        if let Some(s) = self.scale {
            if !(s > 0.0 && s.is_finite()) {
                return Err(invalid("scale", "--scale", s, "a finite number > 0"));
            }
        }
        if !self.rotate_deg.is_finite() {
            return Err(invalid(
                "rotate_deg",
                "--rotate",
                self.rotate_deg,
                "a finite number of degrees",
            ));
        }
        if let Some(o) = self.origin {
            for v in o {
                if !v.is_finite() {
                    return Err(invalid("origin", "--origin", v, "two finite numbers of mm"));
                }
            }
        }
        if self.fit_margin_mm.is_some() {
            let why = "fitting chooses the drawing's size and place";
            if self.scale.is_some() {
                return Err(conflict("scale", "--scale", why));
            }
            if self.origin.is_some() {
                return Err(conflict("origin", "--origin", why));
            }
        }
        Ok(())
    }

    /// Reads `--origin`'s `X,Y` (mm; spaces around either number allowed).
    pub fn parse_origin(text: &str) -> Result<[f64; 2], PlacementError> {
        let bad = |why: String| PlacementError::Origin {
            text: text.to_string(),
            why,
        };
        let mut parts = text.split(',');
        let (Some(x), Some(y), None) = (parts.next(), parts.next(), parts.next()) else {
            return Err(bad("expected exactly one comma".into()));
        };
        let mut out = [0.0; 2];
        for (v, (name, s)) in out.iter_mut().zip([("X", x), ("Y", y)]) {
            let s = s.trim();
            *v = s
                .parse::<f64>()
                .map_err(|_| bad(format!("{name} `{s}` is not a number")))?;
            if !v.is_finite() {
                return Err(bad(format!("{name} must be finite")));
            }
        }
        Ok(out)
    }
}

fn invalid(
    field: &'static str,
    flag: &'static str,
    value: f64,
    expected: &'static str,
) -> PlacementError {
    PlacementError::Invalid {
        field,
        flag,
        value,
        expected,
    }
}

fn conflict(second: &'static str, second_flag: &'static str, why: &'static str) -> PlacementError {
    PlacementError::Conflict {
        first: "fit_margin_mm",
        first_flag: "--fit",
        second,
        second_flag,
        why,
    }
}
