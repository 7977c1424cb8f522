//! The jerk limit and the margins (docs/user-guide.md, "Vehicle limits"), checked on the plan's
//! positions in closed form, not through the evaluator: the accelerations are second and the
//! jerks third differences of the positions. Each test also plans the same mission without the
//! limit or margin and shows that plan breaking what the test asserts, so the test can fail.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use planner::evaluate::{Dynamics, ResolutionMode, FEASIBILITY_TOL};
use planner::geometry::ResolutionCell;
use planner::{Mission, MissionFile, PlanOptions, PlanResult, Summary};

/// A 30 s mission from rest whose only landmark comes late: the least-energy plan accelerates
/// at the acceleration limit at once and stops accelerating when it reaches its cruise speed.
/// `extra` adds to `[params]`.
fn from_rest(extra: &str) -> Mission {
    let text = format!(
        "name = \"from rest\"\n[params]\nhorizon_s = 30\nstart_m = [-600.0, 0.0]\n\
         start_velocity_mps = [0.0, 0.0]\n{extra}\n[landmarks]\n\
         points = [{{ x_m = 0.0, y_m = 300.0, from_s = 25.0, to_s = 30.0 }}]\n"
    );
    Mission::from_file_struct(&MissionFile::from_toml_str(&text).unwrap()).unwrap()
}

fn least_energy(m: &Mission) -> PlanResult {
    let options = PlanOptions {
        dynamics: Dynamics::Vehicle,
        ..PlanOptions::least_energy()
    };
    planner::plan(m, &options).unwrap()
}

fn strict_general(m: &Mission) -> PlanResult {
    let options = PlanOptions {
        resolution: ResolutionMode::General,
        strict_resolution: true,
        dynamics: Dynamics::Vehicle,
        ..PlanOptions::default()
    };
    planner::plan(m, &options).unwrap()
}

/// q_t, t = 0 (the start) to the last slot.
fn positions(plan: &PlanResult) -> Vec<[f64; 2]> {
    std::iter::once(plan.trajectory.start_m)
        .chain(plan.trajectory.pos_m.iter().copied())
        .collect()
}

/// δ² a_t for every slot t ≥ 1: q_t − 2 q_{t−1} + q_{t−2}, and into the first slot
/// 2 (q₁ − q₀ − v₀ δ), from v₀ at t = 0 over half a slot (q₁ = q₀ + v₀ δ + a δ²/2).
fn scaled_accels(m: &Mission, plan: &PlanResult) -> Vec<[f64; 2]> {
    let q = positions(plan);
    let delta = m.params().slot_s;
    let v0 = m.start_velocity_mps();
    (1..q.len())
        .map(|t| {
            let k = |i: usize| {
                if t == 1 {
                    2.0 * (q[1][i] - q[0][i] - v0[i] * delta)
                } else {
                    q[t][i] - 2.0 * q[t - 1][i] + q[t - 2][i]
                }
            };
            [k(0), k(1)]
        })
        .collect()
}

/// The acceleration of every slot from the positions, m/s².
fn accels_mps2(m: &Mission, plan: &PlanResult) -> Vec<f64> {
    let delta2 = m.params().slot_s.powi(2);
    scaled_accels(m, plan)
        .iter()
        .map(|a| a[0].hypot(a[1]) / delta2)
        .collect()
}

