//! The plan cache every process keeps: the plans it holds, answered to lookups and optionally
//! stored in a directory; bounded ([`MAX_HELD_PLANS`], [`MAX_HELD_PLAN_BYTES`]), the least
//! recently used plan evicted first, from memory and from the directory.

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

use super::bounded::{Lru, MAX_HELD_PLANS, MAX_HELD_PLAN_BYTES};
use super::{write_atomic, ServiceError};
use crate::protocol::keys::ALL_PLANS;
use crate::protocol::{Plan, PlanLookup, MAX_PLAN_BYTES};

/// Plans held by a process, answered to `cellsar/*/plan` lookups (so a process that joins late
/// or restarts gets the plans without re-planning; a lookup that is no [`PlanLookup`] gets a
/// typed `bad_request` refusal), optionally persisted in a directory. At most
/// [`MAX_HELD_PLANS`] plans of [`MAX_HELD_PLAN_BYTES`] bytes (encoded) together are held: the
/// least recently used (inserted or got) is evicted first, and its stored file removed.
pub struct PlanCache {
    plans: Arc<Mutex<Lru<Arc<Plan>>>>,
    dir: Option<PathBuf>,
    malformed: Arc<std::sync::atomic::AtomicU64>,
    _queryable: bridge::zenoh::query::Queryable<()>,
}

impl PlanCache {
    /// Declares the lookup queryable on `cellsar/*/plan`; with `dir`, loads the plans stored
    /// there (unreadable files are logged and skipped) and stores new ones.
    pub fn new(node: &ZenohNode, dir: Option<&Path>) -> Result<Self, ServiceError> {
        Self::with_bounds(node, dir, MAX_HELD_PLANS, MAX_HELD_PLAN_BYTES)
    }

