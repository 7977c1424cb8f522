//! Which missions the processor takes on: only those that a launcher (or any client collecting
//! results) asks for, with a result request on `cellsar/<m>/results`, not every plan that is
//! published, so that plans made for others (a peer flooding the planner with requests, say)
//! cannot crowd out the mission being collected. A mission asked for whose plan is not held
//! is *wanted*: its plan is looked up (`cellsar/<m>/plan`, answered by every process that
//! holds it), and taken when published, whichever comes first. The last few plans published
//! are kept aside ([`MAX_OFFERED`]), not taken on: the launcher asks for its mission just
//! after the planner published its plan, which is then at hand without a lookup.

use std::collections::VecDeque;
use std::time::Duration;

use bridge::envelope::DecodeLimits;
use bridge::net::{PendingQuery, QueryOptions};
use bridge::zenoh::query::QueryTarget;
use bridge::{MissionId, ZenohNode};

use crate::protocol::keys as pkeys;
use crate::protocol::{Plan, PlanLookup, MAX_PLAN_BYTES};
use crate::services::plan::Lru;

/// Missions wanted at once; asking for another forgets the one asked for least recently.
pub(super) const MAX_WANTED: usize = 16;

/// Plan lookups in flight at once; a mission asked for beyond them is looked up when it is
/// asked for again (or taken when its plan is published).
pub(super) const MAX_LOOKUPS: usize = 4;

/// Plans published lately kept aside for a request that may follow, at most (and at most
/// [`MAX_PLAN_BYTES`] of them, encoded, together); the least recent goes first.
pub(super) const MAX_OFFERED: usize = 4;

/// How long a plan lookup waits for its replies.
const LOOKUP_TIMEOUT: Duration = Duration::from_secs(2);

/// The missions asked for whose plan is not held, their lookups in flight, and the plans
/// published lately.
pub(super) struct Wanted {
    /// Most recently asked for last.
    ids: VecDeque<MissionId>,
    lookups: Vec<(MissionId, PendingQuery<Plan>)>,
    offered: Lru<Plan>,
}

impl Default for Wanted {
    fn default() -> Self {
        Wanted {
            ids: VecDeque::new(),
            lookups: Vec::new(),
            offered: Lru::new(MAX_OFFERED, MAX_PLAN_BYTES),
        }
    }
}

impl Wanted {
    /// A plan published (`bytes` its encoded body): given back if its mission is wanted,
    /// else kept aside.
    pub(super) fn published(&mut self, plan: Plan, bytes: usize) -> Option<Plan> {
        let id = plan.mission_id;
        if self.ids.contains(&id) {
            return Some(plan);
        }
        self.offered.insert(id, plan, bytes);
        None
    }

    /// Notes that mission `id` was asked for: its plan if it was published lately, else
    /// `None` and its plan is looked up, unless a lookup of it, or [`MAX_LOOKUPS`] lookups,
    /// are in flight.
    pub(super) fn ask(&mut self, node: &ZenohNode, id: MissionId) -> Option<Plan> {
        if let Some(plan) = self.offered.remove(id) {
            return Some(plan);
        }
        self.ids.retain(|m| *m != id);
        self.ids.push_back(id);
        while self.ids.len() > MAX_WANTED {
            if let Some(old) = self.ids.pop_front() {
                self.lookups.retain(|(m, _)| *m != old);
            }
        }
        if self.lookups.len() >= MAX_LOOKUPS || self.lookups.iter().any(|(m, _)| *m == id) {
            return None;
        }
        let opts = QueryOptions {
            timeout: LOOKUP_TIMEOUT,
            target: QueryTarget::All,
            limits: DecodeLimits {
                max_body_bytes: MAX_PLAN_BYTES,
                verify_crc: true,
            },
            ..QueryOptions::default()
        };
        let started = pkeys::plan(id).map_err(|e| e.to_string()).and_then(|key| {
            node.start_query::<PlanLookup, Plan>(&key, &PlanLookup {}, &opts)
                .map_err(|e| e.to_string())
        });
        match started {
            Ok(q) => {
                tracing::info!(mission = %id, "mission asked for: looking its plan up");
                self.lookups.push((id, q));
            }
            Err(e) => tracing::warn!(mission = %id, error = %e, "plan lookup not sent"),
        }
        None
    }

    /// The plans that the lookups found, each of the mission it was looked up for and
    /// consistent with its id (a reply of another mission is skipped; one whose mission id is
    /// not its content's is counted in `inconsistent`, logged and skipped, and the lookup goes
    /// on for the holders' replies); lookups that ended are dropped, their missions still
    /// wanted.
    pub(super) fn found(&mut self, inconsistent: &mut u64) -> Vec<Plan> {
        let mut found = Vec::new();
        self.lookups.retain_mut(|(id, q)| loop {
            match q.poll(Duration::ZERO) {
                None => break true,
                Some(Ok(r)) if r.message.mission_id == *id => {
                    if crate::services::plan::id_consistent(&r.message, inconsistent) {
                        found.push(r.message);
                        break false;
                    }
                }
                Some(Ok(r)) => tracing::warn!(mission = %id, got = %r.message.mission_id,
                    "plan lookup: a reply of another mission skipped"),
                Some(Err(e)) => {
                    tracing::debug!(mission = %id, error = %e, "plan lookup ended without the plan");
                    break false;
                }
            }
        });
        found
    }

