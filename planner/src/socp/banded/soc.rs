//! The second-order cone {(u₀, u₁) : u₀ ≥ ‖u₁‖}: Nesterov–Todd scaling, Jordan algebra and the
//! step to its boundary (Vandenberghe, "The CVXOPT linear and quadratic cone program solvers",
//! 2010, §4).
//!
//! The scaling is W = β Q(w̄) with w̄ᵀJw̄ = 1 (J = diag(1, −1, …, −1)) and
//! Q(w̄) = [w̄₀ w̄₁ᵀ; w̄₁ I + w̄₁w̄₁ᵀ/(1 + w̄₀)], so that Q(w̄)² = 2w̄w̄ᵀ − J and
//! W⁻¹ = β⁻¹ J Q(w̄) J. It maps z to the same point as W⁻¹ maps s: λ = W z = W⁻¹ s.

/// √(u₀² − ‖u₁‖²), or `None` when u is not in the cone's interior.
pub fn jnorm(u: &[f64]) -> Option<f64> {
    let t = norm(&u[1..]);
    let d = (u[0] - t) * (u[0] + t);
    (u[0] > t && d > 0.0 && d.is_finite()).then(|| d.sqrt())
}

fn norm(u: &[f64]) -> f64 {
    u.iter().map(|v| v * v).sum::<f64>().sqrt()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The NT scaling of one cone: β and w̄ (written to `w`), from interior points s and z.
/// Returns β, or `None` when s or z is not interior.
pub fn scaling(s: &[f64], z: &[f64], w: &mut [f64]) -> Option<f64> {
    let aa = jnorm(s)?;
    let bb = jnorm(z)?;
    let sz = dot(s, z) / (aa * bb);
    let gamma = ((1.0 + sz) / 2.0).sqrt();
    let c = 1.0 / (2.0 * gamma);
    w[0] = (s[0] / aa + z[0] / bb) * c;
    for i in 1..s.len() {
        w[i] = (s[i] / aa - z[i] / bb) * c;
    }
    Some((aa / bb).sqrt())
}

/// y ← W y.
pub fn apply_w(beta: f64, w: &[f64], y: &mut [f64]) {
    let w1y1 = dot(&w[1..], &y[1..]);
    let y0 = y[0];
    let c = y0 + w1y1 / (1.0 + w[0]);
    y[0] = beta * (w[0] * y0 + w1y1);
    for i in 1..y.len() {
        y[i] = beta * (y[i] + c * w[i]);
    }
}

/// y ← W⁻¹ y.
pub fn apply_winv(beta: f64, w: &[f64], y: &mut [f64]) {
    let w1y1 = dot(&w[1..], &y[1..]);
    let y0 = y[0];
    let c = -y0 + w1y1 / (1.0 + w[0]);
    y[0] = (w[0] * y0 - w1y1) / beta;
    for i in 1..y.len() {
        y[i] = (y[i] + c * w[i]) / beta;
    }
}

/// out = u ∘ v (Jordan product: (uᵀv, u₀v₁ + v₀u₁)).
pub fn product(u: &[f64], v: &[f64], out: &mut [f64]) {
    out[0] = dot(u, v);
    for i in 1..u.len() {
        out[i] = u[0] * v[i] + v[0] * u[i];
    }
}

/// out = λ ⋄ r, the solution x of λ ∘ x = r (λ interior).
pub fn inverse_product(lambda: &[f64], r: &[f64], out: &mut [f64]) {
    let t = norm(&lambda[1..]);
    let det = (lambda[0] - t) * (lambda[0] + t);
    let x0 = (lambda[0] * r[0] - dot(&lambda[1..], &r[1..])) / det;
    out[0] = x0;
    for i in 1..lambda.len() {
        out[i] = (r[i] - x0 * lambda[i]) / lambda[0];
    }
}

/// The largest α ≥ 0 with u + α d in the cone (u interior); `f64::INFINITY` when every α is.
pub fn max_step(u: &[f64], d: &[f64]) -> f64 {
    // f(α) = (u₀ + α d₀)² − ‖u₁ + α d₁‖² = c + b α + a α², f(0) = c > 0
    let a = d[0] * d[0] - dot(&d[1..], &d[1..]);
    let b = 2.0 * (u[0] * d[0] - dot(&u[1..], &d[1..]));
    let t = norm(&u[1..]);
    let c = (u[0] - t) * (u[0] + t);
    let root = smallest_positive_root(a, b, c);
    // the head must also stay positive (f ≥ 0 also holds on the negative cone)
    let head = if d[0] < 0.0 {
        -u[0] / d[0]
    } else {
        f64::INFINITY
    };
    root.min(head)
}

/// Smallest positive root of a α² + b α + c (c > 0), or infinity when there is none.
fn smallest_positive_root(a: f64, b: f64, c: f64) -> f64 {
    if a == 0.0 {
        return if b < 0.0 { -c / b } else { f64::INFINITY };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return f64::INFINITY;
    }
    let sq = disc.sqrt();
    // numerically stable pair of roots
    let qq = -0.5 * (b + b.signum() * sq);
    let (r1, r2) = if qq != 0.0 {
        (qq / a, c / qq)
    } else {
        (0.0, 0.0)
    };
    [r1, r2]
        .into_iter()
        .filter(|r| *r > 0.0 && r.is_finite())
        .fold(f64::INFINITY, f64::min)
}

/// min{t : u + t e ∈ cone} = −(u₀ − ‖u₁‖) (e = (1, 0, …)).
pub fn min_shift(u: &[f64]) -> f64 {
    norm(&u[1..]) - u[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn interior(v: &[f64], margin: f64) -> Vec<f64> {
        let mut u = v.to_vec();
        u[0] = norm(&v[1..]) + margin;
        u
    }

    proptest! {
        /// W z = W⁻¹ s, W W⁻¹ = I, λ ⋄ (λ ∘ x) = x, and the step to the boundary lands on it.
        #[test]
        fn nt_scaling_and_jordan_algebra(
            sv in proptest::collection::vec(-3.0f64..3.0, 4),
            zv in proptest::collection::vec(-3.0f64..3.0, 4),
            xv in proptest::collection::vec(-3.0f64..3.0, 4),
            ms in 0.01f64..2.0,
            mz in 0.01f64..2.0,
        ) {
            let s = interior(&sv, ms);
            let z = interior(&zv, mz);
            let mut w = vec![0.0; 4];
            let beta = scaling(&s, &z, &mut w).unwrap();
            prop_assert!((jnorm(&w).unwrap() - 1.0).abs() < 1e-9);
            let mut wz = z.clone();
            apply_w(beta, &w, &mut wz);
            let mut wis = s.clone();
            apply_winv(beta, &w, &mut wis);
            for i in 0..4 {
                prop_assert!((wz[i] - wis[i]).abs() < 1e-8 * (1.0 + wz[i].abs()), "{wz:?} {wis:?}");
            }
            let mut y = xv.clone();
            apply_w(beta, &w, &mut y);
            apply_winv(beta, &w, &mut y);
            for i in 0..4 {
                prop_assert!((y[i] - xv[i]).abs() < 1e-9 * (1.0 + xv[i].abs()));
            }
            let mut r = vec![0.0; 4];
            product(&wz, &xv, &mut r);
            let mut back = vec![0.0; 4];
            inverse_product(&wz, &r, &mut back);
            for i in 0..4 {
                prop_assert!((back[i] - xv[i]).abs() < 1e-7 * (1.0 + xv[i].abs()));
            }
            let alpha = max_step(&s, &xv);
            if alpha.is_finite() {
                let at: Vec<f64> = (0..4).map(|i| s[i] + alpha * xv[i]).collect();
                prop_assert!((at[0] - norm(&at[1..])).abs() < 1e-7 * (1.0 + at[0].abs()));
                let inside: Vec<f64> = (0..4).map(|i| s[i] + 0.99 * alpha * xv[i]).collect();
                prop_assert!(inside[0] > norm(&inside[1..]));
            } else {
                let far: Vec<f64> = (0..4).map(|i| s[i] + 1e6 * xv[i]).collect();
                prop_assert!(far[0] >= norm(&far[1..]) - 1e-6 * far[0].abs());
            }
        }
    }
}
