//! The plan cache every process keeps: the plans it holds, answered to lookups and optionally
//! stored in a directory.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use bridge::envelope::{self, DecodeLimits, Meta};
use bridge::net::{QueryOptions, WireFormat};
use bridge::zenoh::key_expr::KeyExpr;
use bridge::zenoh::query::{Query, QueryTarget};
use bridge::zenoh::Wait;
use bridge::{MissionId, Refusal, RefusalKind, ZenohNode};

use super::{write_atomic, ServiceError};
use crate::protocol::keys::ALL_PLANS;
use crate::protocol::{Plan, PlanLookup, MAX_PLAN_BYTES};

/// Plans held by a process, answered to `cellsar/*/plan` lookups (so a process that joins late
/// or restarts gets the plans without re-planning; a lookup that is no [`PlanLookup`] gets a
/// typed `bad_request` refusal), optionally persisted in a directory.
pub struct PlanCache {
    plans: Arc<Mutex<BTreeMap<MissionId, Arc<Plan>>>>,
    dir: Option<PathBuf>,
    malformed: Arc<std::sync::atomic::AtomicU64>,
    _queryable: bridge::zenoh::query::Queryable<()>,
}

impl PlanCache {
    /// Declares the lookup queryable on `cellsar/*/plan`; with `dir`, loads the plans stored
    /// there (unreadable files are logged and skipped) and stores new ones.
    pub fn new(node: &ZenohNode, dir: Option<&Path>) -> Result<Self, ServiceError> {
        let plans: Arc<Mutex<BTreeMap<MissionId, Arc<Plan>>>> = Arc::default();
        if let Some(d) = dir {
            std::fs::create_dir_all(d).map_err(|e| ServiceError::io(d, e))?;
            let mut loaded = BTreeMap::new();
            for entry in std::fs::read_dir(d)
                .map_err(|e| ServiceError::io(d, e))?
                .flatten()
            {
                let path = entry.path();
                if path.extension().and_then(|e| e.to_str()) != Some("plan") {
                    continue;
                }
                match load_plan(&path) {
                    Ok(p) => {
                        loaded.insert(p.mission_id, Arc::new(p));
                    }
                    Err(e) => {
                        tracing::warn!(file = %path.display(), error = %e, "stored plan skipped")
                    }
                }
            }
            if !loaded.is_empty() {
                tracing::info!(plans = loaded.len(), dir = %d.display(), "plans restored");
            }
            if let Ok(mut p) = plans.lock() {
                *p = loaded;
            }
        }
        let p = plans.clone();
        let malformed = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let m = malformed.clone();
        let log = Arc::new(bridge::counters::BadPayloadLog::default());
        let queryable = node
            .session()
            .declare_queryable(ALL_PLANS)
            .callback(move |query: Query| answer_lookup(&p, &query, &m, &log))
            .wait()
            .map_err(|e| bridge::NetError::zenoh("declare queryable", ALL_PLANS, e))?;
        Ok(PlanCache {
            plans,
            dir: dir.map(Path::to_path_buf),
            malformed,
            _queryable: queryable,
        })
    }

    /// Lookups whose payload was not a [`PlanLookup`] (answered with an error, counted, logged).
    pub fn malformed(&self) -> u64 {
        self.malformed.load(Ordering::Relaxed)
    }

    /// Adds (or replaces) a plan; stores it when the cache has a directory. The plan is held
    /// (and answered to lookups) even when storing it fails; the error says why it was not
    /// stored.
    pub fn insert(&self, plan: Arc<Plan>) -> Result<(), ServiceError> {
        if let Ok(mut p) = self.plans.lock() {
            p.insert(plan.mission_id, plan.clone());
        }
        if let Some(d) = &self.dir {
            let bytes = envelope::encode(
                plan.as_ref(),
                Meta {
                    mission_id: plan.mission_id,
                    ..Meta::default()
                },
            )
            .map_err(|error| ServiceError::Codec {
                what: format!("plan {}", plan.mission_id),
                error,
            })?;
            let path = d.join(format!("{}.plan", plan.mission_id));
            write_atomic(&path, &bytes)?;
        }
        Ok(())
    }

    /// Lets go of the plan of `id` (no longer answered to lookups; a stored copy stays).
    pub fn remove(&self, id: MissionId) {
        if let Ok(mut p) = self.plans.lock() {
            p.remove(&id);
        }
    }

    /// The plan of `id`, if held.
    pub fn get(&self, id: MissionId) -> Option<Arc<Plan>> {
        self.plans.lock().ok().and_then(|p| p.get(&id).cloned())
    }

    /// Every plan held.
    pub fn all(&self) -> Vec<Arc<Plan>> {
        self.plans
            .lock()
            .map(|p| p.values().cloned().collect())
            .unwrap_or_default()
    }

    /// Subscribes to every mission's plans as they are published (bounded to
    /// [`MAX_PLAN_BYTES`]); the echo and the processor take their missions from it.
    pub fn subscribe_plans(
        node: &ZenohNode,
    ) -> Result<bridge::net::TypedSubscriber<Plan>, bridge::NetError> {
        node.subscriber::<Plan>(
            ALL_PLANS,
            bridge::net::SubscribeOptions {
                capacity: 16,
                limits: DecodeLimits {
                    max_body_bytes: MAX_PLAN_BYTES,
                    verify_crc: true,
                },
                ..bridge::net::SubscribeOptions::default()
            },
        )
    }

