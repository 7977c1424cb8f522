//! The expected least distance E\[d_min\] from a designated object to the other N − 1 objects of a
//! uniform (Poisson, conditioned on N) point set in a disk of radius R (paper Section II-A).
//!
//! erratum 1 (docs/paper-notes.md): the paper's CDF (eq. `cpdf_of_l`) lacks a factor l in its last term. The
//! correct CDF of the distance between two uniform points in a disk is
//! F(l) = 1 + (2/π)(l²/R² − 1) acos(l/2R) − (l/(πR))(1 + l²/(2R²)) sqrt(1 − l²/(4R²)).
//! [`expected_dmin_m`] integrates E = ∫₀^{2R} (1 − F(l))^{N−1} dl for either form
//! ([`CdfForm::Correct`] or [`CdfForm::AsPrinted`]); [`expected_dmin_monte_carlo_m`] samples it.

use std::f64::consts::PI;

use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// Which CDF of the pairwise distance to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CdfForm {
    /// The correct CDF (factor l in the last term).
    Correct,
    /// The paper's eq. (cpdf_of_l) as printed (its last term lacks the factor l). Reproduces the
    /// paper's "≈ 20 m at R = 5000 m" but is not a distribution (F(0) = −1/(πR)).
    AsPrinted,
}

/// Invalid input to the E\[d_min\] functions.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DminError {
    /// The radius must be finite and positive.
    #[error("radius_m = {0}: must be a finite number > 0")]
    Radius(f64),
    /// At least two objects are needed for a least distance.
    #[error("objects = {0}: at least 2 objects are needed")]
    Objects(u64),
    /// At least one Monte Carlo trial.
    #[error("trials = 0: at least one Monte Carlo trial is needed")]
    Trials,
    /// The quadrature did not reach its tolerance within its budget of integrand evaluations
    /// (the as-printed integrand for very large N, which changes sign and spans hundreds of
    /// orders of magnitude).
    #[error("objects = {objects}: the quadrature of E[d_min] did not converge within {evaluations} evaluations")]
    Quadrature {
        /// N.
        objects: u64,
        /// The evaluation budget.
        evaluations: usize,
    },
}

/// Most integrand evaluations one E\[d_min\] quadrature may spend (the correct formula needs a
/// few thousand at any N).
pub const QUADRATURE_BUDGET: usize = 20_000_000;

/// CDF of the distance between two points drawn uniformly in a disk of radius `r`.
pub fn pair_distance_cdf(l: f64, r: f64, form: CdfForm) -> f64 {
    if l <= 0.0 {
        return match form {
            CdfForm::Correct => 0.0,
            CdfForm::AsPrinted => cdf_expr(0.0, r, form),
        };
    }
    if l >= 2.0 * r {
        return 1.0;
    }
    cdf_expr(l, r, form)
}

fn cdf_expr(l: f64, r: f64, form: CdfForm) -> f64 {
    let x = l / (2.0 * r);
    let factor = match form {
        CdfForm::Correct => l,
        CdfForm::AsPrinted => 1.0,
    };
    1.0 + (2.0 / PI) * (l * l / (r * r) - 1.0) * x.acos()
        - factor / (PI * r) * (1.0 + l * l / (2.0 * r * r)) * (1.0 - x * x).max(0.0).sqrt()
}

/// PDF of the pairwise distance (the paper's footnote, which is correct):
/// f(l) = (2l/R²)((2/π) acos(l/2R) − (l/(πR)) sqrt(1 − l²/(4R²))).
pub fn pair_distance_pdf(l: f64, r: f64) -> f64 {
    if !(0.0..=2.0 * r).contains(&l) {
        return 0.0;
    }
    let x = l / (2.0 * r);
    2.0 * l / (r * r) * ((2.0 / PI) * x.acos() - l / (PI * r) * (1.0 - x * x).max(0.0).sqrt())
}

fn check(radius_m: f64, objects: u64) -> Result<(), DminError> {
    if !(radius_m.is_finite() && radius_m > 0.0) {
        return Err(DminError::Radius(radius_m));
    }
    if objects < 2 {
        return Err(DminError::Objects(objects));
    }
    Ok(())
}

