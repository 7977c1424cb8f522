//! Best effort under the general resolution (docs/user-guide.md, "Resolution"): the default
//! mission, whose cell cannot be held within d_min everywhere from its start, gets the plan with
//! the least resolution deficit, measured on the exact geometry; an energy cap holds; a mission
//! with a strict general plan gets that plan.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use planner::evaluate::{Dynamics, ResolutionMode, ACCEL_MARGIN_REL};
use planner::shortfall::ResolutionShortfall;
use planner::{evaluate, plan, Mission, PlanOptions, Preset};

fn best_effort(max_extra_energy_pct: Option<f64>) -> PlanOptions {
    PlanOptions {
        resolution: ResolutionMode::General,
        max_extra_energy_pct,
        ..Default::default()
    }
}

/// [`best_effort`] under the paper's vehicle model (the velocity may jump).
fn paper_best_effort(max_extra_energy_pct: Option<f64>) -> PlanOptions {
    PlanOptions {
        dynamics: Dynamics::Paper,
        ..best_effort(max_extra_energy_pct)
    }
}

/// The default mission under the vehicle limits (the default): every plan is flyable in every
/// slot; the best effort leaves 3 of the 30 windows (34 slots) unresolved by the longest chord,
/// where the least-energy flyable plan leaves 15 (298 slots), and within 10 % more energy at
/// most half of those.
#[test]
fn default_mission_flyable_best_effort_leaves_three_windows_and_half_of_them_within_ten_percent() {
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let limit = m.params().max_accel_mps2 * (1.0 + ACCEL_MARGIN_REL);
    let least = plan(&m, &PlanOptions::least_energy()).unwrap();
    assert_eq!(least.dynamics, Dynamics::Vehicle);
    let best = plan(&m, &best_effort(None)).unwrap();
    assert_eq!(best.dynamics, Dynamics::Vehicle);
    let ev = evaluate(&m, &best.trajectory);
    assert!(
        ev.is_feasible_with(ResolutionMode::Paper, Dynamics::Vehicle),
        "{:?}",
        ev.violations
    );
    let before = ResolutionShortfall::new(&m, &least.evaluation);
    let after = ResolutionShortfall::new(&m, &ev);
    assert_eq!(before.unresolved_windows, 15);
    assert!(
        after.unresolved_windows <= 3 && after.unresolved_slots <= 40,
        "{} unresolved windows, {} slots",
        after.unresolved_windows,
        after.unresolved_slots
    );
    assert!(
        after.total_deficit_m < 0.15 * before.total_deficit_m,
        "deficit {} m against {} m",
        after.total_deficit_m,
        before.total_deficit_m
    );
    let extra = ev.energy_j / least.evaluation.energy_j - 1.0;
    assert!(
        (0.0..=0.35).contains(&extra),
        "{:.2} % more energy",
        100.0 * extra
    );
    let capped = plan(&m, &best_effort(Some(10.0))).unwrap();
    let ev10 = evaluate(&m, &capped.trajectory);
    assert!(ev10.energy_j <= least.evaluation.energy_j * 1.10 * (1.0 + 1e-9));
    let within = ResolutionShortfall::new(&m, &ev10);
    assert!(
        within.unresolved_windows <= before.unresolved_windows / 2,
        "{} unresolved windows within 10 %",
        within.unresolved_windows
    );
    // flyable in every slot, judged on the exact geometry from the mission's start velocity
    for (name, e) in [
        ("least energy", &least.evaluation),
        ("best effort", &ev),
        ("capped", &ev10),
    ] {
        for s in &e.slots {
            assert!(
                s.accel_mps2 <= limit,
                "{name}: slot {} at {} m/s²",
                s.t,
                s.accel_mps2
            );
        }
    }
}

