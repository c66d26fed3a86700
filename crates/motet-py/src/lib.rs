//! Python bindings: `motet.Machine` wraps `motet_api::Machine`.

use motet_api::{ApiError, Event, Machine as Inner};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

create_exception!(
    _motet,
    MotetError,
    PyException,
    "Base class of motet's errors."
);
create_exception!(
    _motet,
    MachineFileError,
    MotetError,
    "The machine file is invalid; the message names file:line:column."
);
create_exception!(
    _motet,
    UnreachableError,
    MotetError,
    "The target is beyond travel or cannot be reached by the kinematics."
);
create_exception!(
    _motet,
    UnknownNameError,
    MotetError,
    "No axis or tool has that name."
);
create_exception!(
    _motet,
    ValueOutOfRangeError,
    MotetError,
    "A feed, dwell or tool value is out of range."
);

fn to_py(e: ApiError) -> PyErr {
    let msg = e.to_string();
    match e {
        ApiError::Machine(_) => MachineFileError::new_err(msg),
        ApiError::Unreachable(_) => UnreachableError::new_err(msg),
        ApiError::UnknownAxis { .. } | ApiError::UnknownTool { .. } => {
            UnknownNameError::new_err(msg)
        }
        ApiError::BadFeed(_) | ApiError::BadDwell(_) | ApiError::BadToolValue(_) => {
            ValueOutOfRangeError::new_err(msg)
        }
        _ => MotetError::new_err(msg),
    }
}

/// Named axis values from keyword arguments, e.g. `x=10, y=20`.
fn axes(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, f64)>> {
    let mut out = Vec::new();
    if let Some(kw) = kwargs {
        for (k, v) in kw.iter() {
            out.push((k.extract::<String>()?, v.extract::<f64>()?));
        }
    }
    Ok(out)
}

fn borrowed(v: &[(String, f64)]) -> Vec<(&str, f64)> {
    v.iter().map(|(k, x)| (k.as_str(), *x)).collect()
}

/// A machine driven call by call. Moves are planned and streamed to the
/// machine's nodes as they are called; a call blocks only when the machine's
/// queues are full.
#[pyclass(unsendable, module = "motet._motet")]
struct Machine {
    inner: Inner,
}

#[pymethods]
impl Machine {
    /// Opens the machine described by a machine file (TOML), on simulated nodes.
    #[new]
    fn new(path: &str) -> PyResult<Self> {
        Ok(Machine {
            inner: Inner::open(path).map_err(to_py)?,
        })
    }

    /// Axis names, in order.
    #[getter]
    fn axes(&self) -> Vec<String> {
        self.inner.axes()
    }

    /// Tool names.
    #[getter]
    fn tools(&self) -> Vec<String> {
        self.inner.tools()
    }

    /// Move the named axes to absolute positions: `move_to(x=10, y=20, feed=50)`.
    /// `feed` is in units per second; without it the machine's drawing feed.
    #[pyo3(signature = (feed=None, **kwargs))]
    fn move_to(&mut self, feed: Option<f64>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let a = axes(kwargs)?;
        self.inner.move_to(&borrowed(&a), feed).map_err(to_py)
    }

    /// Move the named axes to absolute positions as fast as the limits allow.
    #[pyo3(signature = (**kwargs))]
    fn rapid_to(&mut self, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let a = axes(kwargs)?;
        self.inner.rapid_to(&borrowed(&a)).map_err(to_py)
    }

    /// Move the named axes by the given amounts: `jog(x=-5)`.
    #[pyo3(signature = (feed=None, **kwargs))]
    fn jog(&mut self, feed: Option<f64>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let a = axes(kwargs)?;
        self.inner.jog(&borrowed(&a), feed).map_err(to_py)
    }

    /// Set a tool output: pen 1 down / 0 up, laser or spindle power 0..1.
    fn set_tool(&mut self, tool: &str, value: f32) -> PyResult<()> {
        self.inner.set_tool(tool, value).map_err(to_py)
    }

