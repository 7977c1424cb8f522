//! Tests of the Clarabel wrapper.

use super::*;

/// min x + y s.t. ‖(x, y)‖ ≤ 1: optimum x = y = −1/√2, objective −√2.
fn unit_disc_problem() -> ProblemBuilder {
    let mut b = ProblemBuilder::new(2);
    b.add_linear_cost(0, 1.0);
    b.add_linear_cost(1, 1.0);
    b.soc(
        Lin::constant_only(1.0),
        &[Lin::var(0, 1.0), Lin::var(1, 1.0)],
    );
    b
}

#[test]
fn tiny_socp() {
    let b = unit_disc_problem();
    let mut s = SocpSolver::new(SocpSettings::default());
    let sol = s.solve(&b).unwrap();
    let h = -1.0 / 2f64.sqrt();
    assert!((sol.x[0] - h).abs() < 1e-6 && (sol.x[1] - h).abs() < 1e-6);
    assert!((sol.objective - 2.0 * h).abs() < 1e-6);
}

/// Same structure, new values: the pattern is reused and the answer follows the data.
#[test]
fn in_place_update_follows_data() {
    let mut s = SocpSolver::new(SocpSettings::default());
    for r in [1.0, 2.0, 3.0] {
        let mut b = ProblemBuilder::new(2);
        b.add_linear_cost(0, 1.0);
        b.add_square_cost(1, 1.0); // + y²
        b.add_linear_cost(1, -2.0 * r); // − 2 r y → y = r
        b.soc(Lin::constant_only(r), &[Lin::var(0, 1.0)]); // |x| ≤ r
        let sol = s.solve(&b).unwrap();
        assert!((sol.x[0] + r).abs() < 1e-6, "x = {}", sol.x[0]);
        assert!((sol.x[1] - r).abs() < 1e-6, "y = {}", sol.x[1]);
    }
    assert_eq!(s.builds, 1);
}

/// A failed solve is repeated with refinement when (and only when) the settings ask for it,
/// then with the fallbacks when they are on; the last attempt's failure is what the caller
/// sees.
#[test]
fn failed_solve_is_retried_with_refinement_then_fallbacks() {
    let b = unit_disc_problem();
    // one interior-point iteration cannot solve it: every attempt stops at the limit
    let starved = SocpSettings {
        max_iter: 1,
        fallbacks: false,
        ..SocpSettings::exact_geometry()
    };
    let mut s = SocpSolver::new(starved);
    assert!(matches!(s.solve(&b), Err(SolveError::Inaccurate { .. })));
    assert_eq!(s.retries, 1);
    let mut s = SocpSolver::new(SocpSettings {
        max_iter: 1,
        fallbacks: false,
        ..SocpSettings::default()
    });
    assert!(s.solve(&b).is_err());
    assert_eq!(s.retries, 0);
    // with the fallbacks: the other refinement setting, then looser tolerances (for the
    // exact settings the other refinement setting is the refinement retry itself)
    for (settings, attempts) in [
        (SocpSettings::exact_geometry(), 2),
        (SocpSettings::default(), 2),
    ] {
        let mut s = SocpSolver::new(SocpSettings {
            max_iter: 1,
            ..settings
        });
        assert!(matches!(s.solve(&b), Err(SolveError::Inaccurate { .. })));
        assert_eq!(s.retries, attempts);
    }
    // a solvable program needs no retry, and the fast settings find the same optimum
    let mut s = SocpSolver::new(SocpSettings::exact_geometry());
    let sol = s.solve(&b).unwrap();
    assert_eq!(s.retries, 0);
    assert!((sol.objective + 2f64.sqrt()).abs() < 1e-6);
}

/// A program that the default tolerances cannot finish within the iteration limit but the
/// looser fallback can is rescued, and the answer still passes the residual check.
#[test]
fn looser_fallback_rescues_an_inaccurate_stop() {
    let b = unit_disc_problem();
    let iterations = |tol: f64| {
        SocpSolver::new(SocpSettings {
            tol_feas: tol,
            tol_gap_rel: tol,
            ..SocpSettings::default()
        })
        .solve(&b)
        .unwrap()
        .iterations
    };
    let (tight, loose) = (iterations(1e-8), iterations(1e-6));
    assert!(
        loose < tight,
        "1e-6 needs {loose}, 1e-8 needs {tight} iterations"
    );
    // stopped at the limit, Clarabel calls the point AlmostSolved: accept none here
    let limited = SocpSettings {
        max_iter: loose,
        almost_solved_violation: -1.0,
        ..SocpSettings::default()
    };
    let mut s = SocpSolver::new(SocpSettings {
        fallbacks: false,
        ..limited
    });
    let first = s.solve(&b);
    assert!(
        matches!(first, Err(SolveError::Inaccurate { .. })),
        "{tight} {loose} {:?}",
        first.map(|s| (s.status, s.iterations, s.violation))
    );
    let mut s = SocpSolver::new(limited);
    let sol = s.solve(&b).unwrap();
    assert_eq!(
        s.retries, 2,
        "other refinement first, then the looser tolerances"
    );
    assert!(sol.violation <= 1e-6, "{}", sol.violation);
    assert!(
        (sol.objective + 2f64.sqrt()).abs() < 1e-5,
        "{}",
        sol.objective
    );
}

/// A variable index beyond the problem is a setup error naming it, not a panic.
#[test]
fn out_of_range_variables_are_setup_errors() {
    let mut square = ProblemBuilder::new(2);
    square.add_square_cost(5, 1.0);
    let mut linear = ProblemBuilder::new(2);
    linear.add_linear_cost(4, 1.0);
    let mut row = ProblemBuilder::new(2);
    row.nonneg(Lin::var(0, 1.0));
    row.soc(Lin::var(1, 1.0), &[Lin::var(7, 1.0)]);
    for (b, settings, needles) in [
        (&square, SocpSettings::default(), &["(5, 5)"][..]),
        (&linear, SocpSettings::default(), &["entry 4"][..]),
        (
            &row,
            SocpSettings::exact_geometry(),
            &["row 2", "variable 7"][..],
        ),
    ] {
        let e = SocpSolver::new(settings).solve(b).unwrap_err();
        assert!(
            matches!(&e, SolveError::Setup(m) if needles.iter().all(|n| m.contains(n))),
            "{e}"
        );
    }
}

#[test]
fn infeasible_is_reported() {
    let mut b = ProblemBuilder::new(1);
    b.nonneg(Lin::var(0, 1.0).plus_const(-2.0)); // x ≥ 2
    b.nonneg(Lin::var(0, -1.0).plus_const(1.0)); // x ≤ 1
    let mut s = SocpSolver::new(SocpSettings::default());
    assert!(matches!(s.solve(&b), Err(SolveError::Infeasible(_))));
}

/// min t s.t. x² ≤ t·1, x = 3 → t = 9 (an equality cone and a rotated cone).
fn rotated_cone_problem() -> ProblemBuilder {
    let mut b = ProblemBuilder::new(2);
    b.add_linear_cost(1, 1.0);
    b.zero(Lin::var(0, 1.0).plus_const(-3.0));
    b.rotated_soc(
        Lin::var(1, 1.0),
        Lin::constant_only(1.0),
        &[Lin::var(0, 1.0)],
    );
    b
}

#[test]
fn rotated_cone() {
    let b = rotated_cone_problem();
    let sol = SocpSolver::new(SocpSettings::default()).solve(&b).unwrap();
    assert!((sol.x[1] - 9.0).abs() < 1e-5, "{}", sol.x[1]);
}
