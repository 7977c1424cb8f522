//! Planning off the interpreter: the plan runs on a worker thread while the calling thread,
//! detached from Python, waits for it and every 50 ms re-attaches briefly to check for signals
//! (Ctrl-C). A signal (or an exception raised by the progress callback) sets the planner's
//! stop flag (`planner::plan_with_stop`), which the planner reads before every cone program;
//! the plan then ends within about one program's time and the exception is raised.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use planner::{IterationRecord, Mission, Observer, PlanOptions, PlanResult};
use pyo3::prelude::*;

use crate::errors::{panic_error, plan_error};
use crate::json;

/// How often the waiting thread checks for signals.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Hands each iteration to a Python callable (as a dict) and stops the plan when it raises.
struct Progress<'a> {
    callback: Option<Py<PyAny>>,
    stop: &'a AtomicBool,
    error: Option<PyErr>,
}

impl Progress<'_> {
    fn call(&mut self, arg: impl FnOnce(Python<'_>) -> PyResult<Bound<'_, PyAny>>) {
        let Some(callback) = &self.callback else {
            return;
        };
        if self.error.is_some() {
            return;
        }
        let outcome = Python::attach(|py| {
            let value = arg(py)?;
            callback.call1(py, (value,)).map(drop)
        });
        if let Err(e) = outcome {
            self.error = Some(e);
            self.stop.store(true, Ordering::Relaxed);
        }
    }
}

impl Observer for Progress<'_> {
    fn on_iteration(&mut self, record: &IterationRecord) {
        self.call(|py| json::to_py(py, record));
    }
    fn on_phase(&mut self, phase: &str) {
        self.call(|py| {
            let d = pyo3::types::PyDict::new(py);
            d.set_item("phase", phase)?;
            Ok(d.into_any())
        });
    }
}

/// Plans `mission` with the interpreter released; Ctrl-C raises `KeyboardInterrupt`, an
/// exception in `progress` is re-raised, and a planner error becomes its Python exception.
pub fn plan_detached(
    py: Python<'_>,
    mission: &Mission,
    options: &PlanOptions,
    progress: Option<Py<PyAny>>,
) -> PyResult<PlanResult> {
    let stop = AtomicBool::new(false);
    let (result, interrupt, callback_error) = py.detach(|| {
        std::thread::scope(|scope| {
            let (done_tx, done_rx) = mpsc::channel::<()>();
            let stop = &stop;
            let worker = scope.spawn(move || {
                let mut observer = Progress {
                    callback: progress,
                    stop,
                    error: None,
                };
                let result = planner::plan_with_stop(mission, options, &mut observer, stop);
                let _ = done_tx.send(());
                (result, observer.error)
            });
            let mut interrupt = None;
            while let Err(mpsc::RecvTimeoutError::Timeout) = done_rx.recv_timeout(SIGNAL_POLL) {
                if interrupt.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        stop.store(true, Ordering::Relaxed);
                        interrupt = Some(e);
                    }
                }
            }
            match worker.join() {
                Ok((result, callback_error)) => (Ok(result), interrupt, callback_error),
                Err(payload) => (Err(payload), interrupt, None),
            }
        })
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    if let Some(e) = callback_error {
        return Err(e);
    }
    match result {
        Ok(Ok(r)) => Ok(r),
        Ok(Err(e)) => Err(plan_error(py, &e)),
        Err(payload) => Err(panic_error("the planner", payload.as_ref())),
    }
}
