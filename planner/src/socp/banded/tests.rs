//! The banded method against closed forms and against Clarabel on random chain programs.

use super::*;
use crate::socp::{Backend, Lin, SocpSettings, SocpSolver};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn banded(prob: &ProblemBuilder) -> BandedSolution {
    solve(prob, &BandedSettings::default()).unwrap()
}

/// min x + y s.t. ‖(x, y)‖ ≤ 1: x = y = −1/√2.
#[test]
fn unit_disc() {
    let b = crate::socp::tests::unit_disc_problem();
    let sol = banded(&b);
    let h = -1.0 / 2f64.sqrt();
    assert!(
        (sol.x[0] - h).abs() < 1e-7 && (sol.x[1] - h).abs() < 1e-7,
        "{:?}",
        sol.x
    );
}

/// min x² − 8x + t s.t. x ≤ 1, y ≥ x + 1, t ≥ y²: the bound is active, x = 1, y = 2, t = 4.
#[test]
fn quadratic_with_bounds_and_rotated_cone() {
    let mut b = ProblemBuilder::new(3);
    b.add_square_cost(0, 1.0);
    b.add_linear_cost(0, -8.0);
    b.add_linear_cost(2, 1.0); // + t, t ≥ y² with y = x + 1 … so t = (x + 1)²
    b.nonneg(Lin::var(0, -1.0).plus_const(1.0)); // x ≤ 1
    b.nonneg(
        Lin::var(1, 1.0)
            .minus_lin(&Lin::var(0, 1.0))
            .plus_const(-1.0),
    ); // y ≥ x + 1
    b.rotated_soc(
        Lin::var(2, 1.0),
        Lin::constant_only(1.0),
        &[Lin::var(1, 1.0)],
    );
    // minimise x² − 8x + (x + 1)²: derivative 4x − 6 = 0 at x = 1.5, so x = 1 (on the bound)
    let sol = banded(&b);
    assert!((sol.x[0] - 1.0).abs() < 1e-6, "{:?}", sol.x);
    assert!((sol.x[1] - 2.0).abs() < 1e-6, "{:?}", sol.x);
    assert!((sol.x[2] - 4.0).abs() < 1e-5, "{:?}", sol.x);
}

/// A chain program shaped like the planner's: per slot t a position p_t ∈ R², a speed epigraph
/// V_t ≥ ‖p_t − p_{t−1}‖, V_t ≤ V_max, a rotated cone w_t ≥ V_t², and a disc the position must
/// stay in; objective Σ (c₁ V_t + c₂ w_t + c₃ e_t) with e_t ≥ ‖p_t − g_t‖ − r (elastic).
fn chain(rng: &mut ChaCha8Rng, slots: usize) -> ProblemBuilder {
    let per = 5; // x, y, V, w, e
    let mut b = ProblemBuilder::new(per * slots);
    let start = [0.0, 0.0];
    let mut centre = [0.0f64, 0.0];
    for t in 0..slots {
        let (x, y, v, w, e) = (per * t, per * t + 1, per * t + 2, per * t + 3, per * t + 4);
        b.add_linear_cost(v, rng.gen_range(0.1..1.0));
        b.add_linear_cost(w, rng.gen_range(0.01..0.2));
        b.add_linear_cost(e, 10.0);
        if rng.gen_bool(0.3) {
            b.add_square_cost(x, rng.gen_range(0.0..0.1));
        }
        let (vx, vy) = if t == 0 {
            (
                Lin::var(x, 1.0).plus_const(-start[0]),
                Lin::var(y, 1.0).plus_const(-start[1]),
            )
        } else {
            (
                Lin::var(x, 1.0).minus_lin(&Lin::var(x - per, 1.0)),
                Lin::var(y, 1.0).minus_lin(&Lin::var(y - per, 1.0)),
            )
        };
        b.soc(Lin::var(v, 1.0), &[vx, vy]);
        b.nonneg(Lin::var(v, -1.0).plus_const(20.0));
        b.rotated_soc(
            Lin::var(w, 1.0),
            Lin::constant_only(1.0),
            &[Lin::var(v, 1.0)],
        );
        centre[0] += rng.gen_range(-5.0..15.0);
        centre[1] += rng.gen_range(-5.0..15.0);
        let r = rng.gen_range(5.0..30.0);
        b.soc(
            Lin::var(e, 1.0).plus_const(r),
            &[
                Lin::var(x, 1.0).plus_const(-centre[0]),
                Lin::var(y, 1.0).plus_const(-centre[1]),
            ],
        );
        b.nonneg(Lin::var(e, 1.0));
    }
    b
}

