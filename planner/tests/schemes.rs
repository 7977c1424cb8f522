#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]
//! Each scheme on short missions, checked on the exact geometry by code written here, independent
//! of the optimiser and of `planner::evaluate`.

use planner::landmarks::{LandmarkWindow, LandmarksSpec};
use planner::{plan, Mission, Params, PlanOptions, Preset, Scheme, TerminationReason, Trajectory};

/// Independent check: true speeds, headings, centres and energy straight from the paper's
/// equations with Table II numbers typed in again.
struct Check {
    energy_j: f64,
    max_sensing_excess_m: f64,
    min_landmark_speed_mps: f64,
    max_speed_mps: f64,
}

fn power_w(v: f64) -> f64 {
    let (p0, utip, p1, v0): (f64, f64, f64, f64) = (3.4, 60.0, 118.0, 5.4);
    let (s, a, rho, df) = (0.02, 0.5, 1.225, 0.3);
    p0 * (1.0 + 3.0 * v * v / (utip * utip))
        + p1 * ((1.0 + v.powi(4) / (4.0 * v0.powi(4))).sqrt() - v * v / (2.0 * v0 * v0)).sqrt()
        + 0.5 * df * rho * s * a * v.powi(3)
}

fn check(m: &Mission, tr: &Trajectory) -> Check {
    let p = m.params();
    let d = p.altitude_m * p.observation_angle_rad.tan();
    let mut prev = tr.start_m;
    let mut heading = 0.0f64;
    let mut out = Check {
        energy_j: 0.0,
        max_sensing_excess_m: f64::NEG_INFINITY,
        min_landmark_speed_mps: f64::INFINITY,
        max_speed_mps: 0.0,
    };
    for (i, q) in tr.pos_m.iter().enumerate() {
        let (dx, dy) = (q[0] - prev[0], q[1] - prev[1]);
        let v = dx.hypot(dy) / p.slot_s;
        if v > 0.0 {
            heading = dy.atan2(dx);
        }
        out.energy_j += power_w(v) * p.slot_s;
        out.max_speed_mps = out.max_speed_mps.max(v);
        if let Some(g) = m.target_m(i + 1) {
            let c = [q[0] + d * heading.sin(), q[1] - d * heading.cos()];
            let e = (c[0] - g[0]).hypot(c[1] - g[1]) - p.sensing_radius_m;
            out.max_sensing_excess_m = out.max_sensing_excess_m.max(e);
            out.min_landmark_speed_mps = out.min_landmark_speed_mps.min(v);
        }
        prev = *q;
    }
    out
}

/// A 60 s mission with three landmarks and a gap.
/// The floor T·P(V*) of a 300 s mission with Table II's numbers, J.
const FLOOR_J: f64 = 300.0 * 50.2911;

/// Every landmark slot in view and at least the azimuth speed λH/(T_d d_min cos η) ≈ 7.07 m/s,
/// by the independent check.
fn assert_feasible_on_exact_geometry(c: &Check) {
    assert!(
        c.max_sensing_excess_m <= 1e-4,
        "sensing excess {} m",
        c.max_sensing_excess_m
    );
    assert!(
        c.min_landmark_speed_mps >= 7.0710678 - 1e-4,
        "landmark-slot speed {} m/s",
        c.min_landmark_speed_mps
    );
}

fn short_mission() -> Mission {
    let mut p = Params::default();
    p.horizon_s = 60.0;
    p.start_m = [-900.0, -100.0];
    let spec = LandmarksSpec {
        points: Some(vec![
            LandmarkWindow {
                x_m: 0.0,
                y_m: 0.0,
                from_s: 0.0,
                to_s: 20.0,
            },
            LandmarkWindow {
                x_m: 100.0,
                y_m: 120.0,
                from_s: 20.0,
                to_s: 40.0,
            },
            LandmarkWindow {
                x_m: 250.0,
                y_m: 150.0,
                from_s: 45.0,
                to_s: 60.0,
            },
        ]),
        ..Default::default()
    };
    Mission::new("short", p, &spec).unwrap()
}

