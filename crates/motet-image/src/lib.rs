//! Photograph job source: a PNG or JPEG turned into a pen drawing.
//!
//! After the MakerBot "draw a face on a post-it note" experiment (Freesteel
//! blog, December 2011): find the sudden changes in brightness and run the
//! pen along them. [`parse`] does, in order:
//!
//! 1. **Decode** the bytes; the format (PNG or JPEG) is sniffed from the
//!    content, not from a file name. Transparent pixels are composited over
//!    white (the paper). Broken, truncated or unsupported input is a
//!    [`SourceError`] `cannot decode image: …`.
//! 2. **Resize** so that the longer side is [`ImageOptions::max_px`] pixels
//!    (up or down; every pixel-valued option refers to this working
//!    resolution), and convert to **grayscale**.
//! 3. **Blur** with a Gaussian of [`ImageOptions::blur_sigma`] pixels (on top
//!    of the σ = 1.4 blur `imageproc`'s Canny applies itself), which keeps
//!    skin texture and JPEG noise from turning into scribbles.
//! 4. **Canny** edge detection ([`imageproc::edges::canny`]). Thresholds are
//!    Sobel gradient magnitudes; NaN thresholds are chosen from the image:
//!    the high one at the [`AUTO_HIGH_PERCENTILE`] of the gradient
//!    magnitudes (at least [`AUTO_HIGH_FLOOR`]), the low one at
//!    [`AUTO_LOW_RATIO`] of the high one.
//! 5. **Thin** the edges to one pixel (Zhang–Suen: Canny keeps both pixels
//!    of a step that falls exactly between two), then **trace** them into
//!    chains of pixels: pixels are linked as 8-neighbours, except that a diagonal link is ignored where a
//!    side pixel already connects the two (mixed adjacency), so Canny's
//!    staircases are simple curves. Chains start at end pixels (one
//!    neighbour), then at forks (three or more neighbours), then the
//!    remaining closed loops are traced; every pixel is traced once, and
//!    forks end chains (a chain may end on a fork another chain already
//!    passed through, so the drawing stays connected).
//! 6. **Drop** chains of fewer than [`ImageOptions::min_length_px`] pixels
//!    (isolated specks and short spurs), except short links between two
//!    forks of a larger edge, which would otherwise leave gaps.
//! 7. **Simplify** each chain (pixel centres) with Ramer–Douglas–Peucker to
//!    [`ImageOptions::simplify_px`].
//! 8. **Order** the polylines greedily: next is the one with the free end
//!    point nearest to the pen (reversed if that is its last point), found
//!    with a uniform grid; the first is the one nearest to the machine's
//!    start position.
//! 9. **Fit** pixels to machine millimetres: image y points down, machine y
//!    up; by default the image is scaled to fit the x/y travel less a
//!    [`DEFAULT_MARGIN_MM`] margin, keeping its aspect ratio, and centred.
//! 10. **Emit** the same shape of output as the SVG source: for each
//!     polyline a pen-up (tool 0.0), a rapid to its start, a pen-down (the
//!     primary tool's `on_value`), [`MoveKind::Feed`](motet_planner::MoveKind::Feed) moves at
//!     [`JobTarget::draw_feed`]; a pen-up at the end. The pen is not lifted
//!     between polylines that meet, and no move has zero length. Axes other
//!     than x and y keep the start position (clamped into their travel).
//!
//! Every move lies within the travel of the machine's axes; a placement
//! ([`ImageOptions::width_mm`], [`ImageOptions::origin`]) that would draw
//! outside it is an error.
//!
//! # Source locations
//!
//! Images have no lines: every command and every error is located at line 0
//! (column 0), meaning "the whole file".

mod order;
mod simplify;
mod trace;

use image::imageops::FilterType;
use image::{DynamicImage, GrayImage, ImageFormat};
use motet_planner::{
    Command, JobTarget, Located, SourceError, SourceLoc, StrokeEmitter, StrokeSettings,
};
use motet_trajectory::MAX_AXES;

use trace::EdgeMap;

