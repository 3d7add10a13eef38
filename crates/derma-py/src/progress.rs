//! derma-core's progress as a Python callback: `callback(stage, done, total)` at each stage's
//! start and end and at most ten times a second between, called with the GIL taken again and
//! no lock held (a slow callback delays only the worker that calls it).

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
        let last = {
            let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
            close_stage(&self.callable, &mut s)
        };
        self.make([last]);
        let mut s = self.state.into_inner().unwrap_or_else(|p| p.into_inner());
        match s.raised.take() {
            Some(e) => Err(e),
            None => Ok(s.notes),
        }
    }
}

/// A call to make: the arguments, taken under the lock and made after it is released.
type Call = (String, u64, u64);

/// The call for the state's stage now, unless an earlier call raised.
fn due_call(callable: &Option<Py<PyAny>>, s: &mut State) -> Option<Call> {
    callable.as_ref()?;
    if s.raised.is_some() {
        return None;
    }
    s.last = Some(Instant::now());
    Some((s.stage.clone(), s.done, s.total))
}

/// Reports the current stage as done when it was not yet: the call to make.
fn close_stage(callable: &Option<Py<PyAny>>, s: &mut State) -> Option<Call> {
    if !s.stage.is_empty() && s.done < s.total {
        s.done = s.total;
        return due_call(callable, s);
    }
    None
}

impl Callback {
    /// Makes the calls (outside the lock); the first exception is kept for [`Callback::finish`].
    fn make(&self, calls: impl IntoIterator<Item = Option<Call>>) {
        let Some(c) = &self.callable else { return };
        for args in calls.into_iter().flatten() {
            if let Err(e) = Python::attach(|py| c.call1(py, args).map(drop)) {
                let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
                s.raised.get_or_insert(e);
                return;
            }
        }
    }
}

impl Progress for Callback {
    fn stage(&self, name: &str, total: u64, _unit: Unit) {
        let calls = {
            let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
            let closed = close_stage(&self.callable, &mut s);
            s.stage = name.to_string();
            s.done = 0;
            s.total = total;
            [closed, due_call(&self.callable, &mut s)]
        };
        self.make(calls);
    }

    fn advance(&self, steps: u64) {
        let call = {
            let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
            s.done += steps;
            let due = s.last.is_none_or(|t| t.elapsed() >= INTERVAL);
            if due || s.done == s.total {
                due_call(&self.callable, &mut s)
            } else {
                None
            }
        };
        self.make([call]);
    }

    fn note(&self, note: Note) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        s.notes.push(note.to_string());
    }
}