    /// Stand still for `seconds` after the motion queued before.
    fn dwell(&mut self, seconds: f64) -> PyResult<()> {
        self.inner.dwell(seconds).map_err(to_py)
    }

    /// Block until everything queued has run and the machine is at rest.
    fn wait(&mut self) -> PyResult<()> {
        self.inner.wait().map_err(to_py)
    }

    /// Where the motors are now, by axis name.
    #[getter]
    fn position<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.inner.position() {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Where the machine will be after everything queued, by axis name.
    #[getter]
    fn target<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.inner.target() {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Simulated time, seconds.
    #[getter]
    fn time(&self) -> f64 {
        self.inner.time()
    }

    /// Calls `callback(event)` for every event: a dict with `kind` ("tool" or
    /// "idle"), `time` (s) and, for tools, `tool` and `value`.
    fn on_event(&mut self, callback: Py<PyAny>) {
        self.inner.on_event(move |e| {
            Python::attach(|py| {
                let d = PyDict::new(py);
                let filled: PyResult<()> = (|| {
                    match e {
                        Event::Tool { time, tool, value } => {
                            d.set_item("kind", "tool")?;
                            d.set_item("time", *time)?;
                            d.set_item("tool", tool)?;
                            d.set_item("value", *value)?;
                        }
                        Event::Idle { time } => {
                            d.set_item("kind", "idle")?;
                            d.set_item("time", *time)?;
                        }
                    }
                    Ok(())
                })();
                let result =
                    filled.and_then(|_| callback.call1(py, PyTuple::new(py, [d])?).map(|_| ()));
                if let Err(err) = result {
                    // A callback cannot stop the machine; show its error.
                    err.print(py);
                }
            })
        });
    }

    /// The run report as a dict (duration, distances, steps, peaks, accuracy).
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&self.inner.report())
            .map_err(|e| MotetError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Write path.png, path.svg and report.json of everything executed so far.
    fn save(&mut self, directory: &str) -> PyResult<()> {
        self.inner.save(directory).map_err(to_py)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Leaving a `with` block waits for the machine to finish.
    fn __exit__(&mut self, _t: Py<PyAny>, _v: Py<PyAny>, _tb: Py<PyAny>) -> PyResult<bool> {
        self.inner.wait().map_err(to_py)?;
        Ok(false)
    }
}

type Polyline = Vec<(f64, f64)>;

/// Edges of a photograph as polylines: decode, grayscale, resize so the longest
/// side is `max_px`, blur, Canny, thin, trace, drop chains shorter than
/// `min_length_px`, simplify. Returns `(width_px, height_px, polylines)` with
/// points `(x, y)` in pixels, y pointing down.
#[pyfunction]
#[pyo3(signature = (path, max_px=400, blur_sigma=1.5, min_length_px=8, simplify_px=0.8))]
fn trace_edges(
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
    let d = motet_image::edge_polylines(&data, &opts)
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
fn run_job(machine: &mut Machine, path: &str, allow_unknown: bool) -> PyResult<usize> {
    machine.inner.run_job(path, allow_unknown).map_err(to_py)
}

#[pymodule]
fn _motet(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Machine>()?;
    m.add_function(wrap_pyfunction!(trace_edges, m)?)?;
    m.add_function(wrap_pyfunction!(run_job, m)?)?;
    let py = m.py();
    m.add("MotetError", py.get_type::<MotetError>())?;
    m.add("MachineFileError", py.get_type::<MachineFileError>())?;
    m.add("UnreachableError", py.get_type::<UnreachableError>())?;
    m.add("UnknownNameError", py.get_type::<UnknownNameError>())?;
    m.add(
        "ValueOutOfRangeError",
        py.get_type::<ValueOutOfRangeError>(),
    )?;
    Ok(())
}