/// Default working resolution: pixels along the longer side.
pub const DEFAULT_MAX_PX: u32 = 400;
/// Largest accepted [`ImageOptions::max_px`].
pub const MAX_WORKING_PX: u32 = 8192;
/// Smallest accepted [`ImageOptions::max_px`].
pub const MIN_WORKING_PX: u32 = 8;
/// Largest accepted [`ImageOptions::blur_sigma`], in pixels.
pub const MAX_BLUR_SIGMA: f32 = 100.0;
/// Margin left on each side of the travel when the image is fitted, in mm
/// (at most a quarter of the shorter travel).
pub const DEFAULT_MARGIN_MM: f64 = 10.0;
/// Automatic high threshold: this fraction of all pixels have a weaker
/// gradient.
pub const AUTO_HIGH_PERCENTILE: f64 = 0.75;
/// Lowest automatic high threshold (Sobel magnitude; a black/white step
/// reaches about 1000), so that flat images yield no edges from noise.
pub const AUTO_HIGH_FLOOR: f32 = 40.0;
/// Automatic low threshold as a fraction of the high one.
pub const AUTO_LOW_RATIO: f32 = 0.4;
/// Smallest low threshold handed to Canny. imageproc's hysteresis would
/// otherwise also follow the zero-strength image border (and index outside
/// the image).
const MIN_LOW_THRESHOLD: f32 = 1.0;
/// Blur Canny applies itself before taking gradients.
const CANNY_SIGMA: f32 = 1.4;
/// Where the commands come from: an image has no lines.
const LOC: SourceLoc = SourceLoc { line: 0, column: 0 };

/// How the photograph is turned into strokes and placed on the machine.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageOptions {
    /// Width of the whole image on the machine in mm; the height follows
    /// from the aspect ratio. `None`: as large as fits the x/y travel less a
    /// [`DEFAULT_MARGIN_MM`] margin on every side.
    pub width_mm: Option<f64>,
    /// Machine x, y (mm) of the image's bottom-left corner. `None`: the image
    /// is centred in the x/y travel.
    pub origin: Option<[f64; 2]>,
    /// Working resolution: pixels along the longer side after resizing
    /// ([`MIN_WORKING_PX`]..=[`MAX_WORKING_PX`], default [`DEFAULT_MAX_PX`]).
    pub max_px: u32,
    /// Canny low (weak edge) threshold, Sobel gradient magnitude; NaN:
    /// [`AUTO_LOW_RATIO`] × the high threshold. Raised to at least 1.
    pub low_threshold: f32,
    /// Canny high (strong edge) threshold, Sobel gradient magnitude; NaN:
    /// chosen from the image (see the crate documentation).
    pub high_threshold: f32,
    /// Gaussian blur before edge detection in working pixels; 0 for none.
    /// Default 1.5.
    pub blur_sigma: f32,
    /// Edge chains with fewer pixels than this are dropped. Default 8.
    pub min_length_px: usize,
    /// Ramer–Douglas–Peucker tolerance in working pixels; 0 keeps every
    /// pixel. Default 0.8.
    pub simplify_px: f64,
}

impl Default for ImageOptions {
    fn default() -> Self {
        ImageOptions {
            width_mm: None,
            origin: None,
            max_px: DEFAULT_MAX_PX,
            low_threshold: f32::NAN,
            high_threshold: f32::NAN,
            blur_sigma: 1.5,
            min_length_px: 8,
            simplify_px: 0.8,
        }
    }
}

/// What [`parse_with_info`] made of the image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImageInfo {
    /// Working resolution (after resizing to [`ImageOptions::max_px`]).
    pub width_px: u32,
    /// Working height in pixels, after the same resizing as
    /// [`ImageInfo::width_px`].
    pub height_px: u32,
    /// Polylines drawn (after dropping short chains).
    pub polylines: usize,
    /// Vertices of those polylines after simplification.
    pub points: usize,
    /// Pen-down path length, mm.
    pub drawn_mm: f64,
    /// Pen-up travel length including the first move from the start, mm.
    pub travel_mm: f64,
}

/// Turn a PNG or JPEG photograph into pen-drawing commands for `target`.
///
/// Returns an empty list (and no error) for an image without edges. Errors
/// (all at line 0): undecodable input (`cannot decode image: …`), a machine
/// without `x` or `y` axis, invalid options or travel, a placement beyond
/// the travel.
pub fn parse(
    data: &[u8],
    target: &JobTarget,
    opts: &ImageOptions,
) -> Result<Vec<Located<Command>>, SourceError> {
    parse_with_info(data, target, opts).map(|(commands, _)| commands)
}

/// Edge polylines in the working image's pixels (x right, y down).
#[derive(Clone, Debug, PartialEq)]
pub struct EdgeDrawing {
    /// Working image width in pixels (after resizing to
    /// [`ImageOptions::max_px`]).
    pub width_px: u32,
    /// Working image height in pixels.
    pub height_px: u32,
    /// Traced, simplified edge chains, each at least the minimum length, as
    /// `[x, y]` pixel coordinates of the working image.
    pub polylines: Vec<Vec<[f64; 2]>>,
}