#[test]
fn exact_is_feasible_and_monotone_on_a_short_mission() {
    let m = short_mission();
    let r = plan(&m, &PlanOptions::least_energy()).unwrap();
    let c = check(&m, &r.trajectory);
    assert!(
        c.max_sensing_excess_m <= 1e-4,
        "sensing excess {}",
        c.max_sensing_excess_m
    );
    let v_min = 0.1 * 1000.0 / (1.0 * 20.0 * std::f64::consts::FRAC_PI_4.cos());
    assert!(
        c.min_landmark_speed_mps >= v_min - 1e-4,
        "{}",
        c.min_landmark_speed_mps
    );
    assert!(c.max_speed_mps <= 50.0 + 1e-6);
    assert!((c.energy_j - r.evaluation.energy_j).abs() < 1e-6 * c.energy_j);
    // every accepted iterate's true energy is no larger than the previous one
    for w in r.true_energy_history.windows(2) {
        assert!(w[1] <= w[0] * (1.0 + 1e-9), "{w:?}");
    }
    assert!(r.evaluation.energy_j <= r.start_energy_j + 1e-6 || r.repair_iterations > 0);
    // the optimiser's own objective is an upper bound of the true energy at its solution
    assert!(r.objective >= r.evaluation.energy_j - 1e-3 * r.evaluation.energy_j);
}

#[test]
fn exact_reaches_the_floor_on_the_default_mission_30m() {
    let m = Mission::preset(Preset::Default, 30.0).unwrap();
    let r = plan(&m, &PlanOptions::least_energy()).unwrap();
    let c = check(&m, &r.trajectory);
    assert_feasible_on_exact_geometry(&c);
    // floor T·P(V*) ≈ 15 087 J; the target is within 5 %
    assert!(
        c.energy_j < 1.05 * FLOOR_J,
        "{} J vs floor {FLOOR_J} J",
        c.energy_j
    );
    assert!(
        c.energy_j >= FLOOR_J * 0.999,
        "below the floor? {}",
        c.energy_j
    );
    assert_eq!(r.termination, TerminationReason::Converged);
}

#[test]
fn exact_is_feasible_on_the_default_mission_200m() {
    let m = Mission::preset(Preset::Default, 200.0).unwrap();
    let r = plan(&m, &PlanOptions::least_energy()).unwrap();
    let c = check(&m, &r.trajectory);
    assert_feasible_on_exact_geometry(&c);
    // The centre must follow a 5.8 km L-shaped route with the UAV outside the corner; docs/paper-notes.md ("Where the results
    // differ from the paper") estimates at least 6.6 km of flight (≥ 15.94 kJ) even before timing.
    // The plan flies about 7.4 km for ≈ 18.27 kJ. Guard against regressions.
    assert!(c.energy_j < 18_400.0, "{}", c.energy_j);
    assert!(r.trajectory.length_m() > 6_575.0);
}

/// Fig. 11's random realisations 18 and 3. Realisation 18: the 10 s coarse level alone started
/// the fine SCA from a poor track (16.5 kJ) that it then took 198 iterations to improve; the 20 s
/// level finds the orbit at once. Realisation 3: the 20 s level's phase I stalled (its merit
/// counted only the slot-end centre while its slacks also bound the slot-start centre), so the
/// plan fell back to the 10 s level and took 138 fine iterations to end 11 J above the floor.
/// Realisation 19: its 20 s level stalls for good (23 m of whole-slot violation left), and the
/// 10 s level, started again from the guidance law, left the fine SCA 149 iterations to end 7 J
/// above the floor; the stalled 20 s track now starts the 10 s level (as well as the guidance
/// law; the cheaper result is kept). Realisation 0 (the one Fig. 11 plots) ended 406 J above the
/// floor after 17 iterations for the same reason.
#[test]
fn exact_reaches_the_floor_at_once_on_random_realisations_18_3_19_and_0() {
    for seed in [18, 3, 19, 0] {
        let file = planner::MissionFile::from_toml_str(&format!(
            "[params]\n[landmarks]\npreset = \"random\"\nspacing_m = 100.0\nseed = {seed}\n"
        ))
        .unwrap();
        let m = Mission::from_file_struct(&file).unwrap();
        let r = plan(&m, &PlanOptions::least_energy()).unwrap();
        let c = check(&m, &r.trajectory);
        assert_feasible_on_exact_geometry(&c);
        assert!(
            c.energy_j < FLOOR_J + 2.0,
            "random-{seed}: {} J vs floor {FLOOR_J} J",
            c.energy_j
        );
        assert!(
            r.iterations <= 5,
            "random-{seed}: {} fine iterations",
            r.iterations
        );
        assert_eq!(r.termination, TerminationReason::Converged, "random-{seed}");
    }
}

