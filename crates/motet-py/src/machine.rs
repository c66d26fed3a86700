//! `motet.Machine`: `motet_api::Machine` for Python.

use crate::errors::{busy, to_py, MotetError};
use crate::events::Events;
use crate::signals::Raised;
use motet_api::{ApiError, Machine as Inner};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::RefCell;

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
///
/// Event callbacks run after the call that produced the events, so they may
/// use the machine; an exception a callback raises is raised by that call.
/// Ctrl-C stops any call within milliseconds with KeyboardInterrupt and
/// leaves the machine usable: what was accepted stays queued.
#[pyclass(unsendable, frozen, module = "motet._motet")]
pub struct Machine {
    inner: RefCell<Inner>,
    events: Events,
    raised: Raised,
}

impl Machine {
    /// Runs `f` on the machine without the GIL (other Python threads go on;
    /// Ctrl-C is checked every few milliseconds), then delivers the events
    /// it produced.
    pub fn work<R: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&mut Inner) -> Result<R, ApiError> + Send,
    ) -> PyResult<R> {
        let result = {
            let mut inner = self.inner.try_borrow_mut().map_err(|_| busy())?;
            let inner: &mut Inner = &mut inner;
            py.detach(move || f(inner))
        };
        let value = result.map_err(|e| match e {
            ApiError::Interrupted => self
                .raised
                .take()
                .unwrap_or_else(|| to_py(ApiError::Interrupted)),
            e => to_py(e),
        })?;
        self.events.deliver(py)?;
        Ok(value)
    }

    fn read<R>(&self, f: impl FnOnce(&Inner) -> R) -> PyResult<R> {
        let inner = self.inner.try_borrow().map_err(|_| busy())?;
        Ok(f(&inner))
    }
}

fn dict<'py>(py: Python<'py>, values: Vec<(String, f64)>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in values {
        d.set_item(k, v)?;
    }
    Ok(d)
}

#[pymethods]
impl Machine {
    /// Opens the machine described by a machine file (TOML), on simulated nodes.
    #[new]
    fn new(path: &str) -> PyResult<Self> {
        let mut inner = Inner::open(path).map_err(to_py)?;
        let raised = Raised::default();
        inner.on_interrupt(raised.check());
        Ok(Machine {
            inner: RefCell::new(inner),
            events: Events::default(),
            raised,
        })
    }

    /// Axis names, in order.
    #[getter]
    fn axes(&self) -> PyResult<Vec<String>> {
        self.read(|m| m.axes())
    }

    /// Tool names.
    #[getter]
    fn tools(&self) -> PyResult<Vec<String>> {
        self.read(|m| m.tools())
    }

    /// Move the named axes to absolute positions: `move_to(x=10, y=20, feed=50)`.
    /// `feed` is in units per second; without it the machine's drawing feed.
    #[pyo3(signature = (feed=None, **kwargs))]
    fn move_to(
        &self,
        py: Python<'_>,
        feed: Option<f64>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        let a = axes(kwargs)?;
        self.work(py, |m| m.move_to(&borrowed(&a), feed))
    }

    /// Move the named axes to absolute positions as fast as the limits allow.
    #[pyo3(signature = (**kwargs))]
    fn rapid_to(&self, py: Python<'_>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let a = axes(kwargs)?;
        self.work(py, |m| m.rapid_to(&borrowed(&a)))
    }

    /// Move the named axes by the given amounts: `jog(x=-5)`.
    #[pyo3(signature = (feed=None, **kwargs))]
    fn jog(
        &self,
        py: Python<'_>,
        feed: Option<f64>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        let a = axes(kwargs)?;
        self.work(py, |m| m.jog(&borrowed(&a), feed))
    }

    /// Set a tool output: pen 1 down / 0 up, laser or spindle power 0..1.
    fn set_tool(&self, py: Python<'_>, tool: &str, value: f32) -> PyResult<()> {
        self.work(py, |m| m.set_tool(tool, value))
    }

    /// Stand still for `seconds` after the motion queued before.
    fn dwell(&self, py: Python<'_>, seconds: f64) -> PyResult<()> {
        self.work(py, |m| m.dwell(seconds))
    }

    /// Block until everything queued has run and the machine is at rest,
    /// including motion that event callbacks queue meanwhile.
    fn wait(&self, py: Python<'_>) -> PyResult<()> {
        loop {
            self.work(py, |m| m.wait())?;
            if self.read(|m| m.is_idle())? {
                return Ok(());
            }
        }
    }

    /// Where the motors are now, by axis name.
    #[getter]
    fn position<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        dict(py, self.read(|m| m.position())?)
    }

    /// Where the machine will be after everything queued, by axis name.
    #[getter]
    fn target<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        dict(py, self.read(|m| m.target())?)
    }

    /// Simulated time, seconds.
    #[getter]
    fn time(&self) -> PyResult<f64> {
        self.read(|m| m.time())
    }

    /// Calls `callback(event)` for every event from now on: a dict with
    /// `kind` ("tool" or "idle"), `time` (s) and, for tools, `tool` and
    /// `value`. Callbacks run after the call that produced the event and may
    /// use the machine; an exception they raise is raised by that call.
    fn on_event(&self, callback: Py<PyAny>) -> PyResult<()> {
        if self.events.add(callback) {
            let recorder = self.events.recorder();
            self.inner
                .try_borrow_mut()
                .map_err(|_| busy())?
                .on_event(recorder);
        }
        Ok(())
    }

    /// The run report as a dict (duration, distances, steps, peaks, accuracy).
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&self.read(|m| m.report())?)
            .map_err(|e| MotetError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Write path.png, path.svg and report.json of everything executed so
    /// far into `directory`, which is made if missing (its parent must exist).
    fn save(&self, py: Python<'_>, directory: &str) -> PyResult<()> {
        self.work(py, |m| m.save(directory))
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Leaving a `with` block waits for the machine to finish, unless the
    /// block raised (Ctrl-C included): then the exception goes on at once and
    /// the queued motion stays queued.
    fn __exit__(
        &self,
        py: Python<'_>,
        exc_type: Option<Py<PyAny>>,
        _exc: Option<Py<PyAny>>,
        _tb: Option<Py<PyAny>>,
    ) -> PyResult<bool> {
        if exc_type.is_none() {
            self.wait(py)?;
        }
        Ok(false)
    }
}