/// The first half of the pipeline for callers that place and order strokes
/// themselves (the Python example does): decode, grayscale, resize, blur,
/// Canny, thin, trace, drop short chains, simplify. Returns the working image
/// size and the polylines in its pixel coordinates.
pub fn edge_polylines(data: &[u8], opts: &ImageOptions) -> Result<EdgeDrawing, SourceError> {
    check_options(opts)?;
    let work = resize(decode(data)?, opts.max_px);
    let (w, h) = work.dimensions();
    Ok(EdgeDrawing {
        width_px: w,
        height_px: h,
        polylines: polylines(&work, opts),
    })
}

/// [`parse`], also returning statistics about the drawing.
pub fn parse_with_info(
    data: &[u8],
    target: &JobTarget,
    opts: &ImageOptions,
) -> Result<(Vec<Located<Command>>, ImageInfo), SourceError> {
    let xi = target
        .axis("x")
        .ok_or_else(|| error("an image needs an x axis; the machine has none"))?;
    let yi = target
        .axis("y")
        .ok_or_else(|| error("an image needs a y axis; the machine has none"))?;
    check_options(opts)?;
    let travel_x = travel(target, xi)?;
    let travel_y = travel(target, yi)?;

    let gray = decode(data)?;
    let work = resize(gray, opts.max_px);
    let (w, h) = work.dimensions();
    let lines = polylines(&work, opts);

    // Placement: pixel (px, py) -> machine mm.
    let (scale, origin) = placement(travel_x, travel_y, w, h, opts)?;
    let to_mm = |p: [f64; 2]| {
        [
            origin[0] + p[0] * scale,
            origin[1] + (h as f64 - p[1]) * scale,
        ]
    };
    let from = [
        (target.start[xi] - origin[0]) / scale,
        h as f64 - (target.start[yi] - origin[1]) / scale,
    ];
    let from = if from.iter().all(|v| v.is_finite()) {
        from
    } else {
        [0.0, 0.0]
    };
    let ordered = order::order(lines, from);

    let mut mm: Vec<Vec<[f64; 2]>> = Vec::with_capacity(ordered.len());
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for line in &ordered {
        let l: Vec<[f64; 2]> = line.iter().map(|&p| to_mm(p)).collect();
        for p in &l {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        mm.push(l);
    }
    if !mm.is_empty() {
        for (k, (name, t)) in [("x", travel_x), ("y", travel_y)].into_iter().enumerate() {
            if !(lo[k] >= t[0] && hi[k] <= t[1]) {
                return Err(error(format!(
                    "the drawing spans {name} {:.3}..{:.3} mm, beyond the {name} travel \
                     {}..{} mm; use a smaller width_mm or another origin",
                    lo[k], hi[k], t[0], t[1]
                )));
            }
        }
    }

    let mut start = target.start;
    for (i, axis) in target.axes.iter().enumerate().take(MAX_AXES) {
        let [a, b] = axis.travel;
        if i != xi && i != yi && a <= b {
            start[i] = if start[i] >= a { start[i].min(b) } else { a };
        }
    }
    let mut em = StrokeEmitter::new(StrokeSettings {
        start,
        ..StrokeSettings::for_target(target, xi, yi)
    });
    let mut info = ImageInfo {
        width_px: w,
        height_px: h,
        ..ImageInfo::default()
    };
    for line in &mm {
        if em.polyline(line, LOC) {
            info.polylines += 1;
            info.points += line.len();
        }
    }
    info.drawn_mm = em.drawn();
    info.travel_mm = em.travel();
    Ok((em.finish(LOC), info))
}

fn error(message: impl Into<String>) -> SourceError {
    SourceError::new(0, 0, message)
}

fn check_options(opts: &ImageOptions) -> Result<(), SourceError> {
    if !(MIN_WORKING_PX..=MAX_WORKING_PX).contains(&opts.max_px) {
        return Err(error(format!(
            "max_px must be {MIN_WORKING_PX}..={MAX_WORKING_PX}, not {}",
            opts.max_px
        )));
    }
    for (name, v) in [
        ("low_threshold", opts.low_threshold),
        ("high_threshold", opts.high_threshold),
    ] {
        if v < 0.0 {
            return Err(error(format!("{name} must not be negative, not {v}")));
        }
    }
    if opts.low_threshold > opts.high_threshold {
        return Err(error(format!(
            "low_threshold {} is above high_threshold {}",
            opts.low_threshold, opts.high_threshold
        )));
    }
    if !(0.0..=MAX_BLUR_SIGMA).contains(&opts.blur_sigma) {
        return Err(error(format!(
            "blur_sigma must be 0..={MAX_BLUR_SIGMA} pixels, not {}",
            opts.blur_sigma
        )));
    }
    if !(opts.simplify_px >= 0.0 && opts.simplify_px.is_finite()) {
        return Err(error(format!(
            "simplify_px must be a non-negative number, not {}",
            opts.simplify_px
        )));
    }
    if let Some(wm) = opts.width_mm {
        if !(wm > 0.0 && wm.is_finite()) {
            return Err(error(format!(
                "width_mm must be a positive number, not {wm}"
            )));
        }
    }
    if let Some(o) = opts.origin {
        if !o.iter().all(|v| v.is_finite()) {
            return Err(error(format!("origin must be finite, not {o:?}")));
        }
    }
    Ok(())
}

fn travel(target: &JobTarget, i: usize) -> Result<[f64; 2], SourceError> {
    let axis = &target.axes[i];
    let [a, b] = axis.travel;
    if a <= b {
        Ok([a, b])
    } else {
        Err(error(format!(
            "the {} axis has no valid travel ({a}..{b})",
            axis.name
        )))
    }
}

/// Decode PNG or JPEG bytes into grayscale, transparent parts over white.
fn decode(data: &[u8]) -> Result<GrayImage, SourceError> {
    if data.is_empty() {
        return Err(error("cannot decode image: the input is empty"));
    }
    let format = match image::guess_format(data) {
        Ok(f @ (ImageFormat::Png | ImageFormat::Jpeg)) => f,
        Ok(f) => {
            return Err(error(format!(
                "cannot decode image: {} is not supported (only PNG and JPEG)",
                f.extensions_str().first().unwrap_or(&"this format")
            )))
        }
        Err(_) => {
            return Err(error(
                "cannot decode image: not a PNG or JPEG file (unrecognised content)",
            ))
        }
    };
    if format == ImageFormat::Png && !png_has_end(data) {
        // The PNG decoder does not need the end chunk; a file cut there is
        // still a cut file.
        return Err(error(
            "cannot decode image: truncated PNG (no complete IEND chunk)",
        ));
    }
    if format == ImageFormat::Jpeg && !jpeg_has_end(data) {
        // The JPEG decoder fills a cut-off scan with gray and reports
        // success; a photo cut in half is not what the user meant to draw.
        return Err(error(
            "cannot decode image: truncated JPEG (no end-of-image marker after the image data)",
        ));
    }
    // Decoders are fuzzed, but a panic on hostile input must still not take
    // the host down.
    let decoded = std::panic::catch_unwind(|| image::load_from_memory_with_format(data, format));
    let img = match decoded {
        Ok(Ok(img)) => img,
        Ok(Err(e)) => return Err(error(format!("cannot decode image: {e}"))),
        Err(_) => {
            return Err(error(
                "cannot decode image: the decoder failed on malformed data",
            ))
        }
    };
    if img.width() == 0 || img.height() == 0 {
        return Err(error("cannot decode image: the image has no pixels"));
    }
    Ok(gray_on_white(&img))
}

/// Whether a PNG has its end chunk, checksum included.
fn png_has_end(data: &[u8]) -> bool {
    data.windows(4)
        .rposition(|w| w == b"IEND")
        .is_some_and(|p| p + 8 <= data.len())
}

/// Whether a JPEG has an end-of-image marker after its last start-of-scan.
/// (Entropy-coded data escapes 0xFF, so neither marker can occur inside a
/// scan; an EXIF thumbnail's markers come before the main image's scans.)
fn jpeg_has_end(data: &[u8]) -> bool {
    let find_last = |m: u8| data.windows(2).rposition(|w| w == [0xFF, m]);
    match (find_last(0xDA), find_last(0xD9)) {
        (Some(sos), Some(eoi)) => eoi > sos,
        _ => false,
    }
}

fn gray_on_white(img: &DynamicImage) -> GrayImage {
    if !img.color().has_alpha() {
        return img.to_luma8();
    }
    let la = img.to_luma_alpha8();
    let (w, h) = la.dimensions();
    let data = la
        .pixels()
        .map(|p| {
            let [l, a] = p.0;
            let (l, a) = (l as u32, a as u32);
            ((l * a + 255 * (255 - a) + 127) / 255) as u8
        })
        .collect();
    GrayImage::from_raw(w, h, data).expect("size matches")
}

fn resize(img: GrayImage, max_px: u32) -> GrayImage {
    let (w, h) = img.dimensions();
    let long = w.max(h) as f64;
    let s = max_px as f64 / long;
    let nw = ((w as f64 * s).round() as u32).clamp(1, max_px);
    let nh = ((h as f64 * s).round() as u32).clamp(1, max_px);
    if (nw, nh) == (w, h) {
        img
    } else {
        image::imageops::resize(&img, nw, nh, FilterType::Triangle)
    }
}

/// Canny thresholds from the options, automatic where NaN.
fn thresholds(img: &GrayImage, opts: &ImageOptions) -> (f32, f32) {
    let high = if opts.high_threshold.is_nan() {
        let auto = auto_high(img);
        // A given low threshold above the automatic high one wins.
        if opts.low_threshold.is_nan() {
            auto
        } else {
            auto.max(opts.low_threshold)
        }
    } else {
        opts.high_threshold
    };
    let low = if opts.low_threshold.is_nan() {
        AUTO_LOW_RATIO * high
    } else {
        opts.low_threshold
    };
    let low = low.max(MIN_LOW_THRESHOLD);
    (low, high.max(low))
}

fn auto_high(img: &GrayImage) -> f32 {
    let blurred = imageproc::filter::gaussian_blur_f32(img, CANNY_SIGMA);
    let mut mag = imageproc::gradients::sobel_gradients(&blurred).into_raw();
    if mag.is_empty() {
        return AUTO_HIGH_FLOOR;
    }
    let k = ((mag.len() - 1) as f64 * AUTO_HIGH_PERCENTILE).round() as usize;
    let (_, &mut v, _) = mag.select_nth_unstable(k);
    (v as f32).max(AUTO_HIGH_FLOOR)
}

/// Edge polylines in working-pixel coordinates (pixel centres, y down).
fn polylines(work: &GrayImage, opts: &ImageOptions) -> Vec<Vec<[f64; 2]>> {
    let pre = if opts.blur_sigma > 0.0 {
        imageproc::filter::gaussian_blur_f32(work, opts.blur_sigma)
    } else {
        work.clone()
    };
    let (low, high) = thresholds(&pre, opts);
    let edges = imageproc::edges::canny(&pre, low, high);
    let (w, h) = edges.dimensions();
    let mut map = EdgeMap {
        width: w,
        height: h,
        set: edges.into_raw().into_iter().map(|v| v > 0).collect(),
    };
    trace::thin(&mut map);
    let chains = trace::trace(&map);
    let sizes = trace::component_sizes(&map);
    let min = opts.min_length_px;
    chains
        .into_iter()
        .filter(|c| {
            let (a, b) = (c.pixels[0], c.pixels[c.pixels.len() - 1]);
            c.pixels.len() >= min
                || (a != b
                    && trace::is_fork(&map, a)
                    && trace::is_fork(&map, b)
                    && sizes[a as usize] as usize >= min)
        })
        .map(|c| {
            let pts: Vec<[f64; 2]> = c
                .pixels
                .iter()
                .map(|&p| [(p % w) as f64 + 0.5, (p / w) as f64 + 0.5])
                .collect();
            simplify::rdp(&pts, opts.simplify_px)
        })
        .collect()
}

/// Scale (mm per working pixel) and the machine position of the image's
/// bottom-left corner.
fn placement(
    tx: [f64; 2],
    ty: [f64; 2],
    w: u32,
    h: u32,
    opts: &ImageOptions,
) -> Result<(f64, [f64; 2]), SourceError> {
    let (w, h) = (w as f64, h as f64);
    let finite = tx.iter().chain(&ty).all(|v| v.is_finite());
    let scale = match opts.width_mm {
        Some(wm) => wm / w,
        None => {
            if !finite {
                return Err(error(
                    "cannot fit the image to an unbounded x/y travel; give width_mm and origin",
                ));
            }
            let (sx, sy) = (tx[1] - tx[0], ty[1] - ty[0]);
            let margin = DEFAULT_MARGIN_MM.min(sx.min(sy) / 4.0);
            ((sx - 2.0 * margin) / w).min((sy - 2.0 * margin) / h)
        }
    };
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(error(format!(
            "the x/y travel ({}..{}, {}..{} mm) is too small to draw on",
            tx[0], tx[1], ty[0], ty[1]
        )));
    }
    let origin = match opts.origin {
        Some(o) => o,
        None => {
            if !finite {
                return Err(error(
                    "cannot centre the image in an unbounded x/y travel; give origin",
                ));
            }
            [
                (tx[0] + tx[1]) / 2.0 - w * scale / 2.0,
                (ty[0] + ty[1]) / 2.0 - h * scale / 2.0,
            ]
        }
    };
    Ok((scale, origin))
}