    /// As [`PlanCache::new`], at most `max_plans` plans of `max_bytes` bytes together.
    pub fn with_bounds(
        node: &ZenohNode,
        dir: Option<&Path>,
        max_plans: usize,
        max_bytes: usize,
    ) -> Result<Self, ServiceError> {
        let plans = Arc::new(Mutex::new(Lru::new(max_plans, max_bytes)));
        if let Some(d) = dir {
            std::fs::create_dir_all(d).map_err(|e| ServiceError::io(d, e))?;
            // the oldest first, so that the most recently stored are those kept
            let mut files: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(d)
                .map_err(|e| ServiceError::io(d, e))?
                .flatten()
                .map(|entry| entry.path())
                .filter(|path| path.extension().and_then(|e| e.to_str()) == Some("plan"))
                .map(|path| {
                    let t = std::fs::metadata(&path)
                        .and_then(|m| m.modified())
                        .unwrap_or(std::time::UNIX_EPOCH);
                    (t, path)
                })
                .collect();
            files.sort();
            let mut restored = 0usize;
            if let Ok(mut held) = plans.lock() {
                for (_, path) in files {
                    match load_plan(&path) {
                        Ok((p, bytes)) => {
                            let evicted = held.insert(p.mission_id, Arc::new(p), bytes);
                            remove_stored(d, &evicted);
                            restored += 1;
                        }
                        Err(e) => {
                            tracing::warn!(file = %path.display(), error = %e,
                                "stored plan skipped")
                        }
                    }
                }
                if restored > 0 {
                    tracing::info!(plans = held.len(), dir = %d.display(), "plans restored");
                }
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
        let evicted = match self.plans.lock() {
            Ok(mut p) => p.insert(plan.mission_id, plan.clone(), bytes.len()),
            Err(_) => Vec::new(),
        };
        if !evicted.is_empty() {
            tracing::info!(evicted = evicted.len(), "least recently used plans let go");
        }
        if let Some(d) = &self.dir {
            remove_stored(d, &evicted);
            if !evicted.contains(&plan.mission_id) {
                write_atomic(&stored_path(d, plan.mission_id), &bytes)?;
            }
        }
        Ok(())
    }

    /// Lets go of the plan of `id` (no longer answered to lookups; a stored copy stays).
    pub fn remove(&self, id: MissionId) {
        if let Ok(mut p) = self.plans.lock() {
            p.remove(id);
        }
    }

    /// The plan of `id`, if held (now the most recently used).
    pub fn get(&self, id: MissionId) -> Option<Arc<Plan>> {
        self.plans
            .lock()
            .ok()
            .and_then(|mut p| p.get(id).map(|p| p.clone()))
    }

    /// Every plan held.
    pub fn all(&self) -> Vec<Arc<Plan>> {
        self.plans
            .lock()
            .map(|p| p.values().cloned().collect())
            .unwrap_or_default()
    }

    /// How many plans are held, and their bytes (encoded).
    pub fn held(&self) -> (usize, usize) {
        self.plans
            .lock()
            .map(|p| (p.len(), p.bytes()))
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
        let opts = lookup_options(timeout);
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

    /// Asks every process for the plan of mission `id` (`cellsar/<id>/plan`) and gives the
    /// first reply whose content gives `id` ([`super::id_consistent`]), waiting at most
    /// `timeout`. Replies are not consolidated, so that one holder's plan cannot hide
    /// another's: a reply of another mission, or one whose mission id is not its content's (a
    /// forgery, counted in `inconsistent` and logged), is skipped and the next one read.
    /// `None` when no reply gives the plan (a failed lookup is logged).
    pub fn lookup_consistent(
        node: &ZenohNode,
        id: MissionId,
        timeout: Duration,
        inconsistent: &mut u64,
    ) -> Option<Plan> {
        let opts = lookup_options(timeout);
        let started = crate::protocol::keys::plan(id)
            .map_err(|e| e.to_string())
            .and_then(|key| {
                node.start_query::<PlanLookup, Plan>(&key, &PlanLookup {}, &opts)
                    .map_err(|e| e.to_string())
            });
        let mut pending = match started {
            Ok(q) => q,
            Err(e) => {
                tracing::warn!(mission = %id, error = %e, "plan lookup not sent");
                return None;
            }
        };
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match pending.poll(left.min(Duration::from_millis(50))) {
                None if left.is_zero() => return None,
                None => {}
                Some(Ok(r)) if r.message.mission_id != id => {
                    tracing::warn!(mission = %id, got = %r.message.mission_id,
                        "plan lookup: a reply of another mission skipped");
                }
                Some(Ok(r)) if super::id_consistent(&r.message, inconsistent) => {
                    return Some(r.message);
                }
                // a forgery: counted and logged, the next reply read
                Some(Ok(_)) => {}
                Some(Err(e)) => {
                    tracing::debug!(mission = %id, error = %e, "plan lookup ended without the plan");
                    return None;
                }
            }
        }
    }
}

/// Where the plan of `id` is stored in `dir`.
fn stored_path(dir: &Path, id: MissionId) -> PathBuf {
    dir.join(format!("{id}.plan"))
}

/// Removes the stored plans of `ids` from `dir` (one already gone is no error).
fn remove_stored(dir: &Path, ids: &[MissionId]) {
    for id in ids {
        let path = stored_path(dir, *id);
        if let Err(e) = std::fs::remove_file(&path) {
            if e.kind() != std::io::ErrorKind::NotFound {
                tracing::warn!(file = %path.display(), error = %e, "evicted plan not removed");
            }
        }
    }
}

fn answer_lookup(
    plans: &Mutex<Lru<Arc<Plan>>>,
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

/// A stored plan and its size in bytes.
fn load_plan(path: &Path) -> Result<(Plan, usize), ServiceError> {
    // no more than the largest plan accepted is read
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(
        &mut std::io::Read::take(
            std::fs::File::open(path).map_err(|e| ServiceError::io(path, e))?,
            (MAX_PLAN_BYTES + envelope::HEADER_LEN + 1) as u64,
        ),
        &mut bytes,
    )
    .map_err(|e| ServiceError::io(path, e))?;
    envelope::decode::<Plan>(
        &bytes,
        &DecodeLimits {
            max_body_bytes: MAX_PLAN_BYTES,
            verify_crc: true,
        },
    )
    .map(|e| (e.message, bytes.len()))
    .map_err(|error| ServiceError::Codec {
        what: path.display().to_string(),
        error,
    })
}

/// The options of a plan lookup: every holder asked, each reply bounded by the largest plan
/// and its checksum verified.
fn lookup_options(timeout: Duration) -> QueryOptions {
    QueryOptions {
        timeout,
        target: QueryTarget::All,
        limits: DecodeLimits {
            max_body_bytes: MAX_PLAN_BYTES,
            verify_crc: true,
        },
        ..QueryOptions::default()
    }
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

    /// A small plan, planned here.
    fn small_plan(name: &str) -> Plan {
        use crate::protocol::PlanRequest;
        use crate::services::plan::plan_request;
        use planner::{MissionFile, NoObserver};
        let req = PlanRequest {
            mission: MissionFile::from_toml_str(&format!(
                "name = \"{name}\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{{ x_m \
                 = 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }}, {{ x_m = 0.0, y_m = 30.0, \
                 from_s = 10.0, to_s = 20.0 }}]\n",
            ))
            .unwrap(),
            options: Default::default(),
        };
        plan_request(&req, "p", &mut NoObserver).unwrap()
    }

    /// `plan` with its content changed (the mission renamed), its mission id kept.
    fn forged(plan: &Plan) -> Plan {
        let mut f = plan.clone();
        f.mission.name = Some("forged".into());
        f
    }

    /// A plan whose mission id is not its content's is refused, counted once and logged; the
    /// real plan passes, the count unchanged.
    #[test]
    fn a_plan_whose_id_is_not_its_contents_is_counted_and_refused() {
        let plan = small_plan("real");
        let mut inconsistent = 0;
        assert!(crate::services::plan::id_consistent(
            &plan,
            &mut inconsistent
        ));
        assert_eq!(inconsistent, 0);
        let f = forged(&plan);
        assert_eq!(f.mission_id, plan.mission_id);
        assert!(!crate::services::plan::id_consistent(&f, &mut inconsistent));
        assert_eq!(inconsistent, 1);
        // an id of another mission under the real content, too
        let other = Plan {
            mission_id: MissionId(plan.mission_id.0 ^ 1),
            ..plan.clone()
        };
        assert!(!crate::services::plan::id_consistent(
            &other,
            &mut inconsistent
        ));
        assert_eq!(inconsistent, 2);
        assert!(crate::services::plan::id_consistent(
            &plan,
            &mut inconsistent
        ));
        assert_eq!(inconsistent, 2);
    }

    /// A lookup of a mission whose only holder answers a forgery (its content changed, the
    /// mission id kept) finds nothing and counts the forgery; with the real plan held too,
    /// whichever reply comes first, the lookup gives the real plan.
    #[test]
    fn a_lookup_skips_forged_plans_and_takes_the_holders() {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .unwrap()
            .port();
        let ep = format!("tcp/127.0.0.1:{port}");
        let open = |listen: &[String], connect: &[String], name: &str| {
            ZenohNode::open(
                ZenohArgs::isolated(listen, connect).to_config().unwrap(),
                "test",
                name,
            )
            .unwrap()
        };
        let hub = open(std::slice::from_ref(&ep), &[], "asker");
        let forger = open(
            &["tcp/127.0.0.1:0".to_string()],
            std::slice::from_ref(&ep),
            "forger",
        );
        let holder = open(&["tcp/127.0.0.1:0".to_string()], &[ep], "holder");
        let plan = small_plan("looked-up");
        let id = plan.mission_id;
        let forgeries = PlanCache::new(&forger, None).unwrap();
        forgeries.insert(Arc::new(forged(&plan))).unwrap();
        // the forger is reached (the mesh forms within a moment)
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut inconsistent = 0;
        while inconsistent == 0 {
            assert!(Instant::now() < deadline, "the forger never answered");
            let got =
                PlanCache::lookup_consistent(&hub, id, Duration::from_secs(1), &mut inconsistent);
            assert!(got.is_none(), "a forgery taken");
        }
        assert_eq!(inconsistent, 1);
        let holds = PlanCache::new(&holder, None).unwrap();
        holds.insert(Arc::new(plan.clone())).unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        let got = loop {
            assert!(Instant::now() < deadline, "the holder never answered");
            if let Some(p) =
                PlanCache::lookup_consistent(&hub, id, Duration::from_secs(2), &mut inconsistent)
            {
                break p;
            }
        };
        assert_eq!(got, plan);
        assert!(got.id_problem().is_none());
        drop((forgeries, holds));
        for n in [hub, forger, holder] {
            n.close().unwrap();
        }
    }

    /// The cache holds at most its bound of plans, the least recently used evicted first from
    /// memory and from the state directory; a restart restores the most recently stored ones
    /// within the bound and removes the rest.
    #[test]
    fn the_cache_and_its_directory_are_bounded_least_recently_used_first() {
        use crate::protocol::PlanRequest;
        use crate::services::plan::plan_request;
        use planner::{MissionFile, NoObserver};
        let node = ZenohNode::open(
            ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[])
                .to_config()
                .unwrap(),
            "test",
            "bounded",
        )
        .unwrap();
        let req = PlanRequest {
            mission: MissionFile::from_toml_str(
                "name = \"b\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{ x_m = \
                 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }, { x_m = 0.0, y_m = 30.0, from_s = \
                 10.0, to_s = 20.0 }]\n",
            )
            .unwrap(),
            options: Default::default(),
        };
        let plan = plan_request(&req, "p", &mut NoObserver).unwrap();
        let numbered = |n: u64| {
            Arc::new(Plan {
                mission_id: MissionId(n),
                ..plan.clone()
            })
        };
        let dir = tempfile::tempdir().unwrap();
        let stored = || {
            let mut v: Vec<String> = std::fs::read_dir(dir.path())
                .unwrap()
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            v.sort();
            v
        };
        let file = |n: u64| format!("{}.plan", MissionId(n));
        let cache = PlanCache::with_bounds(&node, Some(dir.path()), 3, usize::MAX).unwrap();
        for n in 1..=3 {
            cache.insert(numbered(n)).unwrap();
            std::thread::sleep(Duration::from_millis(20));
        }
        // 1 used again: 2 goes when 4 comes
        assert!(cache.get(MissionId(1)).is_some());
        cache.insert(numbered(4)).unwrap();
        assert!(cache.get(MissionId(2)).is_none());
        let (count, bytes) = cache.held();
        assert_eq!(count, 3);
        let mut want = vec![file(1), file(3), file(4)];
        want.sort();
        assert_eq!(stored(), want);
        // bytes: room for two plans only
        let one = bytes / 3;
        drop(cache);
        let cache = PlanCache::with_bounds(&node, None, 100, 2 * one).unwrap();
        for n in 10..20 {
            cache.insert(numbered(n)).unwrap();
            assert!(cache.held().1 <= 2 * one);
        }
        assert_eq!(cache.held().0, 2);
        drop(cache);
        // a restart with a bound of 2 restores the two most recently stored (3, 4: 1 was
        // stored first) and removes the other file
        let cache = PlanCache::with_bounds(&node, Some(dir.path()), 2, usize::MAX).unwrap();
        assert_eq!(cache.held().0, 2);
        assert!(cache.get(MissionId(3)).is_some() && cache.get(MissionId(4)).is_some());
        let mut want = vec![file(3), file(4)];
        want.sort();
        assert_eq!(stored(), want);
        drop(cache);
        node.close().unwrap();
    }
}
