//! The floods of `forge`: many well-formed messages that a peer may send but that ask for
//! what is not there.
//!
//! - `--flood-plans N`: `N` plans of distinct missions, each under the mission id its content
//!   gives (so that every service takes it as a real plan: plan caches, the processor's
//!   missions, the per-mission publishers fill), published once when the forger starts;
//! - `--flood-queries`: every round and for every mission it learned, a request to publish
//!   again every aperture up to [`FLOOD_APERTURES`] and the metrics, a request to the echo for
//!   an aperture out of range with a frame size other than the echo's, and a lookup of a plan
//!   that nobody made.

use std::time::Duration;

use anyhow::Result;
use bridge::net::{PublishOptions, QueryOptions};
use bridge::{MissionId, ZenohNode};
use pipeline::protocol::{
    keys, mission_id, ApertureRequest, Plan, PlanLookup, RequestAck, ResultAck, ResultRequest,
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
