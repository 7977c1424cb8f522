#![allow(clippy::unwrap_used, clippy::expect_used)]
//! The scheme `paper` with free altitude: the paper's alternating extension (altitude step,
//! then Algorithm 1 at those altitudes) never returns more energy than the fixed-altitude plan,
//! never a less feasible plan, stops within its cap; and with the altitude fixed the scheme's
//! plans are bit for bit those it made before the extension.

use std::path::{Path, PathBuf};

use planner::driver::{ALTERNATION_PHASE, MAX_ALTERNATIONS};
use planner::evaluate::evaluate_with_altitudes;
use planner::{
    plan, plan_with_observer, AltitudeMode, IterationRecord, Mission, MissionFile, Observer,
    PlanOptions, PlanResult, Scheme, TerminationReason,
};

fn mission_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../missions/{name}.toml"))
}

/// A straight track's mission: from (−1000, 0) m, one landmark at (0, 100) m in view for the
/// whole horizon (the UAV flies north with the landmark 1 km to its right).
fn straight(horizon_s: f64) -> Mission {
    let text = format!(
        "name = \"straight\"\n[params]\nhorizon_s = {horizon_s}\nstart_m = [-1000.0, 0.0]\n\
         [landmarks]\npoints = [{{ x_m = 0.0, y_m = 100.0, from_s = 0.0, to_s = {horizon_s} }}]\n"
    );
    Mission::from_file_struct(&MissionFile::from_toml_str(&text).unwrap()).unwrap()
}

fn free(mission: &Mission, lo: f64, hi: f64) -> Mission {
    let mut p = mission.params().clone();
    p.altitude = AltitudeMode::Free;
    p.min_altitude_m = Some(lo);
    p.max_altitude_m = Some(hi);
    mission.with_params(p).unwrap()
}

fn paper_free() -> PlanOptions {
    PlanOptions {
        altitude_profile: true,
        ..PlanOptions::for_scheme(Scheme::Paper)
    }
}

/// Counts the alternations (the phase the driver announces at the start of each).
#[derive(Default)]
struct Alternations(usize);
impl Observer for Alternations {
    fn on_phase(&mut self, phase: &str) {
        if phase == ALTERNATION_PHASE {
            self.0 += 1;
        }
    }
    fn on_iteration(&mut self, _record: &IterationRecord) {}
}

/// The checks every alternating plan passes against the fixed plan `fixed` of the same mission:
/// one altitude per slot within the bounds and rates, its evaluation that of its track at its
/// altitudes, no more energy, and no less feasible (feasible when the fixed plan is).
fn check_against_fixed(m: &Mission, r: &PlanResult, fixed: &PlanResult) {
    let p = m.params();
    let z = r.altitudes_m.as_ref().expect("a free plan has altitudes");
    assert_eq!(z.len(), m.slots());
    let mut prev = p.altitude_m;
    for (t, &h) in z.iter().enumerate() {
        assert!((600.0..=1200.0).contains(&h), "slot {}: {h} m", t + 1);
        let rate = (h - prev) / p.slot_s;
        assert!(rate <= p.max_climb_mps + 1e-9 && -rate <= p.max_descent_mps + 1e-9);
        prev = h;
    }
    let ev = evaluate_with_altitudes(m, &r.trajectory, z).unwrap();
    assert_eq!(ev, r.evaluation);
    let fixed_ev = &fixed.evaluation;
    assert!(
        ev.energy_j <= fixed_ev.energy_j * (1.0 + 1e-9),
        "{} J > fixed {} J",
        ev.energy_j,
        fixed_ev.energy_j
    );
    if fixed_ev.is_feasible() {
        assert!(ev.is_feasible(), "{:?}", ev.violations);
        assert!(ev.slots.iter().all(|s| s.landmark_m.is_none() || s.in_view));
    } else {
        assert!(ev.slots_out_of_view <= fixed_ev.slots_out_of_view);
        assert!(ev.violations.sensing_m <= fixed_ev.violations.sensing_m + 1e-9);
    }
    assert_eq!(r.scheme, Scheme::Paper);
}