#[test]
fn paper_and_baselines_run_and_report_their_own_objective() {
    let m = short_mission();
    for scheme in [Scheme::Paper, Scheme::Baseline, Scheme::BaselineExact] {
        let r = plan(&m, &PlanOptions::for_scheme(scheme)).unwrap();
        let c = check(&m, &r.trajectory);
        assert!((c.energy_j - r.evaluation.energy_j).abs() < 1e-6 * c.energy_j);
        assert!(!r.objective_history.is_empty(), "{scheme}");
        if scheme == Scheme::BaselineExact {
            assert!(c.max_sensing_excess_m <= 1e-4);
            // its objective is the true path length
            assert!((r.objective - r.trajectory.length_m()).abs() < 1e-3 * r.objective);
        }
    }
}

/// From a given path, Algorithm 1's first (p5) value is unique: it does not depend on the solver
/// settings, and it matches the value recorded when this test was written (golden result).
#[test]
fn paper_first_iteration_from_a_given_path_is_reproducible() {
    let m = short_mission();
    // a feasible path: the exact scheme's own result
    let start = plan(&m, &PlanOptions::least_energy()).unwrap().trajectory;
    let first = |reuse: bool, tol: f64| {
        let mut o = PlanOptions {
            init: Some(start.clone()),
            max_iterations: 1,
            ..PlanOptions::for_scheme(Scheme::Paper)
        };
        o.socp.reuse = reuse;
        o.socp.tol_feas = tol;
        o.socp.tol_gap_rel = tol;
        plan(&m, &o).unwrap().objective_history[0]
    };
    let a = first(true, 1e-8);
    let b = first(false, 1e-9);
    assert!((a - b).abs() <= 1e-6 * a, "{a} vs {b}");
    // p5 from a feasible path can only improve on the path's own energy
    let e0 = planner::evaluate(&m, &start).energy_j;
    assert!(a <= e0 + 1e-6 * e0, "{a} > {e0}");
}

#[test]
fn infeasible_mission_is_reported_before_solving() {
    let mut p = Params::default();
    p.horizon_s = 10.0;
    let spec = LandmarksSpec {
        points: Some(vec![LandmarkWindow {
            x_m: 20_000.0,
            y_m: 0.0,
            from_s: 0.0,
            to_s: 10.0,
        }]),
        ..Default::default()
    };
    let m = Mission::new("far", p, &spec).unwrap();
    let e = plan(&m, &PlanOptions::least_energy()).unwrap_err();
    match e {
        planner::PlanError::Infeasible(i) => assert_eq!(i.slot, 1),
        other => panic!("unexpected {other}"),
    }
}

