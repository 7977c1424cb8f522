//! The floods of `forge`: many well-formed messages that a peer may send but that ask for
//! what is not there.
//!
//! - `--flood-plans N`: `N` plans of distinct missions, each under the mission id its content
//!   gives (so that every service takes it as a real plan: plan caches, the processor's
//!   missions, the per-mission publishers fill), published once when the forger starts;
//! - `--flood-queries`: every round and for every mission it learned, a request to publish
//!   again every aperture up to [`FLOOD_APERTURES`] and the metrics, a request to the echo for
//!   an aperture out of range with a frame size other than the echo's, and a lookup of a plan
//!   that nobody made;
//! - `--flood-plan-requests N`: `N` plan requests (`cellsar/plan`, bincode, as the launcher
//!   sends them) of distinct small missions, each a real planning job, from a thread of their
//!   own for as long as the forger forges: [`PLAN_REQUESTS_IN_FLIGHT`] at once, each one
//!   answered (a plan, a busy refusal, nothing within [`PLAN_REQUEST_TIMEOUT`]) replaced at
//!   once by the next, so that the planner's request queue stays full.

use std::time::{Duration, Instant};

use anyhow::Result;
use bridge::net::{PublishOptions, QueryOptions};
use bridge::{MissionId, ZenohNode};
use pipeline::protocol::{
    keys, mission_id, ApertureRequest, Plan, PlanLookup, PlanRequest, RequestAck, ResultAck,
    ResultRequest, MAX_PLAN_BYTES,
};

/// Apertures a flooded result request names (more than any mission has).
pub(super) const FLOOD_APERTURES: u32 = 10_000;

/// The flags of the floods.
#[derive(clap::Args, Debug, Clone)]
pub(in super::super) struct FloodArgs {
    /// Publish this many plans of distinct missions (well-formed, each under its own id)
    /// once at the start.
    #[arg(long, default_value_t = 0)]
    pub(super) flood_plans: u32,
    /// Every round and for every mission: ask the processor for every aperture again, the
    /// echo for an aperture out of range, and every holder of plans for one nobody made.
    #[arg(long)]
    flood_queries: bool,
    /// Send this many plan requests of distinct missions (well-formed, as the launcher sends
    /// them), many in flight at once, for as long as the forger forges.
    #[arg(long, default_value_t = 0)]
    pub(super) flood_plan_requests: u32,
}

/// Plan requests of the flood in flight at once (more than the planner's request queue, 16).
pub(super) const PLAN_REQUESTS_IN_FLIGHT: usize = 48;

/// How long a flooded plan request waits for its answer.
pub(super) const PLAN_REQUEST_TIMEOUT: Duration = Duration::from_secs(30);

/// What the flood of plan requests got back.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub(super) struct PlanRequestsFlooded {
    /// Plan requests sent.
    pub sent: u64,
    /// Answered with a plan.
    pub planned: u64,
    /// Refused as busy (the planner's request queue full).
    pub busy: u64,
    /// Answered otherwise (another refusal, no answer, a bad reply) or not sent.
    pub other: u64,
}

/// What the floods sent (and how many of their queries got an answer).
#[derive(Debug, Default, serde::Serialize)]
pub(super) struct Flooded {
    /// Plans of distinct missions published.
    pub plans: u64,
    /// Bytes of one of them, encoded (as on the wire).
    pub plan_bytes: u64,
    /// Queries sent.
    pub queries: u64,
    /// Queries answered with a reply of the expected type.
    pub answered: u64,
    /// The flood of plan requests.
    pub plan_requests: PlanRequestsFlooded,
}

/// `a.flood_plans` plans made from `plan`, each of a mission named `flood-<n>` (and so of
/// its own id).
pub(super) fn plans(plan: &Plan, a: &FloodArgs) -> Vec<Plan> {
    (0..a.flood_plans)
        .map(|n| {
            let mut p = plan.clone();
            p.mission.name = Some(format!("flood-{n}"));
            p.mission_id = mission_id(&p.mission, &p.options);
            p
        })
        .collect()
}

