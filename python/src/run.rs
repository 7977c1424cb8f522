//! Planning off the interpreter: the plan runs on a worker thread while the calling thread,
//! detached from Python, waits for it and every 50 ms re-attaches briefly to check for signals
//! (Ctrl-C). A signal (or an exception raised by the progress callback) sets the planner's
//! stop flag (`planner::plan_with_stop`), which the planner reads before every cone program;
//! the plan then ends within about one program's time and the exception is raised.
//!
//! Workers are kept for the next plan ([`workers`]): a fresh thread per plan costs about 1 ms
//! more (its new stack and cold allocator arena), which would be most of the calling overhead.

use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use planner::{IterationRecord, Mission, Observer, PlanError, PlanOptions, PlanResult};
use pyo3::prelude::*;

use crate::errors::{panic_error, plan_error};
use crate::json;
use crate::workers;

/// How often the waiting thread checks for signals.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Hands each iteration to a Python callable (as a dict) and stops the plan when it raises.
struct Progress {
    callback: Option<Py<PyAny>>,
    stop: Arc<AtomicBool>,
    error: Option<PyErr>,
}

impl Progress {
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

impl Observer for Progress {
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

/// What a worker sends back: the plan (or the panic's payload) and the callback's exception.
type Outcome = (
    std::thread::Result<Result<PlanResult, PlanError>>,
    Option<PyErr>,
);

/// Plans `mission` with the interpreter released; Ctrl-C raises `KeyboardInterrupt`, an
/// exception in `progress` is re-raised, and a planner error becomes its Python exception.
pub fn plan_detached(
    py: Python<'_>,
    mission: &Mission,
    options: &PlanOptions,
    progress: Option<Py<PyAny>>,
) -> PyResult<PlanResult> {
    let stop = Arc::new(AtomicBool::new(false));
    let (done_tx, done_rx) = mpsc::channel::<Outcome>();
    let (mission, options, worker_stop) = (mission.clone(), options.clone(), stop.clone());
    let job = Box::new(move || {
        let mut observer = Progress {
            callback: progress,
            stop: worker_stop,
            error: None,
        };
        let stop = observer.stop.clone();
        let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
            planner::plan_with_stop(&mission, &options, &mut observer, &stop)
        }));
        // the caller may be gone only if it panicked itself; nothing is left to tell then
        let _ = done_tx.send((result, observer.error.take()));
    });
    workers::run(job).map_err(|e| {
        crate::errors::PlanError::new_err(format!("cannot start a planning thread: {e}"))
    })?;
    let waiting_stop = stop;
    let (outcome, interrupt) = py.detach(move || {
        let mut interrupt = None;
        loop {
            match done_rx.recv_timeout(SIGNAL_POLL) {
                Ok(outcome) => return (Some(outcome), interrupt),
                Err(mpsc::RecvTimeoutError::Disconnected) => return (None, interrupt),
                Err(mpsc::RecvTimeoutError::Timeout) => {}
            }
            if interrupt.is_none() {
                if let Err(e) = Python::attach(|py| py.check_signals()) {
                    waiting_stop.store(true, Ordering::Relaxed);
                    interrupt = Some(e);
                }
            }
        }
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    let Some((result, callback_error)) = outcome else {
        return Err(crate::errors::PlanError::new_err(
            "internal error: the planning thread ended without a result",
        ));
    };
    if let Some(e) = callback_error {
        return Err(e);
    }
    match result {
        Ok(Ok(r)) => Ok(r),
        Ok(Err(e)) => Err(plan_error(py, &e)),
        Err(payload) => Err(panic_error("the planner", payload.as_ref())),
    }
}
