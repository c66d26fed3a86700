//! Ctrl-C during long calls. The machine works without the GIL; every few
//! milliseconds it asks this check, which takes the GIL for a moment and
//! runs Python's signal handlers. When one raises (Ctrl-C: KeyboardInterrupt)
//! the call stops and raises that exception.

use pyo3::prelude::*;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Time between two looks at pending signals: well below the 100 ms a
/// person notices. Taking the GIL from a busy Python thread can take its
/// switch interval (5 ms), so looking much more often would slow the
/// machine down whenever other threads run.
const EVERY: Duration = Duration::from_millis(20);

/// The exception a signal handler raised during a call, kept until the call
/// returns.
#[derive(Clone, Default)]
pub struct Raised(Arc<Mutex<Option<PyErr>>>);

impl Raised {
    pub fn take(&self) -> Option<PyErr> {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).take()
    }

    /// The check for `motet_api::Machine::on_interrupt`.
    pub fn check(&self) -> impl FnMut() -> bool + Send + 'static {
        let raised = self.clone();
        let mut last = Instant::now();
        move || {
            if last.elapsed() < EVERY {
                return false;
            }
            last = Instant::now();
            Python::attach(|py| match py.check_signals() {
                Ok(()) => false,
                Err(e) => {
                    *raised.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(e);
                    true
                }
            })
        }
    }
}
