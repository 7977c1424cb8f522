//! The planner as a Zenoh service (`cellsar-planner serve`), and the control-plane messages that
//! every cellsar service shares.
//!
//! ```text
//! cellsar/plan                       queryable: PlanRequest -> Plan, or a typed refusal
//!                                    (bridge::Refusal: bad_request / infeasible / internal,
//!                                    the message naming the field, slot or step; busy when
//!                                    its request queue is full)
//! cellsar/<mission>/plan             each plan, published (bincode); also answered to queries
//!                                    (PlanLookup) from the cache of every process that holds it
//! cellsar/<mission>/plan/summary     the plan's summary (JSON, for tools without Rust)
//! cellsar/<mission>/status/<role>    ServiceStatus of each service (JSON)
//! cellsar/alive/planner/<instance>   liveliness token
//! ```
//!
//! Message kinds of this crate: `0x0100..=0x01ff`. The mission id of a plan is derived from the
//! resolved mission ([`mission_id`]), so every process agrees on it without coordination and a
//! changed mission never shares an id with an old one.
//!
//! - this file: the service ([`serve`]) and planning one request ([`plan_request`]);
//! - `cache.rs`: the plan cache every process keeps ([`PlanCache`]);
//! - `bounded.rs`: per-mission state bounded by count and bytes ([`Lru`]);
//! - `fair.rs`: the request queue, fair across requesters ([`FairQueue`]);
//! - `status.rs`: the status board every service publishes on ([`StatusBoard`]);
//! - `budget.rs`: planning one request within the work budget, in a thread or a worker;
//! - `worker.rs`: planning one request in a child process, ended at the work budget
//!   ([`worker::run_worker`]);
//! - `error.rs`: [`ServiceError`].

mod bounded;
mod budget;
mod cache;
mod error;
mod fair;
#[cfg(test)]
mod publisher_tests;
mod status;
pub mod worker;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use bridge::envelope::Meta;
use bridge::net::{PublishOptions, SubscribeOptions};
use bridge::{ZenohArgs, ZenohNode};
use serde::{Deserialize, Serialize};

use planner::driver::{plan_with_observer, plan_with_stop, Observer, PlanOptions};
use planner::Mission;
use planner::Summary;

use crate::protocol::keys::{self as pkeys, PLAN as PLAN_KEY};
use crate::protocol::{mission_id, Plan, PlanRequest, PlanSummary, Role, ServiceState};

pub use super::os::{stop_on_signals, write_atomic};
pub use bounded::{Lru, MAX_HELD_PLANS, MAX_HELD_PLAN_BYTES, MAX_MISSION_PUBLISHERS};
pub use cache::PlanCache;
pub use error::ServiceError;
pub use fair::{
    requester_of, FairQueue, Full, MAX_QUEUED_PER_REQUESTER, MAX_QUEUED_REQUESTS,
    MAX_REQUESTER_BYTES, REQUESTER_PARAMETER,
};
pub use status::StatusBoard;

/// The default wall-time limit of one plan request, s (`--plan-time-limit-s`): the paper's
/// missions plan in seconds; a request that would run longer answers with its last feasible
/// iterate. A minute within [`DEFAULT_PLAN_BUDGET_S`], for the work after the planner's last
/// check (a cone program, the exact evaluation).
pub const DEFAULT_PLAN_TIME_LIMIT_S: &str = "240";

/// The default work budget of one plan request, s (`--plan-budget-s`): the launcher waits for
/// its plan at most `--plan-timeout-s` (900 s), behind at most the plan in progress and one
/// queued before its own ([`fair`]); three budgets fit in it, so that the launcher hears the
/// answer, a plan or this refusal, before it gives up.
pub const DEFAULT_PLAN_BUDGET_S: &str = "300";

