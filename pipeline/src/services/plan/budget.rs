//! Planning one request within the service's work budget (`--plan-budget-s`): in a worker
//! process ([`super::worker`]) when the service has a worker executable, else in a thread.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bridge::ZenohNode;
use planner::driver::{IterationRecord, Observer};
use planner::Mission;

use super::{plan_request_stoppable, worker, ServeArgs, ServiceError, StatusBoard};
use crate::protocol::{mission_id, Plan, PlanRequest, ServiceState};

/// Planner progress as status lines (`<phase> iteration <k>: true energy <E> J`), at most one
/// every 0.5 s, handed to `send`: the service loop's channel ([`plan_in_thread`]) or the
/// worker's pipe ([`worker`]).
pub(super) struct ProgressLines<F: FnMut(String)> {
    send: F,
    phase: String,
    last: Instant,
}

impl<F: FnMut(String)> ProgressLines<F> {
    /// Progress lines handed to `send`.
    pub(super) fn new(send: F) -> Self {
        Self {
            send,
            phase: String::new(),
            last: Instant::now(),
        }
    }
}

impl<F: FnMut(String)> Observer for ProgressLines<F> {
    fn on_phase(&mut self, phase: &str) {
        self.phase = phase.to_string();
    }
    fn on_iteration(&mut self, r: &IterationRecord) {
        if self.last.elapsed() < Duration::from_millis(500) {
            return;
        }
        self.last = Instant::now();
        (self.send)(format!(
            "{} iteration {}: true energy {:.1} J",
            self.phase, r.iteration, r.true_energy_j
        ));
    }
}

/// Plans `req` within the work budget (`--plan-budget-s`, from now): in a worker process when
/// the service has a worker executable, else in a thread.
pub(super) fn plan_within_budget(
    node: &ZenohNode,
    args: &ServeArgs,
    board: &StatusBoard,
    req: &PlanRequest,
    stop: &AtomicBool,
) -> Result<Plan, ServiceError> {
    let budget = worker::Budget {
        seconds: args.plan_budget_s.as_secs_f64(),
        deadline: Instant::now() + args.plan_budget_s.duration(),
    };
    let limit = args.plan_time_limit_s.as_secs_f64().min(budget.seconds);
    match &args.worker_exe {
        Some(exe) => {
            worker::plan_in_worker(exe, node, board, req, &args.instance, limit, &budget, stop)
        }
        None => plan_in_thread(node, board, req, &args.instance, limit, &budget, stop),
    }
}

/// Plans in a worker thread so that a stop signal is seen while planning (the thread is left
/// behind then: the process is exiting), publishing progress as `planning` status. At the
/// budget's end the request is refused ([`ServiceError::OverBudget`]) and the planning asked
/// to stop; it stops at the planner's next check (before its next cone program).
fn plan_in_thread(
    node: &ZenohNode,
    board: &StatusBoard,
    req: &PlanRequest,
    instance: &str,
    time_limit_s: f64,
    budget: &worker::Budget,
    stop: &AtomicBool,
) -> Result<Plan, ServiceError> {
    let provisional = Mission::from_file_struct(&req.mission)
        .map(|m| mission_id(&m.to_file_struct(), &req.options))
        .unwrap_or_default();
    let (progress_tx, progress_rx) = std::sync::mpsc::channel::<String>();
    let (done_tx, done_rx) = std::sync::mpsc::channel();
    let (req, instance) = (req.clone(), instance.to_string());
    let halt = Arc::new(AtomicBool::new(false));
    let halted = halt.clone();
    let mission = Mission::from_file_struct(&req.mission)
        .map(|m| m.name().to_string())
        .unwrap_or_default();
    std::thread::Builder::new()
        .name("plan".into())
        .spawn(move || {
            let mut obs = ProgressLines::new(|line| {
                let _ = progress_tx.send(line);
            });
            let limit = Some(time_limit_s);
            let r = plan_request_stoppable(&req, &instance, limit, &mut obs, Some(&halted));
            let _ = done_tx.send(r);
        })
        .map_err(|e| ServiceError::Internal(format!("starting the planning thread: {e}")))?;
    let mut status = board.status(provisional, ServiceState::Planning);
    status.message = "planning".into();
    board.publish(node, &status);
    loop {
        if stop.load(Ordering::Relaxed) {
            halt.store(true, Ordering::Relaxed);
            return Err(ServiceError::Internal("stopped while planning".into()));
        }
        if Instant::now() >= budget.deadline {
            halt.store(true, Ordering::Relaxed);
            return Err(ServiceError::OverBudget {
                mission,
                budget_s: budget.seconds,
            });
        }
        while let Ok(line) = progress_rx.try_recv() {
            status.message = line;
            status.uptime_s = board.uptime_s();
            board.publish(node, &status);
        }
        match done_rx.recv_timeout(Duration::from_millis(50)) {
            Ok(result) => return result,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(ServiceError::Internal(
                    "the planning thread panicked".into(),
                ))
            }
        }
    }
}
