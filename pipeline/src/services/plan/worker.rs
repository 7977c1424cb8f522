//! Planning one request in a child process, so that the service can end it at its work budget
//! (`--plan-budget-s`) whatever the planner is doing.
//!
//! The planner reads its stop flag and time limit only between cone programs, and one cone
//! program of a long mission takes minutes; a thread cannot be ended from outside. The service
//! therefore starts its own executable as `plan-worker` for every request it plans
//! ([`plan_in_worker`]), writes the request to the worker's standard input and reads its
//! answer from its standard output, and kills it at the budget. On the pipes, every message is
//! an envelope ([`bridge::envelope`], bincode): the request ([`PlanRequest`]) in; progress
//! lines ([`WorkerProgress`]), then the plan ([`Plan`]) or the refusal ([`Refusal`]) out. The
//! worker's log goes to its standard error, which is the service's.
//!
//! A worker whose service is gone exits: at the end of its standard input, and at the latest
//! after `--exit-after-s`.

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use bridge::envelope::{self, DecodeLimits, Header, Message, Meta, HEADER_LEN};
use bridge::{Refusal, ZenohNode};
use serde::{Deserialize, Serialize};

use super::{plan_request_within, ServiceError, StatusBoard};
use crate::protocol::{Plan, PlanRequest, ServiceState, MAX_PLAN_BYTES};

/// The hidden subcommand of `cellsar-planner` and `cellsar` that plans one request.
pub const WORKER_COMMAND: &str = "plan-worker";

/// Largest plan request the worker reads (the queryable's own bound on a request's body).
const MAX_REQUEST_BYTES: usize = envelope::DEFAULT_MAX_MESSAGE_BYTES;

/// How long a worker whose answer came may take to exit before it is killed.
const EXIT_GRACE: Duration = Duration::from_secs(5);

/// Flags of the `plan-worker` subcommand (given by the service, not by hand).
#[derive(clap::Args, Debug, Clone)]
pub struct WorkerArgs {
    /// The planner's time limit, s (`--plan-time-limit-s`).
    #[arg(long)]
    pub time_limit_s: f64,
    /// Exit after this many seconds whatever happens (the budget and a margin), s.
    #[arg(long)]
    pub exit_after_s: f64,
    /// The service's instance name (the plan's `planner`).
    #[arg(long)]
    pub instance: String,
}

/// A progress line of the worker (on its pipe only, never on the network).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorkerProgress {
    /// The line, as the `planning` status shows it.
    pub line: String,
}

impl Message for WorkerProgress {
    const KIND: u16 = 0x01f0;
    const NAME: &'static str = "planner.worker_progress";
    const SCHEMA_VERSION: u16 = 1;
}

/// Reads one envelope from `r`: `None` at the end of the stream; the body bounded by `limit`
/// before it is allocated.
fn read_envelope(r: &mut impl Read, limit: usize) -> Result<Option<Vec<u8>>, String> {
    let mut head = [0u8; HEADER_LEN];
    match r.read_exact(&mut head) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Ok(None),
        Err(e) => return Err(format!("reading a header: {e}")),
    }
    let header = Header::parse(&head).map_err(|e| e.to_string())?;
    let len = usize::try_from(header.body_len)
        .ok()
        .filter(|n| *n <= limit)
        .ok_or_else(|| format!("a body of {} bytes, more than {limit}", header.body_len))?;
    let mut bytes = head.to_vec();
    bytes.resize(HEADER_LEN + len, 0);
    r.read_exact(&mut bytes[HEADER_LEN..])
        .map_err(|e| format!("reading a body of {len} bytes: {e}"))?;
    Ok(Some(bytes))
}

fn write_message<M: Message>(out: &Mutex<std::io::Stdout>, m: &M) -> Result<(), ServiceError> {
    let bytes = envelope::encode(m, Meta::default()).map_err(|error| ServiceError::Codec {
        what: M::NAME.into(),
        error,
    })?;
    let mut out = out
        .lock()
        .map_err(|_| ServiceError::Internal("the worker's output lock is poisoned".into()))?;
    out.write_all(&bytes)
        .and_then(|()| out.flush())
        .map_err(|e| ServiceError::Internal(format!("writing to the service: {e}")))
}

