//! The planner's work budget (`--plan-budget-s`): a valid mission that would plan for hours
//! holds the planner for at most the budget, is refused naming it, and the next mission is
//! served. Peers flood a planner on loopback with the most expensive valid missions (the
//! paper's default mission at 200 000 slots, the most a mission may have), while a client asks
//! for a normal mission: it plans, and every flood request taken up is answered within its
//! budget.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bridge::net::{QueryOptions, WireFormat};
use bridge::{DecodeLimits, NetError, RefusalKind, ZenohArgs, ZenohNode};
use harness::pipeline::*;
use pipeline::protocol::keys::PLAN as PLAN_KEY;
use pipeline::protocol::{Plan, PlanRequest, PlanRequestOptions, MAX_PLAN_BYTES};
use pipeline::services::plan::REQUESTER_PARAMETER;

/// The planner's budget in this test, s: generous for the normal mission's plan in a debug
/// build on a loaded 2-core machine (about 1 s alone), far below the flood's missions' plans.
const BUDGET_S: f64 = 20.0;

/// Peers flooding, each with its own requester name (each holds a place in the queue).
const FLOODERS: usize = 2;

/// The paper's default mission at 200 000 slots (0.0015 s each over its 300 s): valid, and
/// each cone program of it takes minutes.
fn worst_case(k: u64) -> PlanRequest {
    let text = format!(
        "name = \"worst case {k}\"\n[params]\nslot_s = 0.0015\n[landmarks]\npreset = \"default\"\n"
    );
    let mission = planner::MissionFile::from_toml_str(&text).unwrap();
    let m = planner::Mission::from_file_struct(&mission).unwrap();
    assert_eq!(m.slots(), planner::params::MAX_SLOTS);
    PlanRequest {
        mission,
        options: PlanRequestOptions::default(),
    }
}

/// A short mission of two landmarks named `name` (a name of its own: not in the planner's
/// cache), planned with the paper's resolution (about a second).
fn normal(name: &str) -> PlanRequest {
    let mission = planner::MissionFile::from_toml_str(&format!(
        "name = \"{name}\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [\
         {{ x_m = 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }}, \
         {{ x_m = 0.0, y_m = 30.0, from_s = 10.0, to_s = 20.0 }}]\n"
    ))
    .unwrap();
    PlanRequest {
        mission,
        options: PlanRequestOptions {
            resolution: Some(planner::evaluate::ResolutionMode::Paper),
            ..PlanRequestOptions::default()
        },
    }
}

fn ask(
    node: &ZenohNode,
    requester: &str,
    req: &PlanRequest,
    timeout: Duration,
) -> Result<Plan, NetError> {
    node.query_one::<PlanRequest, Plan>(
        &format!("{PLAN_KEY}?{REQUESTER_PARAMETER}={requester}"),
        req,
        &QueryOptions {
            timeout,
            format: WireFormat::Bincode,
            limits: DecodeLimits {
                max_body_bytes: MAX_PLAN_BYTES,
                verify_crc: true,
            },
            ..QueryOptions::default()
        },
    )
    .map(|r| r.message)
}

/// What the flood saw.
#[derive(Default)]
struct Flooded {
    sent: AtomicU64,
    over_budget: AtomicU64,
    busy: AtomicU64,
    /// The longest a request refused over its budget took, ms (from its sending: it waited for
    /// the request taken up before it, then its own budget).
    longest_ms: AtomicU64,
    other: std::sync::Mutex<Vec<String>>,
}