    /// Mission `id` is no longer wanted (its plan is held, or was refused).
    pub(super) fn forget(&mut self, id: MissionId) {
        self.ids.retain(|m| *m != id);
        self.lookups.retain(|(m, _)| *m != id);
    }
}

#[cfg(test)]
mod tests {
    use bridge::ZenohArgs;
    use planner::{MissionFile, NoObserver};

    use super::*;
    use crate::protocol::PlanRequest;
    use crate::services::plan::plan_request;

    /// The plan of a small mission, planned here, under each of the ids `ids`.
    fn plans(ids: impl IntoIterator<Item = u64>) -> Vec<Plan> {
        let req = PlanRequest {
            mission: MissionFile::from_toml_str(
                "name = \"wanted\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{ x_m = \
                 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }]\n",
            )
            .unwrap(),
            options: Default::default(),
        };
        let plan = plan_request(&req, "p", &mut NoObserver).unwrap();
        ids.into_iter()
            .map(|n| Plan {
                mission_id: MissionId(n),
                ..plan.clone()
            })
            .collect()
    }

    /// The ids of the plans kept aside, in increasing order.
    fn offered(w: &Wanted) -> Vec<u64> {
        let mut ids: Vec<u64> = w.offered.values().map(|p| p.mission_id.0).collect();
        ids.sort_unstable();
        ids
    }

    /// At most [`MAX_OFFERED`] plans published are kept aside, the least recently published
    /// dropped first (a plan published again is the most recent); one asked for is given
    /// back without a lookup, one dropped is looked up and taken when published again.
    #[test]
    fn plans_kept_aside_are_bounded_by_count_the_least_recently_published_first() {
        assert_eq!(MAX_OFFERED, 4);
        let node = ZenohNode::open(
            ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[])
                .to_config()
                .unwrap(),
            "test",
            "wanted",
        )
        .unwrap();
        let mut w = Wanted::default();
        let mut all = plans(1..=8).into_iter();
        let mut plan = || all.next().unwrap();
        let (p1, p2, p3) = (plan(), plan(), plan());
        for p in [p1.clone(), p2, p3.clone(), plan(), plan(), plan()] {
            assert!(w.published(p, 1000).is_none());
        }
        assert_eq!(offered(&w), [3, 4, 5, 6]);
        assert_eq!(w.offered.bytes(), 4000);
        // 3 published again: 4 is now the least recent and goes for 7
        assert!(w.published(p3, 1000).is_none());
        assert!(w.published(plan(), 1000).is_none());
        assert_eq!(offered(&w), [3, 5, 6, 7]);
        // asked for: given back from those kept aside, no longer kept
        let got = w.ask(&node, MissionId(5)).unwrap();
        assert_eq!(got.mission_id, MissionId(5));
        assert_eq!(offered(&w), [3, 6, 7]);
        assert!(w.lookups.is_empty());
        // 1 was dropped: asked for, it is looked up, wanted, and taken when published
        assert!(w.ask(&node, MissionId(1)).is_none());
        assert_eq!(w.lookups.len(), 1);
        assert_eq!(w.published(p1, 1000).unwrap().mission_id, MissionId(1));
        assert_eq!(offered(&w), [3, 6, 7]);
        w.forget(MissionId(1));
        assert!(w.lookups.is_empty() && w.ids.is_empty());
        // a plan of a mission nobody asked for is kept aside again
        assert!(w.published(plan(), 1000).is_none());
        assert_eq!(offered(&w), [3, 6, 7, 8]);
        drop(w);
        node.close().unwrap();
    }

    /// The plans kept aside hold at most [`MAX_PLAN_BYTES`] encoded together: fewer than
    /// [`MAX_OFFERED`] when they are large, the least recently published dropped first.
    #[test]
    fn plans_kept_aside_are_bounded_by_bytes_the_least_recently_published_first() {
        assert_eq!(MAX_PLAN_BYTES, 64 << 20);
        let mut w = Wanted::default();
        let third = MAX_PLAN_BYTES / 3;
        let mut all = plans(1..=6).into_iter();
        let mut plan = || all.next().unwrap();
        for _ in 0..3 {
            assert!(w.published(plan(), third).is_none());
        }
        assert_eq!(offered(&w), [1, 2, 3]);
        // a fourth third does not fit: 1 goes
        assert!(w.published(plan(), third).is_none());
        assert_eq!(offered(&w), [2, 3, 4]);
        assert_eq!(w.offered.bytes(), 3 * third);
        // a plan of the whole bound: every other goes
        assert!(w.published(plan(), MAX_PLAN_BYTES).is_none());
        assert_eq!(offered(&w), [5]);
        assert_eq!(w.offered.bytes(), MAX_PLAN_BYTES);
        // a small one after it: the large one goes
        assert!(w.published(plan(), 1).is_none());
        assert_eq!(offered(&w), [6]);
        assert!(w.offered.bytes() <= MAX_PLAN_BYTES);
    }
}