/// The worker: reads one plan request from standard input, plans it, writes the plan or the
/// refusal to standard output. It exits at the end of its input (its service gone) and after
/// `--exit-after-s` at the latest.
pub fn run_worker(args: &WorkerArgs) -> Result<(), ServiceError> {
    let exit_after = Duration::try_from_secs_f64(args.exit_after_s)
        .map_err(|e| ServiceError::BadRequest(format!("--exit-after-s: {e}")))?;
    std::thread::spawn(move || {
        std::thread::sleep(exit_after);
        tracing::error!("plan worker: past its time; exiting");
        std::process::exit(1);
    });
    let mut input = std::io::stdin().lock();
    let bytes = read_envelope(&mut input, MAX_REQUEST_BYTES)
        .map_err(|e| ServiceError::Internal(format!("plan worker: {e}")))?
        .ok_or_else(|| ServiceError::Internal("plan worker: no request".into()))?;
    let limits = DecodeLimits {
        max_body_bytes: MAX_REQUEST_BYTES,
        verify_crc: true,
    };
    let req: PlanRequest = envelope::decode(&bytes, &limits)
        .map_err(|error| ServiceError::Codec {
            what: "the plan request".into(),
            error,
        })?
        .message;
    drop(input);
    std::thread::spawn(|| {
        // the service holds the pipe open until the answer: its end is the service's
        let mut rest = Vec::new();
        let _ = std::io::stdin().lock().read_to_end(&mut rest);
        std::process::exit(1);
    });
    let out = Mutex::new(std::io::stdout());
    // progress to the service, on the pipe
    let mut obs = super::budget::ProgressLines::new(|line| {
        let _ = write_message(&out, &WorkerProgress { line });
    });
    match plan_request_within(&req, &args.instance, Some(args.time_limit_s), &mut obs) {
        Ok(plan) => write_message(&out, &plan),
        Err(e) => write_message(&out, &e.refusal()),
    }
}

/// What the reader thread hands over from the worker's output.
enum FromWorker {
    Progress(String),
    Answer(Box<Result<Plan, ServiceError>>),
}

/// Decodes one message of the worker's output.
fn decode_answer(bytes: &[u8]) -> Result<FromWorker, String> {
    let header = Header::parse(bytes).map_err(|e| e.to_string())?;
    let limits = DecodeLimits {
        max_body_bytes: MAX_PLAN_BYTES,
        verify_crc: true,
    };
    let err = |e: envelope::CodecError| e.to_string();
    Ok(match header.kind {
        WorkerProgress::KIND => FromWorker::Progress(
            envelope::decode::<WorkerProgress>(bytes, &limits)
                .map_err(err)?
                .message
                .line,
        ),
        Plan::KIND => {
            let plan = envelope::decode::<Plan>(bytes, &limits)
                .map_err(err)?
                .message;
            FromWorker::Answer(Box::new(Ok(plan)))
        }
        Refusal::KIND => {
            let refusal = envelope::decode::<Refusal>(bytes, &limits)
                .map_err(err)?
                .message;
            FromWorker::Answer(Box::new(Err(ServiceError::Refused(refusal))))
        }
        other => return Err(format!("a message of unknown kind {other:#06x}")),
    })
}

/// The budget and clock of one request.
pub(super) struct Budget {
    /// The budget, s.
    pub seconds: f64,
    /// When it ends.
    pub deadline: Instant,
}

/// Plans `req` in a worker process started from `exe`, publishing its progress as `planning`
/// status; at the budget's end the worker is killed and the request refused with
/// [`ServiceError::OverBudget`], at a stop with [`ServiceError::Internal`].
#[allow(clippy::too_many_arguments)]
pub(super) fn plan_in_worker(
    exe: &Path,
    node: &ZenohNode,
    board: &StatusBoard,
    req: &PlanRequest,
    instance: &str,
    time_limit_s: f64,
    budget: &Budget,
    stop: &AtomicBool,
) -> Result<Plan, ServiceError> {
    let mission = planner::Mission::from_file_struct(&req.mission)
        .map(|m| m.name().to_string())
        .unwrap_or_default();
    let bytes = envelope::encode(req, Meta::default()).map_err(|error| ServiceError::Codec {
        what: "the plan request".into(),
        error,
    })?;
    let mut child = Command::new(exe)
        .arg(WORKER_COMMAND)
        .arg("--time-limit-s")
        .arg(time_limit_s.to_string())
        .arg("--exit-after-s")
        .arg((budget.seconds + EXIT_GRACE.as_secs_f64()).to_string())
        .arg("--instance")
        .arg(instance)
        // the service's own parent watches it; the worker's is the service
        .env_remove(crate::supervise::PARENT_ENV)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| {
            ServiceError::Internal(format!("starting the plan worker {}: {e}", exe.display()))
        })?;
    let result = talk_to(&mut child, bytes, node, board, req, &mission, budget, stop);
    end(
        &mut child,
        matches!(result, Ok(_) | Err(ServiceError::Refused(_))),
    );
    result
}