/// E\[d_min\] = ∫₀^{2R} (1 − F(l))^{N−1} dl, m, by adaptive Simpson quadrature.
///
/// With [`CdfForm::AsPrinted`] the base 1 − F exceeds 1 near l = 0, so the value may be
/// meaningless (or not finite) for large N.
pub fn expected_dmin_m(radius_m: f64, objects: u64, form: CdfForm) -> Result<f64, DminError> {
    check(radius_m, objects)?;
    let n1 = (objects - 1) as f64;
    let f = |l: f64| {
        let s = 1.0 - pair_distance_cdf(l, radius_m, form);
        match form {
            // 1 − F ∈ [0, 1]: use exp/ln for large N
            CdfForm::Correct => {
                if s <= 0.0 {
                    0.0
                } else {
                    (n1 * s.ln()).exp()
                }
            }
            // literal: the base can exceed 1 near l = 0
            CdfForm::AsPrinted => s.signum().powf(n1) * (n1 * s.abs().ln()).exp(),
        }
    };
    // The integrand decays on the scale R/sqrt(N); integrate over doubling segments.
    let mut total = 0.0;
    let mut a = 0.0;
    let mut w = (radius_m / (n1.sqrt() * 20.0)).min(2.0 * radius_m);
    let mut budget = QUADRATURE_BUDGET;
    while a < 2.0 * radius_m {
        let b = (a + w).min(2.0 * radius_m);
        let part = adaptive_simpson(&f, a, b, 1e-12 * (1.0 + total), 40, &mut budget).ok_or(
            DminError::Quadrature {
                objects,
                evaluations: QUADRATURE_BUDGET,
            },
        )?;
        total += part;
        if part.abs() < 1e-15 * total && f(b).abs() < 1e-15 {
            break;
        }
        a = b;
        w *= 2.0;
    }
    Ok(total)
}

