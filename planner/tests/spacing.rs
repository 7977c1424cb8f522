//! The built-in start of the `exact` scheme across landmark spacings: when the optimisation of
//! the finest coarse level fails, that level's feasible track is handed on (the guidance law
//! instead led the 80 m and 130 m default missions to optima 15 % and 33 % above their
//! neighbours'). The default mission's energy is at the floor up to about 120 m and rises
//! with the spacing beyond.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use planner::{plan, Mission, PlanOptions, Preset};

fn energy_j(spacing_m: f64) -> f64 {
    let m = Mission::preset(Preset::Default, spacing_m).unwrap();
    let r = plan(&m, &PlanOptions::least_energy()).unwrap();
    assert!(r.evaluation.is_feasible(), "{spacing_m} m: infeasible");
    r.evaluation.energy_j
}

#[test]
fn energy_is_at_the_floor_at_80_m_and_rises_from_120_m() {
    let e70 = energy_j(70.0);
    let e80 = energy_j(80.0);
    let e90 = energy_j(90.0);
    assert!(
        (e80 - e70).abs() < 1e-4 * e70,
        "80 m: {e80} J, 70 m: {e70} J"
    );
    assert!(
        (e90 - e70).abs() < 1e-4 * e70,
        "90 m: {e90} J, 70 m: {e70} J"
    );
    let e120 = energy_j(120.0);
    let e130 = energy_j(130.0);
    let e140 = energy_j(140.0);
    assert!(
        e70 <= e120 * (1.0 + 1e-9) && e120 <= e130 && e130 <= e140,
        "not monotone: 70 m {e70}, 120 m {e120}, 130 m {e130}, 140 m {e140} J"
    );
    // 15 145 J today; the guidance-law start gave 20 217 J
    assert!(e130 < 1.01 * e70, "130 m: {e130} J against {e70} J at 70 m");
}
