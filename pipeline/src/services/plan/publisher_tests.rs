//! The per-mission publishers are bounded ([`MAX_MISSION_PUBLISHERS`]): the planner's plan and
//! summary publishers and every service's status publishers, over more missions than the
//! bound, keep at most the bound, the least recently used undeclared first, and a mission whose
//! publisher went is published again through a new one.

use std::sync::Arc;
use std::time::Duration;

use bridge::envelope::Meta;
use bridge::net::SubscribeOptions;
use bridge::{MissionId, ZenohArgs, ZenohNode};
use planner::{MissionFile, NoObserver};

use super::*;
use crate::protocol::keys as pkeys;
use crate::protocol::{PlanRequest, PlanSummary, Role, ServiceState, ServiceStatus};

/// Missions published, more than [`MAX_MISSION_PUBLISHERS`].
const MISSIONS: u64 = 100;

const _: () = assert!(MISSIONS as usize > MAX_MISSION_PUBLISHERS);

fn node(name: &str) -> ZenohNode {
    ZenohNode::open(
        ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[])
            .to_config()
            .unwrap(),
        "test",
        name,
    )
    .unwrap()
}

/// The plan of a small mission, planned here.
fn small_plan() -> Plan {
    let req = PlanRequest {
        mission: MissionFile::from_toml_str(
            "name = \"pubs\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{ x_m = 0.0, \
             y_m = 0.0, from_s = 0.0, to_s = 10.0 }, { x_m = 0.0, y_m = 30.0, from_s = 10.0, \
             to_s = 20.0 }]\n",
        )
        .unwrap(),
        options: Default::default(),
    };
    plan_request(&req, "p", &mut NoObserver).unwrap()
}

#[test]
fn the_planners_plan_and_summary_publishers_stay_within_the_bound() {
    let node = node("plan-pubs");
    let plan = small_plan();
    let numbered = |n: u64| Plan {
        mission_id: MissionId(n),
        ..plan.clone()
    };
    let meta = |n: u64| Meta {
        mission_id: MissionId(n),
        ..Meta::default()
    };
    let mut plan_pubs = Lru::with_count(MAX_MISSION_PUBLISHERS);
    let mut summary_pubs = Lru::with_count(MAX_MISSION_PUBLISHERS);
    for n in 1..=MISSIONS {
        publish_plan(
            &node,
            &numbered(n),
            meta(n),
            &mut plan_pubs,
            &mut summary_pubs,
        )
        .unwrap();
        let held = (n as usize).min(MAX_MISSION_PUBLISHERS);
        assert_eq!((plan_pubs.len(), summary_pubs.len()), (held, held), "{n}");
    }
    // the least recently used went: the first missions', the last ones' kept
    let first_kept = MISSIONS - MAX_MISSION_PUBLISHERS as u64 + 1;
    for n in 1..=MISSIONS {
        let kept = n >= first_kept;
        assert_eq!(plan_pubs.peek(MissionId(n)).is_some(), kept, "plan {n}");
        assert_eq!(
            summary_pubs.peek(MissionId(n)).is_some(),
            kept,
            "summary {n}"
        );
    }
    // mission 1's publishers went: its next plan goes out through new ones
    let plans = node
        .subscriber::<Plan>(
            &pkeys::plan(MissionId(1)).unwrap(),
            SubscribeOptions::default(),
        )
        .unwrap();
    let summaries = node
        .subscriber::<PlanSummary>(
            &pkeys::plan_summary(MissionId(1)).unwrap(),
            SubscribeOptions::default(),
        )
        .unwrap();
    publish_plan(
        &node,
        &numbered(1),
        meta(1),
        &mut plan_pubs,
        &mut summary_pubs,
    )
    .unwrap();
    assert!(plan_pubs.peek(MissionId(1)).is_some());
    assert!(summary_pubs.peek(MissionId(1)).is_some());
    assert_eq!(plan_pubs.len(), MAX_MISSION_PUBLISHERS);
    assert_eq!(summary_pubs.len(), MAX_MISSION_PUBLISHERS);
    // ... and mission 1 made room by the least recently used (now mission `first_kept`'s)
    assert!(plan_pubs.peek(MissionId(first_kept)).is_none());
    let got = plans.recv_timeout(Duration::from_secs(5)).expect("no plan");
    assert_eq!(got.message.mission_id, MissionId(1));
    let got = summaries
        .recv_timeout(Duration::from_secs(5))
        .expect("no summary");
    assert_eq!(got.message.mission_id, MissionId(1));
    drop((plans, summaries, plan_pubs, summary_pubs));
    node.close().unwrap();
}

#[test]
fn the_status_publishers_stay_within_the_bound() {
    let node = node("status-pubs");
    let board = Arc::new(StatusBoard::new(Role::Processor, "bounded"));
    for n in 1..=MISSIONS {
        board.publish(&node, &board.status(MissionId(n), ServiceState::Running));
        assert_eq!(
            board.publishers(),
            (n as usize).min(MAX_MISSION_PUBLISHERS),
            "{n}"
        );
    }
    assert!(!board.has_publisher(MissionId(1)));
    assert!(board.has_publisher(MissionId(MISSIONS)));
    let statuses = node
        .subscriber::<ServiceStatus>(
            &pkeys::status(MissionId(1), Role::Processor).unwrap(),
            SubscribeOptions::default(),
        )
        .unwrap();
    board.publish(&node, &board.status(MissionId(1), ServiceState::Done));
    assert!(board.has_publisher(MissionId(1)));
    assert_eq!(board.publishers(), MAX_MISSION_PUBLISHERS);
    let got = statuses
        .recv_timeout(Duration::from_secs(5))
        .expect("no status");
    assert_eq!(
        (got.message.mission_id, got.message.state),
        (MissionId(1), ServiceState::Done)
    );
    drop(statuses);
    node.close().unwrap();
}