/// Publishes `plans`, each on its mission's key.
pub(super) fn publish_plans(node: &ZenohNode, plans: &[Plan], r: &mut Flooded) -> Result<()> {
    for p in plans {
        let publisher = node.publisher::<Plan>(
            &keys::plan(p.mission_id)?,
            PublishOptions {
                mission_id: p.mission_id,
                ..PublishOptions::default()
            },
        )?;
        publisher.put(p)?;
        r.plans += 1;
        r.plan_bytes = bridge::envelope::encode(p, bridge::Meta::default())?.len() as u64;
    }
    Ok(())
}

/// One round of queries about mission `id` (with `a.flood_queries`), each answered within
/// 200 ms or given up.
pub(super) fn flood_queries(node: &ZenohNode, id: MissionId, a: &FloodArgs, r: &mut Flooded) {
    if !a.flood_queries {
        return;
    }
    let opts = QueryOptions {
        timeout: Duration::from_millis(200),
        ..QueryOptions::default()
    };
    let nobody = MissionId(id.0 ^ 0x0f0f_0f0f_0f0f_0f0f);
    let results = ResultRequest {
        mission_id: id,
        apertures: (0..FLOOD_APERTURES).collect(),
        metrics: true,
    };
    let aperture = ApertureRequest {
        mission_id: id,
        aperture: FLOOD_APERTURES,
        look: Some(u32::MAX),
        frame_pulses: 1,
        scene_digest: 0,
        requester: "intruder".into(),
    };
    let answered = [
        keys::results(id)
            .ok()
            .map(|k| node.query_one::<_, ResultAck>(&k, &results, &opts).is_ok()),
        keys::echo_request(id).ok().map(|k| {
            node.query_one::<_, RequestAck>(&k, &aperture, &opts)
                .is_ok()
        }),
        keys::plan(nobody)
            .ok()
            .map(|k| node.query_one::<_, Plan>(&k, &PlanLookup {}, &opts).is_ok()),
    ];
    for a in answered.into_iter().flatten() {
        r.queries += 1;
        r.answered += u64::from(a);
    }
}

/// The `n`th flooded plan request: `base`'s mission named `flood-request-<n>` (so of its own
/// id, and planned afresh), `base`'s options.
fn plan_request(base: &PlanRequest, n: u32) -> PlanRequest {
    let mut r = base.clone();
    r.mission.name = Some(format!("flood-request-{n}"));
    r
}

/// Sends `a.flood_plan_requests` plan requests made from `base` until `end`, keeping
/// [`PLAN_REQUESTS_IN_FLIGHT`] of them in flight; those still open at `end` are abandoned.
pub(super) fn plan_requests(
    node: &ZenohNode,
    base: &PlanRequest,
    a: &FloodArgs,
    end: Instant,
) -> PlanRequestsFlooded {
    let mut r = PlanRequestsFlooded::default();
    let opts = QueryOptions {
        timeout: PLAN_REQUEST_TIMEOUT,
        format: bridge::net::WireFormat::Bincode,
        limits: bridge::envelope::DecodeLimits {
            max_body_bytes: MAX_PLAN_BYTES,
            verify_crc: true,
        },
        ..QueryOptions::default()
    };
    let mut next = 0u32;
    let mut pending: Vec<bridge::net::PendingQuery<Plan>> = Vec::new();
    while Instant::now() < end && (next < a.flood_plan_requests || !pending.is_empty()) {
        while pending.len() < PLAN_REQUESTS_IN_FLIGHT && next < a.flood_plan_requests {
            let req = plan_request(base, next);
            next += 1;
            r.sent += 1;
            match node.start_query::<PlanRequest, Plan>(keys::PLAN, &req, &opts) {
                Ok(q) => pending.push(q),
                Err(_) => r.other += 1,
            }
        }
        pending.retain_mut(|q| match q.poll(Duration::ZERO) {
            None => true,
            Some(Ok(_)) => {
                r.planned += 1;
                false
            }
            Some(Err(bridge::NetError::Refused { refusal, .. }))
                if refusal.kind == bridge::RefusalKind::Busy =>
            {
                r.busy += 1;
                false
            }
            Some(Err(_)) => {
                r.other += 1;
                false
            }
        });
        std::thread::sleep(Duration::from_millis(2));
    }
    r
}