    /// The plans other processes already hold (a service that starts late or restarts takes
    /// them instead of waiting for the next publication); a failed lookup is logged and gives
    /// none.
    pub fn plans_known_at_start(node: &ZenohNode) -> Vec<Plan> {
        Self::lookup(node, ALL_PLANS, Duration::from_secs(2)).unwrap_or_else(|e| {
            tracing::warn!(error = %e, "plan lookup at start failed");
            Vec::new()
        })
    }

    /// Asks every process for the plans matching `selector` (e.g. [`ALL_PLANS`] or
    /// `cellsar/<mission>/plan`); replies that do not decode are logged and skipped.
    pub fn lookup(
        node: &ZenohNode,
        selector: &str,
        timeout: Duration,
    ) -> Result<Vec<Plan>, ServiceError> {
        let opts = QueryOptions {
            timeout,
            target: QueryTarget::All,
            limits: DecodeLimits {
                max_body_bytes: MAX_PLAN_BYTES,
                verify_crc: true,
            },
            ..QueryOptions::default()
        };
        let mut out: BTreeMap<MissionId, Plan> = BTreeMap::new();
        for r in node.query::<PlanLookup, Plan>(selector, &PlanLookup {}, &opts)? {
            match r {
                Ok(p) => {
                    out.insert(p.message.mission_id, p.message);
                }
                Err(e) => tracing::warn!(error = %e, "plan lookup reply skipped"),
            }
        }
        Ok(out.into_values().collect())
    }
}

fn answer_lookup(
    plans: &Mutex<BTreeMap<MissionId, Arc<Plan>>>,
    query: &Query,
    malformed: &std::sync::atomic::AtomicU64,
    log: &bridge::counters::BadPayloadLog,
) {
    let format = query.encoding().map(WireFormat::of).unwrap_or_default();
    if let Some(payload) = query.payload() {
        // the size is checked before a fragmented payload is copied
        if let Err(e) = format.decode_zbytes::<PlanLookup>(payload, &DecodeLimits::default()) {
            malformed.fetch_add(1, Ordering::Relaxed);
            let key = query.key_expr().as_str();
            log.log(key, payload.len(), &e);
            let refusal = Refusal::new(RefusalKind::BadRequest, format!("bad plan lookup: {e}"));
            if let Err(e) = bridge::net::refuse_query(query, key, format, &refusal) {
                tracing::debug!(error = %e, "plan lookup refusal failed");
            }
            return;
        }
    }
    let held: Vec<Arc<Plan>> = plans
        .lock()
        .map(|p| p.values().cloned().collect())
        .unwrap_or_default();
    for plan in held {
        let Ok(key) = plan.key() else { continue };
        let Ok(ke) = KeyExpr::try_from(key.clone()) else {
            continue;
        };
        if !query.key_expr().intersects(&ke) {
            continue;
        }
        let meta = Meta {
            mission_id: plan.mission_id,
            ..Meta::default()
        };
        match format.encode(plan.as_ref(), meta) {
            Ok(bytes) => {
                if let Err(e) = query
                    .reply(ke, bytes)
                    .encoding(format.encoding::<Plan>())
                    .wait()
                {
                    tracing::debug!(error = %e, "plan lookup reply failed");
                }
            }
            Err(e) => tracing::warn!(error = %e, "plan lookup: encoding failed"),
        }
    }
}

fn load_plan(path: &Path) -> Result<Plan, ServiceError> {
    let bytes = std::fs::read(path).map_err(|e| ServiceError::io(path, e))?;
    envelope::decode::<Plan>(
        &bytes,
        &DecodeLimits {
            max_body_bytes: MAX_PLAN_BYTES,
            verify_crc: true,
        },
    )
    .map(|e| e.message)
    .map_err(|error| ServiceError::Codec {
        what: path.display().to_string(),
        error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::ServiceStatus;
    use bridge::{Message, ZenohArgs};
    use std::time::Instant;

    /// A plan lookup whose payload is not a `PlanLookup` is refused with a typed
    /// `bad_request` (in the lookup's format), counted as malformed.
    #[test]
    fn bad_plan_lookups_get_a_typed_refusal() {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .unwrap()
            .port();
        let ep = format!("tcp/127.0.0.1:{port}");
        let a = ZenohNode::open(
            ZenohArgs::isolated(std::slice::from_ref(&ep), &[])
                .to_config()
                .unwrap(),
            "test",
            "cache",
        )
        .unwrap();
        let b = ZenohNode::open(
            ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[ep])
                .to_config()
                .unwrap(),
            "test",
            "asker",
        )
        .unwrap();
        let cache = PlanCache::new(&a, None).unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        for format in [WireFormat::Bincode, WireFormat::Json] {
            let opts = QueryOptions {
                format,
                timeout: Duration::from_secs(2),
                ..QueryOptions::default()
            };
            let e = loop {
                match b.query_one::<ServiceStatus, Plan>(
                    "cellsar/0000000000000001/plan",
                    &ServiceStatus::default(),
                    &opts,
                ) {
                    Err(bridge::NetError::NoReply { .. }) if Instant::now() < deadline => {
                        std::thread::sleep(Duration::from_millis(50));
                    }
                    r => break r.unwrap_err(),
                }
            };
            match e {
                bridge::NetError::Refused { refusal, .. } => {
                    assert_eq!(refusal.kind, RefusalKind::BadRequest, "{format:?}");
                    assert!(
                        refusal.message.starts_with("bad plan lookup: ")
                            && refusal.message.contains(PlanLookup::NAME),
                        "{refusal:?}"
                    );
                }
                e => panic!("{format:?}: {e:?}"),
            }
        }
        assert_eq!(cache.malformed(), 2);
        drop(cache);
        a.close().unwrap();
        b.close().unwrap();
    }
}
