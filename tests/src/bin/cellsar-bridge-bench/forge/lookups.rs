//! `forge --answer-plan-lookups`: a queryable on every mission's plan key (`cellsar/*/plan`,
//! where the echo and the processor look up the plan of a mission they are asked for), declared
//! when the forger starts, that answers every lookup with its forged plan (another mission's
//! content) claiming the mission looked up. Only the planner's role may declare it or answer
//! there; the queryable takes no lookup of the forger's own (`Locality::Remote`), so its
//! report counts only the lookups that a router let reach it.

use bridge::net::WireFormat;
use bridge::zenoh::handlers::FifoChannelHandler;
use bridge::zenoh::query::{Query, Queryable};
use bridge::zenoh::sample::Locality;
use bridge::zenoh::Wait;
use bridge::ZenohNode;
use pipeline::protocol::{keys, Plan};
use serde::Serialize;

use super::{mission_of, FORGED_PLAN_ID};

/// The flag of the plan lookups.
#[derive(clap::Args, Debug, Clone)]
pub(in super::super) struct LookupArgs {
    /// Declare a queryable on every mission's plan key (cellsar/*/plan) and answer every plan
    /// lookup with a forged plan claiming the mission looked up.
    #[arg(long)]
    pub(super) answer_plan_lookups: bool,
}

/// What came of its queryable.
#[derive(Debug, Default, Serialize)]
pub(super) struct LookupsAnswered {
    /// Whether the queryable was declared (here; the router may still deny it).
    pub declared: bool,
    /// Plan lookups it got (from other sessions).
    pub lookups: u64,
    /// Forged plans it sent in answer.
    pub answers: u64,
    /// Answers that failed here.
    pub errors: u64,
}

/// The queryable on every mission's plan key.
pub(super) struct Lookups {
    queryable: Queryable<FifoChannelHandler<Query>>,
}

impl Lookups {
    /// Declares the queryable on [`keys::ALL_PLANS`].
    pub(super) fn declare(node: &ZenohNode) -> anyhow::Result<Self> {
        let queryable = node
            .session()
            .declare_queryable(keys::ALL_PLANS)
            .allowed_origin(Locality::Remote)
            .wait()
            .map_err(|e| anyhow::anyhow!("declaring a queryable on {}: {e}", keys::ALL_PLANS))?;
        Ok(Lookups { queryable })
    }

    /// Answers every lookup received so far with `plan` claiming the mission looked up (that of
    /// the query's key, or [`FORGED_PLAN_ID`] for a lookup of every mission).
    pub(super) fn answer(&self, plan: &Plan, r: &mut LookupsAnswered) {
        r.declared = true;
        while let Ok(Some(query)) = self.queryable.try_recv() {
            r.lookups += 1;
            match answer(&query, plan) {
                Ok(()) => {
                    r.answers += 1;
                    eprintln!("answered a plan lookup with a forged plan");
                }
                Err(e) => {
                    r.errors += 1;
                    eprintln!("answering a plan lookup: {e}");
                }
            }
        }
    }
}

fn answer(query: &Query, plan: &Plan) -> Result<(), String> {
    let id = mission_of(query.key_expr().as_str()).unwrap_or(FORGED_PLAN_ID);
    let key = keys::plan(id).map_err(|e| e.to_string())?;
    let forged = Plan {
        mission_id: id,
        ..plan.clone()
    };
    let format = query.encoding().map(WireFormat::of).unwrap_or_default();
    let meta = bridge::Meta {
        mission_id: id,
        ..bridge::Meta::default()
    };
    let bytes = format.encode(&forged, meta).map_err(|e| e.to_string())?;
    query
        .reply(key, bytes)
        .encoding(format.encoding::<Plan>())
        .wait()
        .map_err(|e| e.to_string())
}