/// Flags of `cellsar-planner serve`.
#[derive(clap::Args, Debug, Clone)]
pub struct ServeArgs {
    /// Instance name (liveliness token `cellsar/alive/planner/<instance>`).
    #[arg(long, default_value = "planner")]
    pub instance: String,
    /// Keep the plans in this directory and answer lookups for them after a restart.
    #[arg(long, value_name = "DIR")]
    pub state_dir: Option<PathBuf>,
    /// Wall-time limit of each plan, s: the planner stops iterating at the limit and answers
    /// with its last accepted (feasible) iterate, termination `time_limit` in the summary; a
    /// request whose start is still being repaired then is refused (`internal`). The planner
    /// reads it between cone programs only; `--plan-budget-s` bounds the whole request.
    #[arg(long, value_name = "SECONDS", default_value = DEFAULT_PLAN_TIME_LIMIT_S, value_parser = bridge::flags::parse_seconds)]
    pub plan_time_limit_s: bridge::flags::Seconds,
    /// Work budget of each plan request, s: a request still planning this long after it was
    /// taken up is refused (`internal`, naming the budget), its planning ended, and the next
    /// request served. A request from the network cannot keep the service busy longer.
    #[arg(long, value_name = "SECONDS", default_value = DEFAULT_PLAN_BUDGET_S, value_parser = bridge::flags::parse_seconds)]
    pub plan_budget_s: bridge::flags::Seconds,
    /// The executable whose `plan-worker` subcommand plans each request in a process of its
    /// own, killed at the budget (the binaries give their own, [`worker::own_executable`]).
    /// `None`: each request is planned in a thread of this process, which the budget answers
    /// and asks to stop, and which stops at the planner's next check.
    #[arg(skip)]
    pub worker_exe: Option<PathBuf>,
    /// Zenoh flags.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
}

/// What a plan service did, at exit.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ServeReport {
    /// Requests answered with a plan (fresh or cached).
    pub plans: u64,
    /// Requests answered from the cache.
    pub cached: u64,
    /// Requests answered with an error.
    pub errors: u64,
    /// Malformed requests (counted by the queryable).
    pub malformed: u64,
    /// Requests refused as busy: the queue full, or their requester's place in it taken
    /// ([`MAX_QUEUED_REQUESTS`], [`MAX_QUEUED_PER_REQUESTER`]).
    #[serde(default)]
    pub busy: u64,
    /// Plans that could not be saved to the state directory (still answered and published).
    pub state_errors: u64,
}

/// Plans `req` (validated; errors name the field).
pub fn plan_request(
    req: &PlanRequest,
    instance: &str,
    observer: &mut dyn Observer,
) -> Result<Plan, ServiceError> {
    plan_request_within(req, instance, None, observer)
}

/// [`plan_request`] with a wall-time limit ([`PlanOptions::time_limit_s`]).
pub fn plan_request_within(
    req: &PlanRequest,
    instance: &str,
    time_limit_s: Option<f64>,
    observer: &mut dyn Observer,
) -> Result<Plan, ServiceError> {
    plan_request_stoppable(req, instance, time_limit_s, observer, None)
}