#[test]
fn a_flood_of_the_costliest_valid_missions_holds_the_planner_for_its_budget_only() {
    let dir = tempfile::tempdir().unwrap();
    let hub = format!("tcp/127.0.0.1:{}", free_port());
    let mut args = vec!["planner".to_string()];
    args.extend(
        ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], std::slice::from_ref(&hub))
            .to_cli_args(),
    );
    args.extend(["--plan-budget-s".into(), BUDGET_S.to_string()]);
    let mut planner = Service::start("planner", dir.path(), &args);
    planner.wait_for_log("plan service ready", Duration::from_secs(60));
    let z = ZenohArgs::isolated(std::slice::from_ref(&hub), &[]);
    let node = Arc::new(ZenohNode::open(z.to_config().unwrap(), "client", "budget").unwrap());
    let deadline = Instant::now() + Duration::from_secs(60);
    while node
        .alive_now("cellsar/alive/planner/*", Duration::from_millis(300))
        .unwrap()
        .is_empty()
    {
        assert!(Instant::now() < deadline, "the planner never came up");
        std::thread::sleep(Duration::from_millis(50));
    }
    // the planner reachable: a normal plan before the flood, timed
    let t0 = Instant::now();
    ask(
        &node,
        "launcher",
        &normal("alone"),
        Duration::from_secs(120),
    )
    .unwrap();
    let alone = t0.elapsed();
    assert!(
        alone.as_secs_f64() < BUDGET_S / 2.0,
        "the normal plan took {alone:?}"
    );

    let stop = Arc::new(AtomicBool::new(false));
    let seen = Arc::new(Flooded::default());
    let flooders: Vec<_> = (0..FLOODERS)
        .map(|f| {
            let (node, stop, seen) = (node.clone(), stop.clone(), seen.clone());
            std::thread::spawn(move || {
                let mut k = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    k += 1;
                    let sent = Instant::now();
                    seen.sent.fetch_add(1, Ordering::Relaxed);
                    let budget = Duration::from_secs_f64(BUDGET_S);
                    // bounded: the plan in progress, this flooder's own, and slack
                    match ask(
                        &node,
                        &format!("flood{f}"),
                        &worst_case(k * 10 + f as u64),
                        budget * 6,
                    ) {
                        Err(NetError::Refused { refusal, .. })
                            if refusal.kind == RefusalKind::Internal
                                && refusal.message.contains("--plan-budget-s") =>
                        {
                            seen.over_budget.fetch_add(1, Ordering::Relaxed);
                            let ms = sent.elapsed().as_millis() as u64;
                            seen.longest_ms.fetch_max(ms, Ordering::Relaxed);
                        }
                        Err(NetError::Refused { refusal, .. })
                            if refusal.kind == RefusalKind::Busy =>
                        {
                            seen.busy.fetch_add(1, Ordering::Relaxed);
                            std::thread::sleep(Duration::from_millis(100));
                        }
                        // the planner stopping at the end may leave the last request unanswered
                        _ if stop.load(Ordering::Relaxed) => {}
                        other => seen.other.lock().unwrap().push(format!("{other:?}")),
                    }
                }
            })
        })
        .collect();
    // the flood takes the planner first: wait until the planner has taken up one of its
    // requests (its log names the mission it plans)
    planner.wait_for_log(
        "planning a request requester=\"flood",
        Duration::from_secs(60),
    );
    // the normal mission waits behind at most the plan in progress and one request of each
    // flooder, each within the budget, then plans
    let t0 = Instant::now();
    let bound = Duration::from_secs_f64(BUDGET_S * (FLOODERS as f64 + 2.0)) + alone * 4;
    let plan = ask(
        &node,
        "launcher",
        &normal("normal"),
        bound + Duration::from_secs(60),
    );
    let waited = t0.elapsed();
    stop.store(true, Ordering::Relaxed);
    let plan = plan.unwrap_or_else(|e| panic!("the normal mission: {e} after {waited:?}"));
    assert_eq!(plan.summary.mission, "normal");
    assert!(plan.result.converged);
    assert!(
        waited <= bound,
        "the normal mission waited {waited:?}, bound {bound:?}"
    );
    let log = planner.log_text();
    assert!(
        planner.stop(Duration::from_secs(30)).success(),
        "{}",
        planner.log_text()
    );
    for f in flooders {
        f.join().unwrap();
    }
    let other = seen.other.lock().unwrap().clone();
    let (sent, over, busy) = (
        seen.sent.load(Ordering::Relaxed),
        seen.over_budget.load(Ordering::Relaxed),
        seen.busy.load(Ordering::Relaxed),
    );
    eprintln!(
        "normal plan alone {alone:?}, under the flood {waited:?}; flood: {sent} sent, {over} \
         refused over the budget, {busy} busy, longest over-budget answer {} ms",
        seen.longest_ms.load(Ordering::Relaxed)
    );
    assert!(other.is_empty(), "{other:?}");
    assert!(over >= 1, "no flood request was refused over its budget");
    // each over-budget answer came after its own budget, and within the one before it, its
    // own, and slack
    let longest = Duration::from_millis(seen.longest_ms.load(Ordering::Relaxed));
    assert!(
        longest >= Duration::from_secs_f64(BUDGET_S)
            && longest <= Duration::from_secs_f64(BUDGET_S * (FLOODERS as f64 + 2.0)),
        "{longest:?}"
    );
    assert!(log.contains("work budget of 20 s"), "{log}");
}
