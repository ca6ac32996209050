//! A renderer's state behind a lock: two Python threads sharing one renderer (a Dask worker's
//! threads, a notebook's background thread) take turns instead of failing, and `close()` frees
//! the device at once. The lock is awaited with the GIL released, so a thread rendering (which
//! re-takes the GIL briefly per frame to check for Ctrl-C) never deadlocks with one waiting.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::MutexExt;
use std::cell::RefCell;
use std::sync::{Mutex, PoisonError};

thread_local! {
    /// The locks this thread holds (by address): a call back into the same renderer from its
    /// own `progress` callback would wait for itself forever.
    static HELD: RefCell<Vec<usize>> = const { RefCell::new(Vec::new()) };
}

/// `T`, or nothing once closed.
pub struct Locked<T> {
    state: Mutex<Option<T>>,
    what: &'static str,
}

/// Marks the lock as held by this thread while it lives (also when `f` unwinds).
struct Held(usize);

impl Drop for Held {
    fn drop(&mut self) {
        HELD.with(|h| h.borrow_mut().retain(|a| *a != self.0));
    }
}

impl<T: Send> Locked<T> {
    /// Open, holding `value`; `what` names the class in messages.
    pub fn new(value: T, what: &'static str) -> Self {
        Self { state: Mutex::new(Some(value)), what }
    }

    fn addr(&self) -> usize {
        self as *const Self as usize
    }

    fn not_reentered(&self) -> PyResult<()> {
        let addr = self.addr();
        if HELD.with(|h| h.borrow().contains(&addr)) {
            return Err(PyRuntimeError::new_err(format!(
                "this {} is busy in a call that is running its progress callback; call it after that call returns",
                self.what
            )));
        }
        Ok(())
    }

    /// Runs `f` on the state, after any other thread's call on it has finished.
    pub fn with<R>(&self, py: Python<'_>, f: impl FnOnce(&mut T) -> PyResult<R>) -> PyResult<R> {
        self.not_reentered()?;
        let addr = self.addr();
        // A panic is caught inside (errors::guarded) before it could poison the lock; if one
        // did, the state is still whole: every method leaves it consistent between frames.
        let mut guard = self.state.lock_py_attached(py).unwrap_or_else(PoisonError::into_inner);
        let state = guard.as_mut().ok_or_else(|| {
            PyValueError::new_err(format!(
                "this {} is closed (close() or the end of its `with` block freed its device)",
                self.what
            ))
        })?;
        HELD.with(|h| h.borrow_mut().push(addr));
        let _held = Held(addr);
        f(state)
    }

    /// Frees the state now (with the GIL released: tearing a device down waits for it);
    /// closing twice is harmless.
    pub fn close(&self, py: Python<'_>) -> PyResult<()> {
        self.not_reentered()?;
        let state = self.state.lock_py_attached(py).unwrap_or_else(PoisonError::into_inner).take();
        py.detach(move || drop(state));
        Ok(())
    }

    /// Whether `close()` has run.
    pub fn is_closed(&self, py: Python<'_>) -> bool {
        self.state.lock_py_attached(py).unwrap_or_else(PoisonError::into_inner).is_none()
    }
}