/// Hands `bytes` to the worker and waits for its answer (see [`plan_in_worker`]).
#[allow(clippy::too_many_arguments)]
fn talk_to(
    child: &mut Child,
    bytes: Vec<u8>,
    node: &ZenohNode,
    board: &StatusBoard,
    req: &PlanRequest,
    mission: &str,
    budget: &Budget,
    stop: &AtomicBool,
) -> Result<Plan, ServiceError> {
    let (Some(mut stdin), Some(mut stdout)) = (child.stdin.take(), child.stdout.take()) else {
        return Err(ServiceError::Internal(
            "the plan worker has no pipes".into(),
        ));
    };
    // the request is written, then the pipe held open until this request ends (its end tells
    // the worker that the service is gone)
    let (done_tx, done_rx) = mpsc::channel::<()>();
    std::thread::Builder::new()
        .name("plan-worker-in".into())
        .spawn(move || {
            if stdin.write_all(&bytes).and_then(|()| stdin.flush()).is_ok() {
                let _ = done_rx.recv();
            }
        })
        .map_err(|e| ServiceError::Internal(format!("starting the worker's writer: {e}")))?;
    let (tx, rx) = mpsc::channel::<Result<FromWorker, String>>();
    std::thread::Builder::new()
        .name("plan-worker-out".into())
        .spawn(move || loop {
            match read_envelope(&mut stdout, MAX_PLAN_BYTES) {
                Ok(Some(b)) => {
                    if tx.send(decode_answer(&b)).is_err() {
                        return;
                    }
                }
                Ok(None) => return,
                Err(e) => {
                    let _ = tx.send(Err(e));
                    return;
                }
            }
        })
        .map_err(|e| ServiceError::Internal(format!("starting the worker's reader: {e}")))?;
    let provisional = planner::Mission::from_file_struct(&req.mission)
        .map(|m| crate::protocol::mission_id(&m.to_file_struct(), &req.options))
        .unwrap_or_default();
    let mut status = board.status(provisional, ServiceState::Planning);
    status.message = "planning".into();
    board.publish(node, &status);
    let answer = loop {
        if stop.load(Ordering::Relaxed) {
            break Err(ServiceError::Internal("stopped while planning".into()));
        }
        let left = budget.deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            break Err(ServiceError::OverBudget {
                mission: mission.to_string(),
                budget_s: budget.seconds,
            });
        }
        match rx.recv_timeout(left.min(Duration::from_millis(50))) {
            Ok(Ok(FromWorker::Progress(line))) => {
                status.message = line;
                status.uptime_s = board.uptime_s();
                board.publish(node, &status);
            }
            Ok(Ok(FromWorker::Answer(a))) => break *a,
            Ok(Err(e)) => {
                break Err(ServiceError::Internal(format!(
                    "the plan worker's answer: {e}"
                )))
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                let status = child.try_wait().ok().flatten();
                break Err(ServiceError::Internal(format!(
                    "the plan worker ended without an answer ({})",
                    status.map_or("still running".into(), |s| s.to_string())
                )));
            }
        }
    };
    drop(done_tx);
    answer
}