/// [`plan_request_within`] that also stops once `stop` is set ([`plan_with_stop`]).
pub fn plan_request_stoppable(
    req: &PlanRequest,
    instance: &str,
    time_limit_s: Option<f64>,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Result<Plan, ServiceError> {
    let mission = Mission::from_file_struct(&req.mission)
        .map_err(|e| ServiceError::BadRequest(format!("mission: {e}")))?;
    let options = PlanOptions {
        time_limit_s,
        ..req.options.to_plan_options()?
    };
    let result = match stop {
        Some(stop) => plan_with_stop(&mission, &options, observer, stop),
        None => plan_with_observer(&mission, &options, observer),
    }
    .map_err(|error| ServiceError::Plan {
        mission: mission.name().to_string(),
        error,
    })?;
    let file = mission.to_file_struct();
    Ok(Plan {
        mission_id: mission_id(&file, &req.options),
        summary: Summary::new(&mission, &result),
        mission: file,
        options: req.options.clone(),
        result,
        planner: instance.to_string(),
    })
}

/// Runs the plan service until `stop` is set: answers `cellsar/plan`, publishes each plan and
/// its summary, answers plan lookups from its cache (persisted in `--state-dir`). A stop while
/// the Zenoh session still opens (a client waiting for its router) ends it at once with an
/// empty report.
pub fn serve(args: &ServeArgs, stop: &AtomicBool) -> Result<ServeReport, ServiceError> {
    let config = args.zenoh.to_config()?;
    let Some(node) = ZenohNode::open_until(config, Role::Planner.as_str(), &args.instance, stop)?
    else {
        return Ok(ServeReport::default());
    };
    let report = serve_on(&node, args, stop);
    if let Err(e) = node.close() {
        tracing::warn!(error = %e, "closing the Zenoh session");
    }
    report
}

fn serve_on(
    node: &ZenohNode,
    args: &ServeArgs,
    stop: &AtomicBool,
) -> Result<ServeReport, ServiceError> {
    // the queryable's own queue is only a hand-over: a thread moves each request at once
    // into the fair queue, which decides what is refused as busy
    let requests = node.queryable::<PlanRequest>(
        PLAN_KEY,
        SubscribeOptions {
            capacity: 64,
            ..SubscribeOptions::default()
        },
    )?;
    let queue = fair::SharedQueue::new(MAX_QUEUED_REQUESTS, MAX_QUEUED_PER_REQUESTER);
    let busy = AtomicU64::new(0);
    let done = AtomicBool::new(false);
    let (queue, busy, done) = (&queue, &busy, &done);
    // the taker reports its end: the service fails naming it, instead of waiting for
    // requests that nothing takes any more
    let (exit_tx, exits) = crate::services::threads::thread_exits();
    let report = std::thread::scope(|scope| {
        let taker = std::thread::Builder::new()
            .name("plan-requests".into())
            .spawn_scoped(scope, move || {
                crate::services::threads::report_exit("plan request taker", &exit_tx, || {
                    Ok::<u64, ServiceError>(fair::take_requests(requests, queue, busy, done))
                })
            })
            .map_err(|e| ServiceError::Internal(format!("starting the request thread: {e}")));
        let (report, taker) = match taker {
            Ok(t) => (answer_requests(node, args, queue, &exits, stop), Some(t)),
            Err(e) => (Err(e), None),
        };
        done.store(true, Ordering::Relaxed);
        let malformed = taker
            .and_then(|t| t.join().ok().flatten())
            .unwrap_or_default();
        report.map(|r| ServeReport {
            malformed: r.malformed + malformed,
            busy: busy.load(Ordering::Relaxed),
            ..r
        })
    });
    let report = report?;
    tracing::info!(
        plans = report.plans,
        cached = report.cached,
        errors = report.errors,
        busy = report.busy,
        malformed = report.malformed,
        state_errors = report.state_errors,
        final_counters = true,
        "plan service stopping"
    );
    Ok(report)
}

/// Answers the requests of `queue`, each in turn, until `stop` is set.
fn answer_requests(
    node: &ZenohNode,
    args: &ServeArgs,
    queue: &fair::SharedQueue<bridge::net::IncomingQuery<PlanRequest>>,
    threads: &crate::services::threads::ThreadExits,
    stop: &AtomicBool,
) -> Result<ServeReport, ServiceError> {
    let cache = PlanCache::new(node, args.state_dir.as_deref())?;
    let board = StatusBoard::new(Role::Planner, &args.instance);
    // per-mission publishers, the least recently used undeclared beyond the bound
    let mut plan_pubs: Lru<bridge::net::TypedPublisher<Plan>> =
        Lru::with_count(MAX_MISSION_PUBLISHERS);
    let mut summary_pubs: Lru<bridge::net::TypedPublisher<PlanSummary>> =
        Lru::with_count(MAX_MISSION_PUBLISHERS);
    let mut report = ServeReport::default();
    let mut seq = 0u64;
    tracing::info!(key = PLAN_KEY, instance = %args.instance, session = %node.describe(),
        "plan service ready: answers plan requests until SIGINT/SIGTERM stops it");
    let mut waits = super::wait::WaitLog::default();
    let waiting = format!("a plan request on {PLAN_KEY}");
    while !stop.load(Ordering::Relaxed) {
        threads.check()?;
        let Some((requester, q)) = queue.pop_timeout(Duration::from_millis(100)) else {
            // nobody asked yet: say so (a client that cannot reach this planner is the usual cause)
            if report.plans + report.errors == 0 {
                waits.waiting_for(node, Some(&waiting));
            }
            continue;
        };
        waits.waiting_for(node, None);
        tracing::debug!(requester = %requester, "plan request taken up");
        let req = q.request.clone();
        let cached = Mission::from_file_struct(&req.mission)
            .ok()
            .map(|m| mission_id(&m.to_file_struct(), &req.options))
            .and_then(|id| cache.get(id))
            // the id covers the options already; this guards against a collision of the hash
            .filter(|p| p.options == req.options);
        let plan = match cached {
            Some(p) => {
                report.cached += 1;
                tracing::info!(mission = %p.mission_id, "plan request answered from the cache");
                Ok(p)
            }
            None => {
                tracing::info!(requester = ?requester, mission = ?req.mission.name,
                    budget_s = args.plan_budget_s.as_secs_f64(), "planning a request");
                budget::plan_within_budget(node, args, &board, &req, stop).map(Arc::new)
            }
        };
        if stop.load(Ordering::Relaxed) {
            break;
        }
        match plan {
            Ok(plan) => {
                seq += 1;
                let meta = Meta {
                    mission_id: plan.mission_id,
                    seq,
                    time_unix_ns: 0,
                };
                if let Err(e) = cache.insert(plan.clone()) {
                    // the plan is still answered and published; only a restart forgets it
                    report.state_errors += 1;
                    tracing::error!(mission = %plan.mission_id, error = %e,
                        "plan not saved to the state directory; serving it from memory");
                }
                if let Err(e) = q.reply(plan.as_ref(), meta) {
                    tracing::warn!(error = %e, "plan reply failed");
                }
                drop(q);
                report.plans += 1;
                publish_plan(node, &plan, meta, &mut plan_pubs, &mut summary_pubs)?;
                let mut s = board.status(plan.mission_id, ServiceState::Planned);
                s.done = plan.result.iterations as u64;
                s.total = s.done;
                s.counters.insert("plans".into(), report.plans);
                s.message = format!(
                    "{}: energy {:.1} J, feasible {}",
                    plan.summary.mission, plan.summary.energy_j, plan.summary.feasible
                );
                board.publish(node, &s);
            }
            Err(e) => {
                report.errors += 1;
                tracing::warn!(error = %e, "plan request failed");
                if let Err(e2) = q.refuse(&e.refusal()) {
                    tracing::warn!(error = %e2, "error reply failed");
                }
            }
        }
    }
    report.malformed = cache.malformed();
    Ok(report)
}

fn publish_plan(
    node: &ZenohNode,
    plan: &Plan,
    meta: Meta,
    plan_pubs: &mut Lru<bridge::net::TypedPublisher<Plan>>,
    summary_pubs: &mut Lru<bridge::net::TypedPublisher<PlanSummary>>,
) -> Result<(), ServiceError> {
    let id = plan.mission_id;
    let key = plan.key()?;
    if plan_pubs.get(id).is_none() {
        let made = node.publisher::<Plan>(
            &key,
            PublishOptions {
                mission_id: id,
                ..PublishOptions::default()
            },
        )?;
        plan_pubs.insert(id, made, 0);
    }
    if let Some(p) = plan_pubs.get(id) {
        p.put_with(plan, meta)?;
    }
    if summary_pubs.get(id).is_none() {
        let made = node.publisher::<PlanSummary>(
            &pkeys::plan_summary(id)?,
            PublishOptions {
                mission_id: id,
                ..PublishOptions::json()
            },
        )?;
        summary_pubs.insert(id, made, 0);
    }
    if let Some(p) = summary_pubs.get(id) {
        let s = PlanSummary {
            mission_id: id,
            mission: plan.summary.mission.clone(),
            windows: plan
                .mission
                .landmarks
                .points
                .as_ref()
                .map(Vec::len)
                .unwrap_or(0),
            summary: plan.summary.clone(),
        };
        p.put_with(&s, meta)?;
    }
    Ok(())
}

/// Whether `plan`'s mission id is the one its content gives (the echo's and the processor's
/// check of a plan they are asked to take on); if not, it is counted in `inconsistent`,
/// logged and to be skipped.
pub fn id_consistent(plan: &crate::protocol::Plan, inconsistent: &mut u64) -> bool {
    let Some(why) = plan.id_problem() else {
        return true;
    };
    *inconsistent += 1;
    tracing::warn!(mission = %plan.mission_id, planner = %plan.planner, reason = %why,
        "plan skipped: its mission id is not its content's");
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::*;
    use bridge::envelope::{self, DecodeLimits};
    use bridge::net::WireFormat;
    use bridge::RefusalKind;
    use planner::driver::PlanError;
    use planner::{MissionFile, NoObserver};
    use std::path::Path;

    /// A Zenoh client configuration (JSON5 in `dir`) whose router at an unused loopback port
    /// never comes, waiting for it as `pipeline/deploy/client.json5` does.
    pub(crate) fn client_without_router(dir: &Path) -> ZenohArgs {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .unwrap()
            .port();
        let file = dir.join("client.json5");
        std::fs::write(
            &file,
            bridge::zconfig::waiting_client_json5(&format!("tcp/127.0.0.1:{port}")),
        )
        .unwrap();
        ZenohArgs {
            config: Some(file),
            ..ZenohArgs::default()
        }
    }

    /// A service started before its router stops within a moment of its stop flag (what
    /// SIGINT/SIGTERM set), with an empty report, instead of waiting for the router forever.
    #[test]
    fn serve_stops_while_waiting_for_the_router() {
        let dir = tempfile_dir("serve-norouter");
        let args = ServeArgs {
            instance: "waits".into(),
            state_dir: None,
            plan_time_limit_s: bridge::flags::parse_seconds(DEFAULT_PLAN_TIME_LIMIT_S).unwrap(),
            plan_budget_s: bridge::flags::parse_seconds(DEFAULT_PLAN_BUDGET_S).unwrap(),
            worker_exe: None,
            zenoh: client_without_router(&dir),
        };
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let s = stop.clone();
        std::thread::spawn(move || {
            let _ = tx.send(serve(&args, &s));
        });
        std::thread::sleep(Duration::from_millis(700));
        assert!(rx.try_recv().is_err(), "serve returned without a router");
        stop.store(true, Ordering::Relaxed);
        let report = rx
            .recv_timeout(Duration::from_secs(2))
            .expect("serve did not stop within 2 s of the stop flag")
            .unwrap();
        assert_eq!(report, ServeReport::default());
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A plan request from the network cannot keep the service busy without bound: the
    /// default time limit is 240 s and the default work budget 300 s, and either can be given
    /// but not removed. The service plans in a thread unless given a worker executable (the
    /// binaries give their own).
    #[test]
    fn plan_requests_have_a_default_time_limit_and_budget() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            serve: ServeArgs,
        }
        let c = Cli::try_parse_from(["serve"]).unwrap();
        assert_eq!(c.serve.plan_time_limit_s.as_secs_f64(), 240.0);
        assert_eq!(c.serve.plan_budget_s.as_secs_f64(), 300.0);
        assert_eq!(c.serve.worker_exe, None);
        let c = Cli::try_parse_from([
            "serve",
            "--plan-time-limit-s",
            "2.5",
            "--plan-budget-s",
            "4",
        ])
        .unwrap();
        assert_eq!(c.serve.plan_time_limit_s.as_secs_f64(), 2.5);
        assert_eq!(c.serve.plan_budget_s.as_secs_f64(), 4.0);
        for flag in ["--plan-time-limit-s", "--plan-budget-s"] {
            for bad in ["0", "-1", "inf", "none"] {
                let arg = format!("{flag}={bad}");
                let e = Cli::try_parse_from(["serve", arg.as_str()])
                    .err()
                    .expect("refused");
                assert!(e.to_string().contains(flag), "{bad}: {e}");
            }
        }
    }

    fn tempfile_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("cellsar-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn short_mission() -> MissionFile {
        MissionFile::from_toml_str(
            "name = \"short\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{ x_m = 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }, { x_m = 0.0, y_m = 30.0, from_s = 10.0, to_s = 20.0 }]\n",
        )
        .unwrap()
    }

    /// The service's time limit reaches the planner: a limit that has passed gives either the
    /// start, stopped by the limit, or (start not yet feasible) an `internal` refusal that says
    /// so; a generous one changes nothing.
    #[test]
    fn plan_time_limit_reaches_the_planner() {
        let req = PlanRequest {
            mission: short_mission(),
            options: PlanRequestOptions {
                resolution: Some(planner::evaluate::ResolutionMode::Paper),
                ..PlanRequestOptions::default()
            },
        };
        match plan_request_within(&req, "t", Some(1e-9), &mut NoObserver) {
            Ok(plan) => {
                assert_eq!(
                    plan.result.termination,
                    planner::TerminationReason::TimeLimit
                );
                assert_eq!(plan.result.iterations, 0);
            }
            Err(e) => {
                assert!(
                    matches!(
                        e,
                        ServiceError::Plan {
                            error: PlanError::TimeLimit { .. },
                            ..
                        }
                    ),
                    "{e}"
                );
                assert_eq!(e.refusal().kind, RefusalKind::Internal);
            }
        }
        let plan = plan_request_within(&req, "t", Some(1e6), &mut NoObserver).unwrap();
        assert!(plan.result.converged);
    }

    #[test]
    fn plans_round_trip_in_both_forms() {
        let req = PlanRequest {
            mission: short_mission(),
            options: PlanRequestOptions {
                resolution: Some(planner::evaluate::ResolutionMode::Paper),
                ..PlanRequestOptions::default()
            },
        };
        let plan = plan_request(&req, "t", &mut NoObserver).unwrap();
        assert_eq!(plan.mission_id, mission_id(&plan.mission, &req.options));
        let meta = Meta::default();
        let limits = DecodeLimits {
            max_body_bytes: MAX_PLAN_BYTES,
            verify_crc: true,
        };
        let bin = envelope::encode(&plan, meta).unwrap();
        let back: Plan = envelope::decode(&bin, &limits).unwrap().message;
        assert_eq!(back.result.trajectory, plan.result.trajectory);
        assert_eq!(back.summary, plan.summary);
        assert_eq!(
            serde_json::to_string(&back).unwrap(),
            serde_json::to_string(&plan).unwrap()
        );
        // JSON for tools without Rust: readable, with the trajectory as numbers
        let json = envelope::encode_json(&plan, meta).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        assert_eq!(v["kind_name"], "planner.plan");
        assert!(
            v["body"]["result"]["trajectory"]["pos_m"]
                .as_array()
                .unwrap()
                .len()
                > 10
        );
        // the resolved mission plans to the same mission id
        let again = Mission::from_file_struct(&plan.mission).unwrap();
        assert_eq!(
            mission_id(&again.to_file_struct(), &req.options),
            plan.mission_id
        );
        // other options, another plan: another id (the default options keep the mission's)
        let general = PlanRequestOptions {
            resolution: Some(planner::evaluate::ResolutionMode::General),
            ..PlanRequestOptions::default()
        };
        assert_ne!(mission_id(&plan.mission, &general), plan.mission_id);
        assert_eq!(
            mission_id(&plan.mission, &general),
            mission_id(&again.to_file_struct(), &general)
        );
    }

    #[test]
    fn bad_requests_name_the_field() {
        let mut req = PlanRequest {
            mission: short_mission(),
            options: PlanRequestOptions {
                tolerance: Some(-1.0),
                ..Default::default()
            },
        };
        let e = plan_request(&req, "t", &mut NoObserver).unwrap_err();
        assert!(e.to_string().contains("options.tolerance"), "{e}");
        assert_eq!(e.refusal().kind, RefusalKind::BadRequest);
        req.options = PlanRequestOptions::default();
        req.mission.params.altitude_m = Some(-5.0);
        let e = plan_request(&req, "t", &mut NoObserver).unwrap_err();
        assert!(e.to_string().contains("altitude_m"), "{e}");
        let e =
            serde_json::from_str::<PlanRequest>(r#"{"mission": {"landmarks": {}}, "optoins": {}}"#)
                .unwrap_err();
        assert!(e.to_string().contains("optoins"), "{e}");
    }

    /// A refused plan request is answered with a typed refusal whose kind says why (what the
    /// launcher maps to exit code 2, 3 or 1), readable by the querier in both formats.
    #[test]
    fn refusals_carry_their_kind() {
        // a landmark 50 km away 10 s after the first: no speed reaches it (a bad request is
        // `bad_request`: bad_requests_name_the_field)
        let req = PlanRequest {
            options: PlanRequestOptions {
                resolution: Some(planner::evaluate::ResolutionMode::Paper),
                ..PlanRequestOptions::default()
            },
            mission: MissionFile::from_toml_str(
                "name = \"unreachable\"\n[params]\nhorizon_s = 20\nstart_m = [-1000.0, 0.0]\n\
             [landmarks]\npoints = [{ x_m = 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }, \
             { x_m = 50000.0, y_m = 0.0, from_s = 10.0, to_s = 20.0 }]\n",
            )
            .unwrap(),
        };
        let e = plan_request(&req, "t", &mut NoObserver).unwrap_err();
        let r = e.refusal();
        assert_eq!(r.kind, RefusalKind::Infeasible, "{e}");
        assert_eq!(r.message, e.to_string());
        assert!(
            r.message.contains("\"unreachable\"") && r.message.contains("slot"),
            "{r:?}"
        );
        assert_eq!(
            ServiceError::Internal("the planning thread panicked".into())
                .refusal()
                .kind,
            RefusalKind::Internal
        );
        // what the querier decodes from the error reply, in either format
        for format in [WireFormat::Bincode, WireFormat::Json] {
            let bytes = format.encode(&r, Meta::default()).unwrap();
            match bridge::net::decode_error_reply(
                PLAN_KEY,
                &bytes,
                format,
                &DecodeLimits::default(),
            ) {
                bridge::NetError::Refused { key, refusal } => {
                    assert_eq!(key, PLAN_KEY);
                    assert_eq!(refusal, r);
                }
                other => panic!("{format:?}: {other:?}"),
            }
        }
    }
}