#[test]
fn init_paths_phase_one_cannot_use_are_still_planned() {
    // Given paths far outside the speed limit (every slot at one point 1 km away: the first
    // step is 1 km in 0.5 s; or the feasible start shifted by 300 m after the first slot). Before
    // the fix every one failed with "iteration 0: subproblem is infeasible": the speed floor of
    // the repair program (85 % of the previous step) lay above the speed limit.
    let m = short_mission();
    let n = m.slots();
    let built_in = plan(&m, &PlanOptions::least_energy()).unwrap();
    let shifted = Trajectory {
        pos_m: built_in
            .trajectory
            .pos_m
            .iter()
            .map(|q| [q[0] + 300.0, q[1]])
            .collect(),
        ..built_in.trajectory.clone()
    };
    let parked = Trajectory {
        pos_m: vec![[100.0, 0.0]; n],
        ..built_in.trajectory.clone()
    };
    for (name, init) in [("shifted", shifted), ("parked", parked)] {
        let r = plan(
            &m,
            &PlanOptions {
                init: Some(init),
                ..PlanOptions::least_energy()
            },
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_feasible_on_exact_geometry(&check(&m, &r.trajectory));
        assert!(r.evaluation.is_feasible(), "{name}");
        assert_eq!(r.trajectory.start_m, m.params().start_m, "{name}");
    }
}

#[test]
fn init_that_starts_elsewhere_is_rejected() {
    // Its t = 0 row is not the mission's start: it used to become the plan's start silently.
    let m = short_mission();
    let bad = Trajectory {
        slot_s: 0.5,
        start_m: [0.0, 0.0],
        pos_m: vec![[0.0, 0.0]; m.slots()],
    };
    let e = plan(
        &m,
        &PlanOptions {
            init: Some(bad),
            ..PlanOptions::least_energy()
        },
    )
    .unwrap_err();
    assert!(matches!(e, planner::PlanError::InvalidInit(_)), "{e}");
    assert!(e.to_string().contains("start_m"), "{e}");
}

#[test]
fn bad_init_is_rejected_with_a_message() {
    let m = short_mission();
    let bad = Trajectory {
        slot_s: 0.5,
        start_m: [0.0, 0.0],
        pos_m: vec![[0.0, 0.0]; 3],
    };
    let e = plan(
        &m,
        &PlanOptions {
            init: Some(bad),
            ..PlanOptions::least_energy()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("120 slots"), "{e}");
}

#[test]
fn time_limit_returns_the_last_feasible_iterate() {
    // A feasible given start and a limit that has passed before the first iteration: the plan is
    // that start, unchanged, stopped by the limit (not an error, not an unchecked iterate).
    let m = short_mission();
    let start = plan(
        &m,
        &PlanOptions {
            max_iterations: 1,
            ..PlanOptions::least_energy()
        },
    )
    .unwrap();
    assert!(start.evaluation.is_feasible());
    let r = plan(
        &m,
        &PlanOptions {
            init: Some(start.trajectory.clone()),
            time_limit_s: Some(1e-9),
            ..PlanOptions::least_energy()
        },
    )
    .unwrap();
    assert_eq!(r.termination, TerminationReason::TimeLimit);
    assert_eq!(r.iterations, 0);
    assert!(!r.converged);
    assert_eq!(r.trajectory.pos_m, start.trajectory.pos_m);
    assert_feasible_on_exact_geometry(&check(&m, &r.trajectory));
    // the same for the paper's scheme, from the same path
    let r = plan(
        &m,
        &PlanOptions {
            init: Some(start.trajectory),
            time_limit_s: Some(1e-9),
            ..PlanOptions::for_scheme(Scheme::Paper)
        },
    )
    .unwrap();
    assert_eq!(r.termination, TerminationReason::TimeLimit);
    assert_eq!(r.iterations, 0);
}

#[test]
fn time_limit_during_repair_is_an_error_that_says_so() {
    // An infeasible given start (parked 1 km from the start) and a limit already passed: phase I
    // cannot run, and the error says why instead of planning from another start.
    let m = short_mission();
    let parked = Trajectory {
        slot_s: 0.5,
        start_m: m.params().start_m,
        pos_m: vec![[100.0, 0.0]; m.slots()],
    };
    let e = plan(
        &m,
        &PlanOptions {
            init: Some(parked),
            time_limit_s: Some(1e-9),
            ..PlanOptions::least_energy()
        },
    )
    .unwrap_err();
    assert!(
        matches!(e, planner::PlanError::TimeLimit { iterations: 0, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("time limit"), "{e}");
    // a generous limit changes nothing
    let r = plan(
        &m,
        &PlanOptions {
            time_limit_s: Some(1e6),
            ..PlanOptions::least_energy()
        },
    )
    .unwrap();
    assert_eq!(r.termination, TerminationReason::Converged);
}

#[test]
fn bad_options_are_named() {
    let m = short_mission();
    for (options, field) in [
        (
            PlanOptions {
                time_limit_s: Some(f64::NAN),
                ..PlanOptions::least_energy()
            },
            "time_limit_s",
        ),
        (
            PlanOptions {
                time_limit_s: Some(0.0),
                ..PlanOptions::least_energy()
            },
            "time_limit_s",
        ),
        (
            PlanOptions {
                tolerance: -1.0,
                ..PlanOptions::least_energy()
            },
            "tolerance",
        ),
        (
            PlanOptions {
                min_kappa_scale: 2.0,
                ..PlanOptions::least_energy()
            },
            "min_kappa_scale",
        ),
    ] {
        let e = plan(&m, &options).unwrap_err();
        assert!(
            matches!(e, planner::PlanError::InvalidOption { field: f, .. } if f == field),
            "{e}"
        );
        assert!(e.to_string().contains(field), "{e}");
    }
}

#[test]
fn unrepairable_init_falls_back_only_when_allowed() {
    // Parked 3 km away: the first step is 4 km in 0.5 s and every later step is zero, so the
    // repair programs are numerically infeasible (Clarabel: primal infeasible).
    let m = short_mission();
    let parked = Trajectory {
        slot_s: 0.5,
        start_m: m.params().start_m,
        pos_m: vec![[3000.0, 0.0]; m.slots()],
    };
    let r = plan(
        &m,
        &PlanOptions {
            init: Some(parked.clone()),
            ..PlanOptions::least_energy()
        },
    )
    .unwrap();
    let reason = r
        .init_replaced
        .as_deref()
        .expect("the built-in start was used");
    assert!(reason.contains("iteration 0"), "{reason}");
    assert_feasible_on_exact_geometry(&check(&m, &r.trajectory));
    let e = plan(
        &m,
        &PlanOptions {
            init: Some(parked),
            replace_unrepairable_init: false,
            ..PlanOptions::least_energy()
        },
    )
    .unwrap_err();
    assert_eq!(e.to_string(), reason);
}
