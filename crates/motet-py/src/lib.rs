//! Python bindings: `motet.Machine` wraps `motet_api::Machine`.

mod errors;
mod events;
mod machine;
mod signals;

use errors::{MotetError, ValueOutOfRangeError};
use machine::Machine;
use pyo3::prelude::*;

type Polyline = Vec<(f64, f64)>;

/// Edges of a photograph as polylines: decode, grayscale, resize so the longest
/// side is `max_px`, blur, Canny, thin, trace, drop chains shorter than
/// `min_length_px`, simplify. Returns `(width_px, height_px, polylines)` with
/// points `(x, y)` in pixels, y pointing down.
#[pyfunction]
#[pyo3(signature = (path, max_px=400, blur_sigma=1.5, min_length_px=8, simplify_px=0.8))]
fn trace_edges(
    py: Python<'_>,
    path: &str,
    max_px: u32,
    blur_sigma: f32,
    min_length_px: usize,
    simplify_px: f64,
) -> PyResult<(u32, u32, Vec<Polyline>)> {
    let data =
        std::fs::read(path).map_err(|e| MotetError::new_err(format!("cannot read {path}: {e}")))?;
    let opts = motet_image::ImageOptions {
        max_px,
        blur_sigma,
        min_length_px,
        simplify_px,
        ..Default::default()
    };
    let d = py
        .detach(|| motet_image::edge_polylines(&data, &opts))
        .map_err(|e| ValueOutOfRangeError::new_err(format!("{path}: {}", e.message)))?;
    let lines = d
        .polylines
        .into_iter()
        .map(|l| l.into_iter().map(|p| (p[0], p[1])).collect())
        .collect();
    Ok((d.width_px, d.height_px, lines))
}

/// Reads a job file (G-code, SVG or photo), checks it against the machine and
/// streams it: the same as `motet run`, from a script.
#[pyfunction]
#[pyo3(signature = (machine, path, allow_unknown=false))]
fn run_job(
    py: Python<'_>,
    machine: PyRef<'_, Machine>,
    path: &str,
    allow_unknown: bool,
) -> PyResult<usize> {
    machine.work(py, |m| m.run_job(path, allow_unknown))
}

#[pymodule]
fn _motet(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Machine>()?;
    m.add_function(wrap_pyfunction!(trace_edges, m)?)?;
    m.add_function(wrap_pyfunction!(run_job, m)?)?;
    errors::register(m)
}