/// Monte Carlo E\[d_min\]: `trials` sets of N uniform points in the disk, least distance from the
/// first (designated) point to the others. Returns (mean, standard error), m.
pub fn expected_dmin_monte_carlo_m(
    radius_m: f64,
    objects: u64,
    trials: u32,
    seed: u64,
) -> Result<(f64, f64), DminError> {
    check(radius_m, objects)?;
    if trials == 0 {
        return Err(DminError::Trials);
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let point = |rng: &mut rand_chacha::ChaCha8Rng| {
        let rho = radius_m * rng.gen::<f64>().sqrt();
        let phi = rng.gen::<f64>() * std::f64::consts::TAU;
        (rho * phi.cos(), rho * phi.sin())
    };
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..trials {
        let (x0, y0) = point(&mut rng);
        let mut best = f64::INFINITY;
        for _ in 1..objects {
            let (x, y) = point(&mut rng);
            best = best.min((x - x0).hypot(y - y0));
        }
        sum += best;
        sum2 += best * best;
    }
    let n = trials as f64;
    let mean = sum / n;
    let var = (sum2 / n - mean * mean).max(0.0) * n / (n - 1.0).max(1.0);
    Ok((mean, (var / n).sqrt()))
}

fn simpson(fa: f64, fm: f64, fb: f64, a: f64, b: f64) -> f64 {
    (b - a) / 6.0 * (fa + 4.0 * fm + fb)
}

/// Adaptive Simpson quadrature of `f` over [a, b] with an explicit stack (bounded depth, no
/// recursion); `None` when more than `budget` evaluations
/// would be needed (the budget left is written back).
fn adaptive_simpson(
    f: &impl Fn(f64) -> f64,
    a: f64,
    b: f64,
    tol: f64,
    max_depth: u32,
    budget: &mut usize,
) -> Option<f64> {
    *budget = budget.checked_sub(3)?;
    let fa = f(a);
    let fb = f(b);
    let m = 0.5 * (a + b);
    let fm = f(m);
    let whole = simpson(fa, fm, fb, a, b);
    let mut stack = vec![(a, b, fa, fm, fb, whole, tol, 0u32)];
    let mut total = 0.0;
    while let Some((a, b, fa, fm, fb, whole, tol, depth)) = stack.pop() {
        *budget = budget.checked_sub(2)?;
        let m = 0.5 * (a + b);
        let lm = 0.5 * (a + m);
        let rm = 0.5 * (m + b);
        let flm = f(lm);
        let frm = f(rm);
        let left = simpson(fa, flm, fm, a, m);
        let right = simpson(fm, frm, fb, m, b);
        let delta = left + right - whole;
        // The tolerance is also relative to the piece itself: the as-printed integrand reaches
        // 1e300 for large N, where an absolute 1e-12 would split every piece max_depth levels
        // deep (2^40 pieces: it never ended). A non-finite sample ends the refinement too:
        // splitting cannot make it finite.
        let accept = 15.0 * tol.max(1e-13 * (left + right).abs());
        if depth >= max_depth || delta.abs() <= accept || !delta.is_finite() {
            total += left + right + delta / 15.0;
        } else {
            stack.push((a, m, fa, flm, fm, left, tol / 2.0, depth + 1));
            stack.push((m, b, fm, frm, fb, right, tol / 2.0, depth + 1));
        }
    }
    Some(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn as_printed_with_huge_values_ends() {
        // Before the fix the quadrature split pieces of the as-printed integrand 40 levels deep
        // (an absolute tolerance of 1e-12 it could not reach) and did not end for N ≥ 50 000;
        // the correct formula stays close to its large-N asymptote.
        for objects in [50_000, 100_000, 1_000_000] {
            match expected_dmin_m(5000.0, objects, CdfForm::AsPrinted) {
                Ok(v) => assert!(v.is_nan() || v >= 0.0, "{objects}: {v}"),
                Err(e) => assert!(matches!(e, DminError::Quadrature { .. }), "{e}"),
            }
        }
        let correct = expected_dmin_m(5000.0, 50_000, CdfForm::Correct).unwrap();
        // E[d_min] ≈ R sqrt(π/N)/2 for large N: 19.8 m
        let asymptote = 0.5 * 5000.0 * (std::f64::consts::PI / 50_000.0).sqrt();
        assert!(
            (correct / asymptote - 1.0).abs() < 0.02,
            "{correct} vs {asymptote}"
        );
    }

    #[test]
    fn correct_cdf_is_a_distribution() {
        let r = 100.0;
        assert_eq!(pair_distance_cdf(0.0, r, CdfForm::Correct), 0.0);
        assert!((cdf_expr(2.0 * r, r, CdfForm::Correct) - 1.0).abs() < 1e-12);
        // derivative of the CDF equals the footnote PDF
        for l in [1.0, 10.0, 50.0, 120.0, 190.0] {
            let h = 1e-4;
            let d = (pair_distance_cdf(l + h, r, CdfForm::Correct)
                - pair_distance_cdf(l - h, r, CdfForm::Correct))
                / (2.0 * h);
            assert!((d - pair_distance_pdf(l, r)).abs() < 1e-7, "l={l}");
        }
        // small l: F ≈ l²/R²
        let l = 0.01 * r;
        assert!((pair_distance_cdf(l, r, CdfForm::Correct) / (l * l / (r * r)) - 1.0).abs() < 0.01);
    }

    #[test]
    fn printed_cdf_is_not_zero_at_zero() {
        let r = 5000.0;
        assert!((pair_distance_cdf(0.0, r, CdfForm::AsPrinted) + 1.0 / (PI * r)).abs() < 1e-15);
    }

    /// The printed formula yields the paper's "≈ 20 m at R = 5000 m" (N = 800..1200);
    /// the correct one gives several times more.
    #[test]
    fn printed_gives_about_20_m_correct_gives_much_more() {
        for n in [800, 1000, 1200] {
            let printed = expected_dmin_m(5000.0, n, CdfForm::AsPrinted).unwrap();
            assert!((10.0..25.0).contains(&printed), "N={n}: printed {printed}");
            let correct = expected_dmin_m(5000.0, n, CdfForm::Correct).unwrap();
            // ≈ (√π/2) R/√(N−1) for large N
            let approx = PI.sqrt() / 2.0 * 5000.0 / ((n - 1) as f64).sqrt();
            assert!(
                (correct / approx - 1.0).abs() < 0.05,
                "N={n}: {correct} vs {approx}"
            );
            assert!(correct > 5.0 * printed);
        }
    }

    #[test]
    fn correct_formula_matches_monte_carlo() {
        // The formula treats the N−1 distances as independent; in the disk they are only
        // conditionally so (edge effects), which MC shows as a small positive bias.
        for (r, n) in [(5000.0, 1000u64), (1000.0, 50)] {
            let f = expected_dmin_m(r, n, CdfForm::Correct).unwrap();
            let (mc, se) = expected_dmin_monte_carlo_m(r, n, 4000, 7).unwrap();
            assert!(
                (mc - f).abs() < 0.05 * f + 4.0 * se,
                "R={r} N={n}: formula {f}, MC {mc} ± {se}"
            );
        }
    }

    #[test]
    fn bad_input_is_named() {
        assert_eq!(
            expected_dmin_m(-1.0, 10, CdfForm::Correct),
            Err(DminError::Radius(-1.0))
        );
        assert_eq!(
            expected_dmin_m(1.0, 1, CdfForm::Correct),
            Err(DminError::Objects(1))
        );
        assert_eq!(
            expected_dmin_monte_carlo_m(1.0, 5, 0, 0),
            Err(DminError::Trials)
        );
    }
}
