//! Why the paper's default mission cannot be flown with `--resolution general` from its start, and
//! that it can from another (docs/user-guide.md, "Resolution: paper or general"):
//! the allowed heading arcs of the default geometry, and the planner's named refusal.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use planner::evaluate::ResolutionMode;
use planner::geometry::{heading_unit, Point2, ResolutionCell, RIGHT_TURN};
use planner::{plan, Mission, Params, PlanError, PlanOptions, Preset};

/// Headings (whole degrees) at which a UAV flying at `speed_mps` with the landmark at the
/// centre of its sensing circle sees a cell no wider than d_min, as closed arcs [from, to].
fn allowed_arcs_deg(p: &Params, landmark: [f64; 2], speed_mps: f64) -> Vec<(u32, u32)> {
    let ok = |deg: u32| {
        let h = f64::from(deg).to_radians();
        let u = heading_unit(h);
        // the sensing centre is `centre_offset_m` to the right of the UAV
        let uav = Point2::from(landmark) - RIGHT_TURN * u * p.centre_offset_m();
        ResolutionCell::new(p, uav.into(), (u * speed_mps).into(), landmark).worst_width_m
            <= p.d_min_m
    };
    let mut arcs = Vec::new();
    let mut start = None;
    for deg in 0..=360u32 {
        match (ok(deg % 360), start) {
            (true, None) => start = Some(deg),
            (false, Some(s)) => {
                arcs.push((s, deg - 1));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        arcs.push((s, 360));
    }
    arcs
}

#[test]
fn blind_arcs_around_north_and_east_at_the_default_geometry() {
    let p = Params::default();
    // the figures quoted in README.md
    assert_eq!(
        allowed_arcs_deg(&p, [0.0, 0.0], 15.0),
        vec![(24, 66), (126, 324)]
    );
    assert_eq!(
        allowed_arcs_deg(&p, [0.0, 0.0], 30.0),
        vec![(15, 75), (107, 343)]
    );
    // heading north and heading east are blind at every speed up to V_m
    for v in [8.0, 15.0, 22.0, 30.0] {
        for a in allowed_arcs_deg(&p, [0.0, 0.0], v) {
            assert!(
                !(a.0..=a.1).contains(&0) && !(a.0..=a.1).contains(&90),
                "{v}: {a:?}"
            );
        }
    }
}

#[test]
fn first_landmark_is_seen_from_the_default_start_only_near_the_blind_arc() {
    // From the default start (−1000, −500) the first landmark (0, 0) is within r_s of the
    // sensing centre in slot 1 (the UAV moves at most V_m δ = 15 m) only for headings of
    // about 106–127°: the low edge of the large allowed arc, next to the blind arc around north.
    let p = Params::default();
    let step = p.max_speed_mps * p.slot_s;
    let seen: Vec<u32> = (0..360u32)
        .filter(|&deg| {
            let h = f64::from(deg).to_radians();
            let u = heading_unit(h);
            let q = Point2::from(p.start_m) + u * step;
            let c = q + RIGHT_TURN * u * p.centre_offset_m();
            c.coords.norm() <= p.sensing_radius_m
        })
        .collect();
    let (lo, hi) = (*seen.first().unwrap(), *seen.last().unwrap());
    assert!(
        (100..=110).contains(&lo) && (120..=130).contains(&hi),
        "{lo}..{hi}"
    );
}

#[test]
fn default_mission_under_strict_general_resolution_is_not_found_naming_an_early_slot() {
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let options = PlanOptions {
        resolution: ResolutionMode::General,
        strict_resolution: true,
        ..Default::default()
    };
    match plan(&m, &options) {
        Err(PlanError::NotFound(i)) => {
            // within the first three landmark windows (30 s = 60 slots)
            assert!(i.slot >= 1 && i.slot <= 60, "slot {}: {}", i.slot, i.reason);
            assert!(i.reason.contains("resolution"), "{}", i.reason);
            // after the coarse start, the guidance start and the best effort's plan
            assert!(i.starts >= 3, "{i}");
            let best = i.best.as_ref().expect("the best plan found");
            assert!(!best.is_feasible());
            // it violates what it says it violates, at the slot it names
            let s = &best.evaluation.slots[i.slot - 1];
            let p = m.params();
            assert!(
                !s.in_view
                    || s.worst_width_m > p.d_min_m + 1e-4
                    || s.speed_mps < p.min_speed_mps() - 1e-4
                    || s.accel_mps2 > p.max_accel_mps2 * (1.0 + 1e-7),
                "slot {}: {s:?}",
                i.slot
            );
            assert!(i.to_string().contains("not proven impossible"), "{i}");
        }
        Ok(r) => panic!(
            "a general-resolution plan of the default mission was found ({} J): the user \
             guide's 'Resolution' and 'Refusals' sections say none is found; update them",
            r.evaluation.energy_j
        ),
        Err(e) => panic!("unexpected error: {e}"),
    }
}

#[test]
fn default_mission_from_the_far_end_of_the_allowed_arc_has_a_general_plan() {
    // The same 30 landmarks and windows, started at (342, 940) m, where slot 1 sees landmark 1
    // with a heading near 330°, at the far end of the allowed arc. Flying about 13 m/s the
    // clockwise turn (about V/D rad/s) fits into the arc: every landmark slot is resolved under
    // the general cell, at about 8 % more energy than the paper's resolution needs from the same
    // start (which reaches the floor). (Earlier versions of README.md said this start failed at
    // t = 196.5 s.)
    let m = common::far_start_mission();
    let general = plan(
        &m,
        &PlanOptions {
            resolution: ResolutionMode::General,
            strict_resolution: true,
            ..Default::default()
        },
    )
    .unwrap();
    let ev = &general.evaluation;
    assert!(ev.is_feasible_for(ResolutionMode::General));
    assert_eq!(ev.slots_unresolved, 0);
    let worst = ev
        .slots
        .iter()
        .filter(|s| s.landmark_m.is_some())
        .map(|s| s.worst_width_m)
        .fold(0.0, f64::max);
    assert!(worst <= m.params().d_min_m + 1e-4, "worst cell {worst} m");
    let paper = plan(&m, &PlanOptions::least_energy()).unwrap();
    let cost = ev.energy_j / paper.evaluation.energy_j - 1.0;
    assert!(
        cost > 0.0 && cost < 0.15,
        "general costs {:.1} %",
        100.0 * cost
    );
}
