//! How a run hears from Python while the core works: the progress report of one trajectory
//! (Ctrl-C and the user's callback, between chunks of steps) and the Ctrl-C watch of a batch.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::RecvTimeoutError;

use pyo3::prelude::*;

/// The report of a one-trajectory run: between chunks of steps it re-attaches to the
/// interpreter, checks for Ctrl-C and calls `progress(step)`. Only an explicit False from the
/// callback stops the run; an exception it raises (or Ctrl-C) stops it and is kept in `pending`.
pub fn reporter<'a>(
    progress: &'a Option<Py<PyAny>>,
    pending: &'a mut Option<PyErr>,
) -> impl FnMut(u64) -> bool + 'a {
    move |done: u64| {
        Python::attach(|py| {
            if let Err(e) = py.check_signals() {
                *pending = Some(e);
                return false;
            }
            match progress {
                None => true,
                Some(cb) => match cb.call1(py, (done,)) {
                    Ok(r) => r.extract::<bool>(py).unwrap_or(true),
                    Err(e) => {
                        *pending = Some(e);
                        false
                    }
                },
            }
        })
    }
}

/// Runs `work` on a scoped thread, detached from the interpreter, while this thread looks for
/// Ctrl-C every 20 ms and sets `stop` when it comes. Returns the work's result (Err if it
/// panicked) and whether Ctrl-C came. The worker says when it is done, so a short batch
/// returns at once.
pub fn watching_ctrl_c<T: Send>(
    py: Python<'_>,
    stop: &AtomicBool,
    work: impl FnOnce() -> T + Send,
) -> (std::thread::Result<T>, bool) {
    let mut interrupted = false;
    let out = py.detach(|| {
        std::thread::scope(|scope| {
            let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
            let worker = scope.spawn(move || {
                let out = work();
                let _ = done_tx.send(());
                out
            });
            let tick = std::time::Duration::from_millis(20);
            while let Err(RecvTimeoutError::Timeout) = done_rx.recv_timeout(tick) {
                if !interrupted && Python::attach(|py| py.check_signals().is_err()) {
                    interrupted = true;
                    stop.store(true, Ordering::Relaxed);
                }
            }
            worker.join()
        })
    });
    (out, interrupted)
}
