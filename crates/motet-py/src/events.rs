//! Event delivery to Python callbacks.
//!
//! The machine only records events while it works; they are handed to the
//! callbacks after the call that produced them, once the machine is no longer
//! borrowed. So a callback may use the machine freely (read its position,
//! queue moves, even wait), and an exception it raises propagates out of that
//! call like any other.

use motet_api::Event;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

/// Events not yet delivered and the callbacks they go to.
#[derive(Default)]
pub struct Events {
    /// Filled by the machine while it works (possibly without the GIL).
    queue: Arc<Mutex<VecDeque<Event>>>,
    callbacks: RefCell<Vec<Py<PyAny>>>,
    /// Which callback the front event goes to next: when a callback raises,
    /// the others still get the event at the next delivery, and none gets
    /// it twice.
    next: Cell<usize>,
}

impl Events {
    /// Adds a callback; true for the first, when the machine must start
    /// recording events into [`Events::recorder`].
    pub fn add(&self, callback: Py<PyAny>) -> bool {
        let mut c = self.callbacks.borrow_mut();
        c.push(callback);
        c.len() == 1
    }

    /// What the machine calls for each event.
    pub fn recorder(&self) -> impl FnMut(&Event) + Send + 'static {
        let queue = self.queue.clone();
        move |e| lock(&queue).push_back(e.clone())
    }

    /// Delivers every recorded event to every callback, in order. Stops at
    /// the first callback that raises, with its exception; the rest stay
    /// for the next delivery. Callbacks may deliver re-entrantly (by calling
    /// the machine); the order stays the same.
    pub fn deliver(&self, py: Python<'_>) -> PyResult<()> {
        while let Some((event, callback)) = self.next_call(py) {
            callback.call1(py, (to_dict(py, &event)?,))?;
        }
        Ok(())
    }

    fn next_call(&self, py: Python<'_>) -> Option<(Event, Py<PyAny>)> {
        let mut queue = lock(&self.queue);
        let callbacks = self.callbacks.borrow();
        loop {
            let event = queue.front()?;
            let k = self.next.get();
            if let Some(c) = callbacks.get(k) {
                self.next.set(k + 1);
                return Some((event.clone(), c.clone_ref(py)));
            }
            queue.pop_front();
            self.next.set(0);
        }
    }
}

fn lock(q: &Mutex<VecDeque<Event>>) -> std::sync::MutexGuard<'_, VecDeque<Event>> {
    // Pushing an event cannot panic halfway; a poisoned queue is still whole.
    q.lock().unwrap_or_else(|e| e.into_inner())
}

/// The event as Python sees it: `kind` ("tool" or "idle"), `time` (s) and,
/// for tools, `tool` and `value`.
fn to_dict<'py>(py: Python<'py>, e: &Event) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
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
    Ok(d)
}