/// The jerk of every slot t ≥ 2 from the positions, m/s³: the third difference
/// ‖q_t − 3 q_{t−1} + 3 q_{t−2} − q_{t−3}‖ / δ³ from the third slot on, and into the second slot
/// the change from the first slot's acceleration, whose time is δ/3 (the mean of its ramp
/// weights), to the second's at δ: over 2δ/3.
fn jerks_mps3(m: &Mission, plan: &PlanResult) -> Vec<f64> {
    let delta = m.params().slot_s;
    let a = scaled_accels(m, plan);
    a.windows(2)
        .enumerate()
        .map(|(i, w)| {
            let window = if i == 0 { 2.0 * delta / 3.0 } else { delta };
            (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / (delta * delta * window)
        })
        .collect()
}

fn largest(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

/// A jerk limit below the plan's own jerk: the limited plan keeps it in every slot, and reaches
/// it (ramping its acceleration up and down at the limit), measured on the positions; the
/// evaluator, summary.json and the feasibility agree.
#[test]
fn a_jerk_limit_is_kept_and_used_measured_on_the_positions() {
    let limit = 4.0;
    let free = least_energy(&from_rest(""));
    let free_jerk = largest(&jerks_mps3(&from_rest(""), &free));
    assert!(free_jerk > 2.0 * limit, "unlimited plan: {free_jerk} m/s³");

    let m = from_rest(&format!("max_jerk_mps3 = {limit}"));
    let plan = least_energy(&m);
    let jerks = jerks_mps3(&m, &plan);
    for (t, j) in (2..).zip(&jerks) {
        assert!(*j <= limit * (1.0 + 1e-9), "slot {t}: {j} m/s³");
        let evaluated = plan.evaluation.slots[t - 1].jerk_mps3;
        assert!(
            (evaluated - j).abs() <= 1e-9 * limit,
            "slot {t}: {evaluated} vs {j}"
        );
    }
    assert!(largest(&jerks) >= 0.99 * limit, "{}", largest(&jerks));
    assert_eq!(plan.evaluation.slots[0].jerk_mps3, 0.0);
    assert!(plan.is_feasible() && plan.evaluation.meets(Dynamics::Vehicle));
    // the unlimited plan is not flyable for this vehicle, and the limit costs energy
    let judged = planner::evaluate(&m, &free.trajectory);
    assert!(!judged.meets(Dynamics::Vehicle) && judged.violations.jerk_mps3 > limit);
    assert!(plan.evaluation.energy_j >= free.evaluation.energy_j - 1e-6);
    let summary = serde_json::to_value(Summary::new(&m, &plan)).unwrap();
    assert_eq!(summary["jerk"]["jerk_limit_mps3"], limit);
    assert_eq!(summary["jerk"]["slots_over_jerk_limit"], 0);
    assert!(summary["jerk"]["max_jerk_mps3"].as_f64().unwrap() <= limit * (1.0 + 1e-9));
    // a mission without a jerk limit has no `jerk` (nor `margins`) in its summary
    let plain = serde_json::to_value(Summary::new(&from_rest(""), &free)).unwrap();
    assert!(plain.get("jerk").is_none() && plain.get("margins").is_none());
}

/// A mission that states its start acceleration (here at rest, not accelerating) bounds the
/// first slot's jerk too: from the acceleration a₀ at t = 0 to the first slot's, whose time is
/// δ/3, the acceleration changes by at most j_max δ/3 (measured on the positions); without it
/// the first slot accelerates at a_max at once.
#[test]
fn a_stated_start_acceleration_bounds_the_first_slots_jerk() {
    let limit = 4.0;
    let delta = from_rest("").params().slot_s;
    let unstated = from_rest(&format!("max_jerk_mps3 = {limit}"));
    let first = accels_mps2(&unstated, &least_energy(&unstated))[0];
    assert!(first > limit * delta / 3.0 * 2.0, "{first} m/s²");

    let m = from_rest(&format!(
        "max_jerk_mps3 = {limit}\nstart_accel_mps2 = [0.0, 0.0]"
    ));
    let plan = least_energy(&m);
    let first = accels_mps2(&m, &plan)[0];
    assert!(first <= limit * delta / 3.0 * (1.0 + 1e-9), "{first} m/s²");
    assert!(
        first >= 0.99 * limit * delta / 3.0,
        "{first} m/s²: the room is used"
    );
    assert!((plan.evaluation.slots[0].jerk_mps3 - first / (delta / 3.0)).abs() < 1e-9);
    for (t, j) in (2..).zip(&jerks_mps3(&m, &plan)) {
        assert!(*j <= limit * (1.0 + 1e-9), "slot {t}: {j} m/s³");
    }
}

/// With a 10 % acceleration margin no slot accelerates above 0.9 a_max, measured on the
/// positions (the plan without it accelerates at a_max); the plan is judged against a_max and
/// reports the room it keeps.
#[test]
fn an_acceleration_margin_keeps_its_room_measured_on_the_positions() {
    let a_max = from_rest("").params().max_accel_mps2;
    let free = least_energy(&from_rest(""));
    assert!(largest(&accels_mps2(&from_rest(""), &free)) > 0.99 * a_max);

    let m = from_rest("accel_margin_pct = 10");
    let plan = least_energy(&m);
    let accels = accels_mps2(&m, &plan);
    for (t, a) in (1..).zip(&accels) {
        assert!(*a <= 0.9 * a_max * (1.0 + 1e-9), "slot {t}: {a} m/s²");
    }
    assert!(largest(&accels) >= 0.89 * a_max, "{}", largest(&accels));
    assert_eq!(plan.evaluation.accel_limit_mps2, a_max);
    let s = Summary::new(&m, &plan);
    assert_eq!(s.accel_limit_mps2, a_max);
    let room = s.margins.expect("a mission with margins reports its room");
    assert_eq!(room.requested_pct, [0.0, 10.0, 0.0]);
    assert!(room.accel_room_pct >= 10.0 - 1e-6, "{room:?}");
}

/// With a 5 % resolution margin every landmark slot of the strict general plan has its cell's
/// worst width within 0.95 d_min, computed from the plan's positions (the plan without it
/// widens some slot beyond 0.95 d_min); judged against d_min, every slot is resolved.
#[test]
fn a_resolution_margin_keeps_its_room_in_every_resolved_slot() {
    let widths = |m: &Mission, plan: &PlanResult| -> Vec<f64> {
        let q = positions(plan);
        let delta = m.params().slot_s;
        (1..q.len())
            .filter_map(|t| {
                let g = m.target_m(t)?;
                let v = [
                    (q[t][0] - q[t - 1][0]) / delta,
                    (q[t][1] - q[t - 1][1]) / delta,
                ];
                Some(ResolutionCell::new(m.params(), q[t], v, g).worst_width_m)
            })
            .collect()
    };
    let d_min = from_rest("").params().d_min_m;
    let free = strict_general(&from_rest(""));
    assert!(largest(&widths(&from_rest(""), &free)) > 0.95 * d_min + FEASIBILITY_TOL);

    let m = from_rest("resolution_margin_pct = 5");
    let plan = strict_general(&m);
    let w = widths(&m, &plan);
    assert_eq!(w.len(), 10);
    for width in &w {
        assert!(*width <= 0.95 * d_min + FEASIBILITY_TOL, "{width} m");
    }
    // the speed keeps the tightened azimuth requirement too: V ≥ V_min / 0.95
    let v_min = m.params().min_speed_mps();
    assert!(plan
        .evaluation
        .slots
        .iter()
        .filter(|s| s.landmark_m.is_some())
        .all(|s| s.speed_mps >= v_min / 0.95 - FEASIBILITY_TOL));
    assert_eq!(plan.evaluation.slots_unresolved, 0);
    assert!(plan.is_feasible());
    let room = Summary::new(&m, &plan).margins.unwrap();
    assert!(room.cell_room_pct.unwrap() >= 5.0 - 100.0 * FEASIBILITY_TOL / d_min);
    assert_eq!(room.slots_short_of_margin, 0);
    // the plan without the margin, judged with it, has slots resolved without that room
    let judged = Summary::new(
        &m,
        &planner::PlanResult {
            evaluation: planner::evaluate(&m, &free.trajectory),
            ..free.clone()
        },
    );
    assert!(judged.margins.unwrap().slots_short_of_margin > 0);
}

/// The margins together with a jerk limit and its margin: every limit keeps its room.
#[test]
fn every_margin_together_keeps_every_room() {
    let m = from_rest(
        "max_jerk_mps3 = 5\njerk_margin_pct = 20\naccel_margin_pct = 20\nresolution_margin_pct = 5",
    );
    let plan = least_energy(&m);
    let a_max = m.params().max_accel_mps2;
    assert!(largest(&accels_mps2(&m, &plan)) <= 0.8 * a_max * (1.0 + 1e-9));
    assert!(largest(&jerks_mps3(&m, &plan)) <= 4.0 * (1.0 + 1e-9));
    let room = Summary::new(&m, &plan).margins.unwrap();
    assert!(room.accel_room_pct >= 20.0 - 1e-6 && room.jerk_room_pct.unwrap() >= 20.0 - 1e-6);
    assert!(room.azimuth_room_pct.unwrap() > 5.0 - 1e-6, "{room:?}");
}

/// Bad values in a mission file are refused by name; a mission the margins make impossible is
/// refused naming the margin.
#[test]
fn bad_limits_and_margins_are_refused_by_name() {
    for (line, field) in [
        ("max_jerk_mps3 = 0", "max_jerk_mps3"),
        ("max_jerk_mps3 = 600", "max_jerk_mps3"),
        ("accel_margin_pct = -1", "accel_margin_pct"),
        ("resolution_margin_pct = 51", "resolution_margin_pct"),
        ("jerk_margin_pct = 80", "jerk_margin_pct"),
        ("start_accel_mps2 = [9.0, 0.0]", "start_accel_mps2"),
    ] {
        let text = format!(
            "[params]\n{line}\n[landmarks]\npoints = [{{ x_m = 0.0, y_m = 0.0, from_s = 0.0, \
             to_s = 10.0 }}]\n"
        );
        let e = Mission::from_file_struct(&MissionFile::from_toml_str(&text).unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("parameter `{field}`")),
            "{line}: {e}"
        );
    }
    // V_min at d_min (1 − 50 %) is twice 7.07 m/s, above this vehicle's 12 m/s
    let m = from_rest("max_speed_mps = 12\nresolution_margin_pct = 50");
    let e = planner::plan(&m, &PlanOptions::least_energy())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("resolution_margin_pct = 50") && e.contains("d_min 10"),
        "{e}"
    );
}
