//! derma-core's progress as a Python callback: `callback(stage, done, total)` at each stage's
//! start and end and at most ten times a second between, called with the GIL taken again.

use derma_core::progress::{Note, Progress, Unit};
use pyo3::prelude::*;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The least time between two calls within a stage.
const INTERVAL: Duration = Duration::from_millis(100);

struct State {
    stage: String,
    done: u64,
    total: u64,
    last: Option<Instant>,
    /// The first exception the callback raised: the call returns it when the work is done.
    raised: Option<PyErr>,
    notes: Vec<String>,
}

/// A [`Progress`] that calls a Python callable (or nothing) and keeps the notes.
pub(crate) struct Callback {
    callable: Option<Py<PyAny>>,
    state: Mutex<State>,
}

impl Callback {
    pub(crate) fn new(callable: Option<Py<PyAny>>) -> Self {
        Self {
            callable,
            state: Mutex::new(State {
                stage: String::new(),
                done: 0,
                total: 0,
                last: None,
                raised: None,
                notes: Vec::new(),
            }),
        }
    }

    /// Ends the last stage (a call with done = total) and gives the notes, or the callback's
    /// first exception.
    pub(crate) fn finish(self) -> PyResult<Vec<String>> {
        let mut s = self.state.into_inner().unwrap_or_else(|p| p.into_inner());
        close_stage(&self.callable, &mut s);
        match s.raised.take() {
            Some(e) => Err(e),
            None => Ok(s.notes),
        }
    }
}

/// Calls the callback with the state's stage, unless an earlier call raised.
fn call(callable: &Option<Py<PyAny>>, s: &mut State) {
    let Some(c) = callable else { return };
    if s.raised.is_some() {
        return;
    }
    s.last = Some(Instant::now());
    let args = (s.stage.clone(), s.done, s.total);
    if let Err(e) = Python::attach(|py| c.call1(py, args).map(drop)) {
        s.raised = Some(e);
    }
}

/// Reports the current stage as done, when it was not yet.
fn close_stage(callable: &Option<Py<PyAny>>, s: &mut State) {
    if !s.stage.is_empty() && s.done < s.total {
        s.done = s.total;
        call(callable, s);
    }
}

impl Progress for Callback {
    fn stage(&self, name: &str, total: u64, _unit: Unit) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        close_stage(&self.callable, &mut s);
        s.stage = name.to_string();
        s.done = 0;
        s.total = total;
        call(&self.callable, &mut s);
    }

    fn advance(&self, steps: u64) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        s.done += steps;
        let due = s.last.is_none_or(|t| t.elapsed() >= INTERVAL);
        if due || s.done == s.total {
            call(&self.callable, &mut s);
        }
    }

    fn note(&self, note: Note) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        s.notes.push(note.to_string());
    }
}