/// Reaps the worker: one that answered is given [`EXIT_GRACE`] to exit, any other is killed.
fn end(child: &mut Child, answered: bool) {
    if answered {
        let until = Instant::now() + EXIT_GRACE;
        while Instant::now() < until {
            if let Ok(Some(_)) = child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    if let Err(e) = child.kill() {
        tracing::debug!(error = %e, "killing the plan worker");
    }
    let _ = child.wait();
}

/// The executable that runs plan workers: this process's own (whose `plan-worker` subcommand
/// [`run_worker`] is).
pub fn own_executable() -> Option<std::path::PathBuf> {
    std::env::current_exe().ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use bridge::RefusalKind;

    /// What comes over the worker's pipe is bounded before it is allocated: a header that
    /// announces a body beyond the limit is refused by its size; a stream that ends between
    /// messages is the end, one that ends inside a body an error.
    #[test]
    fn the_workers_pipe_is_read_within_its_bounds() {
        let progress = WorkerProgress {
            line: "exact iteration 3".into(),
        };
        let bytes = envelope::encode(&progress, Meta::default()).unwrap();
        let mut two = bytes.clone();
        two.extend_from_slice(&bytes);
        let mut r = two.as_slice();
        for _ in 0..2 {
            let one = read_envelope(&mut r, 1 << 10).unwrap().unwrap();
            match decode_answer(&one).unwrap() {
                FromWorker::Progress(line) => assert_eq!(line, "exact iteration 3"),
                FromWorker::Answer(_) => panic!("not an answer"),
            }
        }
        assert!(read_envelope(&mut r, 1 << 10).unwrap().is_none());
        let mut huge = bytes.clone();
        huge[40..48].copy_from_slice(&(u64::MAX / 2).to_le_bytes());
        let e = read_envelope(&mut huge.as_slice(), MAX_PLAN_BYTES).unwrap_err();
        assert!(e.contains("more than 67108864"), "{e}");
        let cut = &bytes[..bytes.len() - 1];
        assert!(read_envelope(&mut &cut[..], 1 << 10).is_err());
    }

    /// A worker's refusal is answered as it is (kind and message); a request over the budget
    /// is refused `internal`, naming the budget and its flag.
    #[test]
    fn refusals_keep_their_kind_and_the_budget_is_named() {
        let r = Refusal::new(RefusalKind::Infeasible, "landmark 3 out of reach");
        let bytes = envelope::encode(&r, Meta::default()).unwrap();
        let FromWorker::Answer(answer) = decode_answer(&bytes).unwrap() else {
            panic!("not an answer");
        };
        let Err(e) = *answer else {
            panic!("not a refusal");
        };
        assert_eq!(e.refusal(), r);
        assert_eq!(e.to_string(), "landmark 3 out of reach");
        let e = ServiceError::OverBudget {
            mission: "worst".into(),
            budget_s: 20.0,
        };
        let r = e.refusal();
        assert_eq!(r.kind, RefusalKind::Internal);
        assert!(
            r.message.contains("\"worst\"")
                && r.message.contains("work budget of 20 s (--plan-budget-s)"),
            "{r:?}"
        );
    }

    /// A planner error is answered through the worker as the service answers it in its own
    /// process: the worker writes [`ServiceError::refusal`] and the service answers what it
    /// reads, so every kind (a mission proven impossible `infeasible`, a plan not found
    /// `not_found`, a start that does not fit `bad_request`, a time limit `internal`) and
    /// message comes through unchanged.
    #[test]
    fn planner_errors_are_refused_as_in_process() {
        use planner::driver::{NotFound, PlanError};
        let plan = |error| ServiceError::Plan {
            mission: "corner".into(),
            error,
        };
        let cases = [
            (
                plan(PlanError::Infeasible(planner::init::Infeasibility {
                    slot: 3,
                    t_s: 3.0,
                    reason: "landmark 2 out of reach".into(),
                })),
                RefusalKind::Infeasible,
            ),
            (
                plan(PlanError::NotFound(Box::new(NotFound {
                    slot: 1,
                    t_s: 1.0,
                    reason: "sensing violated by 4.0 m".into(),
                    starts: 2,
                    best: None,
                }))),
                RefusalKind::NotFound,
            ),
            (
                plan(PlanError::InvalidInit("12 rows, 13 slots".into())),
                RefusalKind::BadRequest,
            ),
            (
                plan(PlanError::TimeLimit {
                    limit_s: 1.0,
                    iterations: 4,
                    sensing_violation_m: 2.0,
                }),
                RefusalKind::Internal,
            ),
            (
                ServiceError::BadRequest("options.scheme: unknown".into()),
                RefusalKind::BadRequest,
            ),
        ];
        for (e, kind) in cases {
            let in_process = e.refusal();
            assert_eq!(in_process.kind, kind, "{e}");
            let bytes = envelope::encode(&in_process, Meta::default()).unwrap();
            let FromWorker::Answer(answer) = decode_answer(&bytes).unwrap() else {
                panic!("not an answer");
            };
            let Err(through) = *answer else {
                panic!("not a refusal");
            };
            assert_eq!(through.refusal(), in_process, "{e}");
        }
    }
}