/// The same under the paper's model, whose plans may change velocity at will.
#[test]
fn default_mission_best_effort_leaves_two_windows_and_half_of_them_within_ten_percent() {
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let least = plan(
        &m,
        &PlanOptions {
            dynamics: Dynamics::Paper,
            ..PlanOptions::least_energy()
        },
    )
    .unwrap();
    let best_effort = paper_best_effort;
    let best = plan(&m, &best_effort(None)).unwrap();
    // judged again on the exact geometry, independently of the planner's own evaluation
    let ev = evaluate(&m, &best.trajectory);
    assert!(ev.is_feasible(), "{:?}", ev.violations);
    assert!(best.is_feasible());
    let info = best.best_effort.as_ref().expect("a best-effort plan");
    let refusal = info
        .strict_refusal
        .as_deref()
        .expect("the strict plan is refused");
    assert!(refusal.contains("slot"), "{refusal}");
    assert!((info.least_energy_j - least.evaluation.energy_j).abs() < 1e-6);
    let before = ResolutionShortfall::new(&m, &least.evaluation);
    let after = ResolutionShortfall::new(&m, &ev);
    assert_eq!(info.least_energy_shortfall, before);
    // by the cell's longest chord, the least-energy plan leaves 15 of the 30 windows (297
    // slots) unresolved; the best effort 2 (30 slots)
    assert_eq!(before.unresolved_windows, 15);
    assert!(
        after.unresolved_windows <= 2,
        "{} unresolved windows, {} slots",
        after.unresolved_windows,
        after.unresolved_slots
    );
    assert!(after.unresolved_slots <= 40, "{}", after.unresolved_slots);
    assert!(
        after.total_deficit_m < 0.1 * before.total_deficit_m,
        "deficit {} m against {} m",
        after.total_deficit_m,
        before.total_deficit_m
    );
    let extra = ev.energy_j / least.evaluation.energy_j - 1.0;
    assert!(
        (0.0..=0.35).contains(&extra),
        "{:.2} % more energy",
        100.0 * extra
    );
    // within 10 % more energy: at most half of the least-energy plan's unresolved windows
    let capped = plan(&m, &best_effort(Some(10.0))).unwrap();
    let ev10 = evaluate(&m, &capped.trajectory);
    assert!(ev10.is_feasible(), "{:?}", ev10.violations);
    assert!(ev10.energy_j <= least.evaluation.energy_j * 1.10 * (1.0 + 1e-9));
    let within = ResolutionShortfall::new(&m, &ev10);
    assert!(
        within.unresolved_windows <= before.unresolved_windows / 2,
        "{} unresolved windows within 10 %",
        within.unresolved_windows
    );
    assert!(within.total_deficit_m > after.total_deficit_m);
    // a strict request still finds no plan (and proves nothing: not a refusal)
    let strict = PlanOptions {
        strict_resolution: true,
        ..best_effort(None)
    };
    assert!(matches!(
        plan(&m, &strict),
        Err(planner::PlanError::NotFound(_))
    ));
}

#[test]
fn an_energy_cap_holds_on_the_exact_geometry() {
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let capped = plan(&m, &best_effort(Some(1.0))).unwrap();
    let info = capped.best_effort.as_ref().unwrap();
    let ev = evaluate(&m, &capped.trajectory);
    assert!(ev.is_feasible());
    assert!(
        ev.energy_j <= info.least_energy_j * 1.01 + 1e-6,
        "{} J against a cap of {} J",
        ev.energy_j,
        info.least_energy_j * 1.01
    );
    let after = ResolutionShortfall::new(&m, &ev);
    assert!(after.total_deficit_m < info.least_energy_shortfall.total_deficit_m);
    assert!(plan(&m, &best_effort(Some(-1.0))).is_err());
}

#[test]
fn a_mission_with_a_strict_general_plan_gets_it() {
    let m = common::far_start_mission();
    let best = plan(&m, &best_effort(None)).unwrap();
    let ev = evaluate(&m, &best.trajectory);
    assert!(ev.is_feasible_for(ResolutionMode::General));
    let s = ResolutionShortfall::new(&m, &ev);
    assert_eq!((s.unresolved_slots, s.unresolved_windows), (0, 0));
    assert_eq!(s.first_unresolved_slot, None);
    let info = best.best_effort.as_ref().unwrap();
    assert_eq!(info.strict_refusal, None);
    assert!(ev.energy_j >= info.least_energy_j);
}

#[test]
fn the_tradeoff_curve_meets_its_caps_and_never_loses_resolution() {
    use planner::tradeoff::{tradeoff, UNUSED_CAP_PCT};
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let caps = [1.0, 5.0];
    let points = tradeoff(&m, &PlanOptions::least_energy(), &caps).unwrap();
    assert_eq!(points.len(), caps.len() + 2);
    assert_eq!(points[0].cap_pct, Some(0.0));
    assert_eq!(points[0].extra_energy_pct, 0.0);
    assert_eq!(points.last().unwrap().cap_pct, None);
    let least_j = points[0].plan.evaluation.energy_j;
    let mut deficit = f64::INFINITY;
    for (i, p) in points.iter().enumerate() {
        // judged again on the exact geometry
        let ev = evaluate(&m, &p.plan.trajectory);
        assert!(ev.is_feasible(), "point {i}: {:?}", ev.violations);
        if let Some(cap) = p.cap_pct {
            assert!(
                ev.energy_j <= least_j * (1.0 + cap / 100.0) * (1.0 + 1e-9),
                "point {i}: {} J over its cap of {cap} %",
                ev.energy_j
            );
        }
        let s = ResolutionShortfall::new(&m, &ev);
        assert_eq!(s, p.shortfall);
        assert!(
            s.total_deficit_m <= deficit * (1.0 + 1e-9),
            "point {i}: deficit {} after {deficit}",
            s.total_deficit_m
        );
        deficit = s.total_deficit_m;
    }
    // the best effort resolves more than the least-energy plan within 1 %
    assert!(points[1].shortfall.total_deficit_m < points[0].shortfall.total_deficit_m);
    // a cap that a point stays well below is not used: the larger caps repeat its plan
    for w in points.windows(2).skip(1) {
        if let Some(cap) = w[0].cap_pct {
            if cap - w[0].extra_energy_pct > UNUSED_CAP_PCT {
                assert_eq!(w[1].plan.trajectory.pos_m, w[0].plan.trajectory.pos_m);
            }
        }
    }
}