/// On random chain programs the banded method and Clarabel agree on the optimal value, and
/// the banded answer satisfies every cone to the tolerance.
#[test]
fn agrees_with_clarabel_on_random_chains() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for case in 0..40 {
        let slots = rng.gen_range(1..120);
        let b = chain(&mut rng, slots);
        let sol = banded(&b);
        assert!(
            sol.bandwidth <= 10,
            "case {case}: bandwidth {}",
            sol.bandwidth
        );
        let ours = b.objective(&sol.x);
        let reference = SocpSolver::new(SocpSettings::default()).solve(&b).unwrap();
        let diff = (ours - reference.objective).abs();
        assert!(
            diff <= 1e-6 * (1.0 + reference.objective.abs()),
            "case {case} ({slots} slots): banded {ours} vs Clarabel {}",
            reference.objective
        );
        assert!(
            b.max_relative_cone_violation(&sol.x) <= 1e-7,
            "case {case}: violation {}",
            b.max_relative_cone_violation(&sol.x)
        );
    }
}

#[test]
fn infeasible_program_is_an_error_not_a_panic() {
    let mut b = ProblemBuilder::new(1);
    b.nonneg(Lin::var(0, 1.0).plus_const(-2.0)); // x ≥ 2
    b.nonneg(Lin::var(0, -1.0).plus_const(1.0)); // x ≤ 1
    b.add_linear_cost(0, 1.0);
    assert!(matches!(
        solve(&b, &BandedSettings::default()),
        Err(BandedError::NotConverged { .. }
            | BandedError::Numerical { .. }
            | BandedError::Factorisation { .. })
    ));
}

#[test]
fn unsupported_programs_are_named() {
    let mut b = ProblemBuilder::new(1);
    b.zero(Lin::var(0, 1.0));
    let err = solve(&b, &BandedSettings::default()).unwrap_err();
    assert!(err.to_string().contains("equality"), "{err}");
    // a cost on a variable that does not exist
    let mut b = ProblemBuilder::new(1);
    b.add_square_cost(3, 1.0);
    b.nonneg(Lin::var(0, 1.0));
    let err = solve(&b, &BandedSettings::default()).unwrap_err();
    assert!(err.to_string().contains("(3, 3)"), "{err}");
    // a cone over all variables: bandwidth n − 1
    let mut b = ProblemBuilder::new(80);
    let tail: Vec<Lin> = (1..80).map(|j| Lin::var(j, 1.0)).collect();
    b.soc(Lin::var(0, 1.0), &tail);
    let err = solve(&b, &BandedSettings::default()).unwrap_err();
    assert!(err.to_string().contains("bandwidth 79"), "{err}");
}

/// The solver front end: with the banded backend a program it cannot take (equality cone) is
/// still solved, by Clarabel, and counted.
#[test]
fn socp_solver_falls_back_to_clarabel() {
    let b = crate::socp::tests::rotated_cone_problem();
    let with_banded = SocpSettings {
        backend: Backend::Banded,
        ..SocpSettings::exact_geometry()
    };
    let mut s = SocpSolver::new(with_banded);
    let sol = s.solve(&b).unwrap();
    assert!((sol.x[1] - 9.0).abs() < 1e-5);
    assert_eq!(s.banded_fallbacks, 1);
    // and a banded program is solved without Clarabel
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let b = chain(&mut rng, 30);
    let mut s = SocpSolver::new(with_banded);
    s.solve(&b).unwrap();
    assert_eq!((s.banded_fallbacks, s.builds), (0, 0));
}
