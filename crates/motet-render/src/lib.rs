//! Draws the tool path a simulated machine executed, as PNG and as SVG.
//!
//! The input is a list of [`Stroke`]s in machine coordinates (mm, x to the
//! right, **y up**). Tool-on strokes are drawn dark, travel (`tool_on =
//! false`) faint and translucent, inside a thin grey rectangle showing the
//! machine's travel [`RenderSpec::bounds`].
//!
//! Rules shared by both outputs:
//! * a stroke with fewer than 2 points is skipped, except that a single-point
//!   tool-on stroke is drawn as a dot;
//! * a non-finite coordinate (NaN, ±inf) breaks a stroke: the line is not
//!   drawn through it, the finite runs on either side are drawn separately;
//! * geometry outside the bounds is clipped at the image edge (bounds plus a
//!   small margin).
//!
//! Both are also drawn as the strokes come, for runs of any length:
//! [`PngCanvas`] rasterises each stroke as it is given (memory: the image),
//! [`SvgWriter`] writes each stroke to its output at once (memory: one
//! stroke). [`render_png`] and [`render_svg`] draw a list of strokes through
//! them. Segments are clipped against the image in `f64` before they reach
//! the rasterizer.

mod png;
mod svg;
pub mod timeplot;

pub use png::{render_png, PngCanvas};
pub use svg::{render_svg, SvgWriter, SVG_END};

/// Default for [`RenderSpec::max_px`].
pub const DEFAULT_MAX_PX: u32 = 1600;
/// Smallest accepted [`RenderSpec::max_px`].
pub const MIN_PX: u32 = 16;
/// Largest accepted [`RenderSpec::max_px`] (a 16384² RGBA image is 1 GiB).
pub const MAX_PX: u32 = 16384;

/// One continuous run of machine motion, in machine x,y (mm).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Stroke {
    /// Vertices in the order the machine passed them, machine x,y in mm.
    pub points: Vec<[f64; 2]>,
    /// `true` when the tool was working (cutting, extruding, drawing);
    /// `false` for travel moves.
    pub tool_on: bool,
}

/// What to draw and how big.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSpec {
    /// `[min, max]` of the machine's travel in mm: `[[xmin, ymin], [xmax, ymax]]`.
    pub bounds: [[f64; 2]; 2],
    /// Longest image side in pixels (PNG only); [`DEFAULT_MAX_PX`] by default.
    pub max_px: u32,
    /// Title, written into the SVG `<title>`.
    pub title: String,
}

impl RenderSpec {
    /// A spec with the default image size.
    pub fn new(bounds: [[f64; 2]; 2], title: impl Into<String>) -> Self {
        Self {
            bounds,
            max_px: DEFAULT_MAX_PX,
            title: title.into(),
        }
    }
}

/// Why a PNG could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Bounds with zero or negative width/height, or a non-finite value.
    #[error("invalid bounds {bounds:?}: need finite min < max on both axes")]
    InvalidBounds {
        /// The bounds given, `[[xmin, ymin], [xmax, ymax]]` in mm.
        bounds: [[f64; 2]; 2],
    },
    /// `max_px` outside `MIN_PX..=MAX_PX`, or an image that cannot be allocated.
    #[error("invalid image size: max_px = {max_px} (accepted {MIN_PX}..={MAX_PX})")]
    InvalidSize {
        /// The longest image side asked for, pixels.
        max_px: u32,
    },
    /// The PNG encoder failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
    /// The SVG output could not be written.
    #[error("writing the SVG failed: {0}")]
    Write(String),
}

/// Validated bounds: min corner and extent, all finite, extent > 0.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Extent {
    pub(crate) min: [f64; 2],
    pub(crate) max: [f64; 2],
    pub(crate) size: [f64; 2],
}

impl Extent {
    pub(crate) fn new(b: [[f64; 2]; 2]) -> Option<Self> {
        let size = [b[1][0] - b[0][0], b[1][1] - b[0][1]];
        let ok = b.iter().flatten().all(|v| v.is_finite())
            && size.iter().all(|s| s.is_finite() && *s > 0.0);
        ok.then_some(Self {
            min: b[0],
            max: b[1],
            size,
        })
    }

    pub(crate) fn longest(&self) -> f64 {
        self.size[0].max(self.size[1])
    }
}