#[test]
fn alternation_never_costs_more_than_the_fixed_plan_and_stays_feasible() {
    let fixed_m = straight(10.0);
    let fixed = plan(&fixed_m, &PlanOptions::for_scheme(Scheme::Paper)).unwrap();
    assert!(
        fixed.evaluation.is_feasible(),
        "{:?}",
        fixed.evaluation.violations
    );
    let m = free(&fixed_m, 600.0, 1200.0);
    let mut count = Alternations::default();
    let r = plan_with_observer(&m, &paper_free(), &mut count).unwrap();
    check_against_fixed(&m, &r, &fixed);
    assert!((1..=MAX_ALTERNATIONS).contains(&count.0), "{}", count.0);
}

#[test]
fn alternation_converges_within_its_cap() {
    // the 30 s straight mission: Algorithm 1 leaves slots out of view (the relaxations of
    // erratum 3); the altitude step descends and the alternation converges
    let fixed_m = straight(30.0);
    let fixed = plan(&fixed_m, &PlanOptions::for_scheme(Scheme::Paper)).unwrap();
    let m = free(&fixed_m, 600.0, 1200.0);
    let mut count = Alternations::default();
    let r = plan_with_observer(&m, &paper_free(), &mut count).unwrap();
    check_against_fixed(&m, &r, &fixed);
    assert!((1..=MAX_ALTERNATIONS).contains(&count.0), "{}", count.0);
    assert!(
        matches!(
            r.termination,
            TerminationReason::Converged | TerminationReason::NoProgress
        ),
        "{}",
        r.termination
    );
    // the alternation carried on from the fixed plan: its records follow the fixed plan's
    assert!(r.records.len() > fixed.records.len());
    for (a, b) in r.records.iter().zip(&fixed.records) {
        assert_eq!(
            (a.iteration, a.objective, a.true_energy_j),
            (b.iteration, b.objective, b.true_energy_j)
        );
    }
}

#[test]
fn an_explicit_schedule_ends_at_or_below_the_fixed_plan() {
    let fixed_m = Mission::from_path(&mission_path("explicit")).unwrap();
    let fixed = plan(&fixed_m, &PlanOptions::for_scheme(Scheme::Paper)).unwrap();
    let m = free(&fixed_m, 600.0, 1200.0);
    let mut count = Alternations::default();
    let r = plan_with_observer(&m, &paper_free(), &mut count).unwrap();
    check_against_fixed(&m, &r, &fixed);
    assert!(count.0 <= MAX_ALTERNATIONS);
}

/// FNV-1a over the bits of a plan's positions, own objectives and true energy.
fn plan_hash(r: &PlanResult) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: f64| {
        for b in x.to_bits().to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for q in &r.trajectory.pos_m {
        eat(q[0]);
        eat(q[1]);
    }
    for o in &r.objective_history {
        eat(*o);
    }
    eat(r.evaluation.energy_j);
    h
}

/// With the altitude fixed, `paper` plans are those the scheme made before it learned per-slot
/// altitudes: the hashes were taken from that code on the same missions.
#[test]
fn fixed_altitude_paper_plans_are_bit_for_bit_unchanged() {
    for (name, hash, iterations) in [
        ("default-30m", 0xfe61_a23c_333b_3364_u64, 8),
        ("explicit", 0xaf3d_ca26_61cd_1a00_u64, 3),
    ] {
        let m = Mission::from_path(&mission_path(name)).unwrap();
        let r = plan(&m, &PlanOptions::for_scheme(Scheme::Paper)).unwrap();
        assert_eq!(r.iterations, iterations, "{name}");
        assert_eq!(r.altitudes_m, None, "{name}");
        assert_eq!(plan_hash(&r), hash, "{name}: {:#018x}", plan_hash(&r));
    }
}
