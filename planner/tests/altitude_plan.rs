#![allow(clippy::unwrap_used, clippy::expect_used)]
//! Free-altitude plans (`altitude = "free"`, the `exact` scheme with
//! `PlanOptions::altitude_profile`): checked on the exact geometry at their own altitudes, the
//! bounds and rates checked here slot by slot, the energy against the fixed plan and the floor
//! T min P(V); a mission only a lower altitude can fly gets a plan; the other schemes and callers
//! without the option keep refusing.

use planner::evaluate::evaluate_with_altitudes;
use planner::{
    plan, AltitudeMode, Mission, MissionFile, PlanError, PlanOptions, PlanResult, PowerModel,
    Preset, Scheme,
};

/// `mission` with its altitude free within [`lo`, `hi`].
fn free(mission: &Mission, lo: f64, hi: f64) -> Mission {
    let mut p = mission.params().clone();
    p.altitude = AltitudeMode::Free;
    p.min_altitude_m = Some(lo);
    p.max_altitude_m = Some(hi);
    mission.with_params(p).unwrap()
}

fn profile_options(options: PlanOptions) -> PlanOptions {
    PlanOptions {
        altitude_profile: true,
        ..options
    }
}

/// The checks every free plan must pass: its profile has one altitude per slot within the
/// bounds, each step within the climb and descent rates (from `altitude_m`), its evaluation is
/// `evaluate_with_altitudes` of its track and profile, feasible, and its energy at least the
/// floor T min P(V).
fn check_free_plan(m: &Mission, r: &PlanResult) {
    let p = m.params();
    let z = r.altitudes_m.as_ref().expect("a free plan has altitudes");
    assert_eq!(z.len(), m.slots());
    let (lo, hi) = (p.min_altitude_m.unwrap(), p.max_altitude_m.unwrap());
    let mut prev = p.altitude_m;
    for (t, &h) in z.iter().enumerate() {
        assert!((lo..=hi).contains(&h), "slot {}: {h} m", t + 1);
        let rate = (h - prev) / p.slot_s;
        assert!(
            rate <= p.max_climb_mps + 1e-9 && -rate <= p.max_descent_mps + 1e-9,
            "slot {}: {rate} m/s",
            t + 1
        );
        prev = h;
    }
    let ev = evaluate_with_altitudes(m, &r.trajectory, z).unwrap();
    assert_eq!(ev, r.evaluation);
    assert!(ev.is_feasible(), "{:?}", ev.violations);
    assert!(r.is_feasible());
    let model = PowerModel::new(p);
    let floor_j = m.slots() as f64 * p.slot_s * model.min_power(p.max_speed_mps).1;
    assert!(
        ev.energy_j >= floor_j * (1.0 - 1e-9),
        "{} < {floor_j}",
        ev.energy_j
    );
}

/// The majorisation–minimisation property of the free SCA's accepted iterates (after the fixed
/// plan's): each one's surrogate energy (the subproblem's own objective) is at least its true
/// energy (the surrogate majorises) and at most the previous iterate's true energy (it is tight
/// there, and the previous iterate is feasible for the subproblem), so the true energies never
/// increase. Least-energy plans only (no deficit in the objective).
fn assert_monotone(fixed: &PlanResult, free: &PlanResult) {
    let tol = 1e-5;
    let mut last = fixed.evaluation.energy_j;
    let mut accepted = 0;
    for r in free.records[fixed.records.len()..]
        .iter()
        .filter(|r| r.accepted)
    {
        assert!(
            r.objective >= r.true_energy_j * (1.0 - tol),
            "iteration {}: surrogate {} below the true energy {}",
            r.iteration,
            r.objective,
            r.true_energy_j
        );
        assert!(
            r.objective <= last * (1.0 + tol),
            "iteration {}: surrogate {} above the previous energy {last}",
            r.iteration,
            r.objective
        );
        assert!(
            r.true_energy_j <= last * (1.0 + 1e-9),
            "{} after {last}",
            r.true_energy_j
        );
        last = r.true_energy_j;
        accepted += 1;
    }
    assert_eq!(last, free.evaluation.energy_j);
    assert!(accepted > 0 || free.evaluation.energy_j == fixed.evaluation.energy_j);
}

#[test]
fn bounds_at_the_mission_altitude_give_the_fixed_plan() {
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let options = PlanOptions::least_energy();
    let fixed = plan(&m, &options).unwrap();
    let fm = free(&m, 1000.0, 1000.0);
    let r = plan(&fm, &profile_options(options)).unwrap();
    check_free_plan(&fm, &r);
    assert!(r.altitudes_m.as_ref().unwrap().iter().all(|&h| h == 1000.0));
    let (a, b) = (fixed.evaluation.energy_j, r.evaluation.energy_j);
    assert!(b <= a * (1.0 + 1e-9), "{b} > {a}");
    assert!((a - b).abs() <= 1e-3 * a, "{a} vs {b}");
    assert_monotone(&fixed, &r);
}

/// Default 30 m and 200 m missions, 600–1200 m, least-energy options: feasible at their own
/// altitudes, no more energy than the fixed plan (the 200 m mission's strictly less: it lowers
/// the altitude), the free iterations monotone.
#[test]
fn free_plans_of_the_paper_missions_are_feasible_and_no_dearer() {
    for spacing in [30.0, 200.0] {
        let m = Mission::preset(Preset::Default, spacing).unwrap();
        let options = PlanOptions::least_energy();
        let fixed = plan(&m, &options).unwrap();
        let fm = free(&m, 600.0, 1200.0);
        let r = plan(&fm, &profile_options(options)).unwrap();
        check_free_plan(&fm, &r);
        let (a, b) = (fixed.evaluation.energy_j, r.evaluation.energy_j);
        assert!(b <= a * (1.0 + 1e-9), "spacing {spacing}: {b} > {a}");
        assert_monotone(&fixed, &r);
        if spacing == 200.0 {
            assert!(b < a - 100.0, "{b} vs {a}");
            let low = r
                .altitudes_m
                .as_ref()
                .unwrap()
                .iter()
                .copied()
                .fold(f64::MAX, f64::min);
            assert!(low < 950.0, "{low}");
        }
    }
}

/// The default options (general resolution as a best effort): the free plan keeps every
/// constraint but the cell at its altitudes, its merit (energy + weight × deficit) is no
/// larger than the fixed plan's, and neither is its energy.
#[test]
fn a_best_effort_free_plan_does_not_lose_merit_or_cost_energy() {
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let options = PlanOptions::default();
    let fixed = plan(&m, &options).unwrap();
    let fm = free(&m, 600.0, 1200.0);
    let r = plan(&fm, &profile_options(options.clone())).unwrap();
    check_free_plan(&fm, &r);
    assert!(r.best_effort.is_some());
    let merit = |mm: &Mission, e: &planner::Evaluation| {
        e.energy_j + options.resolution_weight_j_per_m * planner::shortfall::total_deficit_m(mm, e)
    };
    let (a, b) = (merit(&m, &fixed.evaluation), merit(&fm, &r.evaluation));
    assert!(b <= a * (1.0 + 1e-9), "{b} > {a}");
    let (ea, eb) = (fixed.evaluation.energy_j, r.evaluation.energy_j);
    assert!(eb <= ea * (1.0 + 1e-9), "free {eb} J > fixed {ea} J");
}

/// V_min = λ_c H / (T_d d_min cos η) is 7.07 m/s at 1000 m, above the speed limit of 6 m/s, and
/// 5.66 m/s at 800 m: the mission cannot be flown at its altitude, but with the altitude free
/// down to 800 m (a 5 m/s descent reaches it in 40 s, before the landmark's window opens at
/// 50 s) it is.
#[test]
fn a_mission_only_a_lower_altitude_can_fly_gets_a_plan() {
    let text = include_str!("../../missions/only-a-lower-altitude.toml");
    let fm = Mission::from_file_struct(&MissionFile::from_toml_str(text).unwrap()).unwrap();
    let options = PlanOptions::least_energy();
    let mut fixed_params = fm.params().clone();
    fixed_params.altitude = AltitudeMode::Fixed;
    fixed_params.min_altitude_m = None;
    fixed_params.max_altitude_m = None;
    let fixed = fm.with_params(fixed_params).unwrap();
    assert!(
        plan(&fixed, &options).is_err(),
        "the fixed altitude must be infeasible"
    );
    let r = plan(&fm, &profile_options(options)).unwrap();
    check_free_plan(&fm, &r);
    let p = fm.params();
    let z = r.altitudes_m.as_ref().unwrap();
    for s in r.evaluation.slots.iter().filter(|s| s.landmark_m.is_some()) {
        // the azimuth requirement at the slot's altitude, recomputed here
        let v_min = p.wavelength_m * z[s.t - 1]
            / (p.integration_time_s * p.d_min_m * p.observation_angle_rad.cos());
        assert!(
            s.speed_mps >= v_min - 1e-6,
            "slot {}: {} < {v_min}",
            s.t,
            s.speed_mps
        );
        assert!(z[s.t - 1] < 850.0, "slot {}: {} m", s.t, z[s.t - 1]);
    }
}

#[test]
fn only_exact_and_paper_with_the_option_plan_free_altitudes() {
    let fm = free(
        &Mission::preset(Preset::Default, 30.0).unwrap(),
        600.0,
        1200.0,
    );
    for scheme in [Scheme::Baseline, Scheme::BaselineExact] {
        let options = profile_options(PlanOptions::for_scheme(scheme));
        let e = plan(&fm, &options).unwrap_err();
        assert_eq!(e, PlanError::AltitudeConflict { scheme });
        assert!(
            e.to_string().contains("only the schemes exact and paper"),
            "{e}"
        );
    }
    let e = plan(&fm, &PlanOptions::least_energy()).unwrap_err();
    assert_eq!(
        e,
        PlanError::AltitudeConflict {
            scheme: Scheme::Exact
        }
    );
}
