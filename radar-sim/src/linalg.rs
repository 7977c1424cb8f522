//! Small dense complex linear algebra: Hermitian positive-definite solve by Cholesky
//! (nalgebra).

use nalgebra::linalg::Cholesky;
use nalgebra::{DMatrix, DVector};
use rustfft::num_complex::Complex64;

/// Solves `A x = b` for Hermitian positive-definite `A` (n × n, row-major; its lower triangle
/// and the real part of its diagonal are read). Returns `None` when `A` is not numerically
/// positive definite.
pub fn cholesky_solve(a: &[Complex64], b: &[Complex64]) -> Option<Vec<Complex64>> {
    let n = b.len();
    if a.len() != n * n {
        return None;
    }
    // row-major → column-major; the diagonal exactly real, as a Hermitian matrix's is (sums
    // of products may leave rounding in its imaginary part)
    let m = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            Complex64::new(a[i * n + i].re, 0.0)
        } else {
            a[i * n + j]
        }
    });
    let chol = Cholesky::new(m)?;
    // nalgebra takes the complex square root of each pivot, so a negative pivot (A not
    // positive definite) shows as a non-real diagonal of L, not as `None`; a positive one
    // stays exactly real (the updates subtract |L_jk|², whose imaginary part is exactly 0)
    let l = chol.l_dirty();
    let positive = (0..n).all(|j| {
        let d = l[(j, j)];
        d.im == 0.0 && d.re > 0.0 && d.re.is_finite()
    });
    if !positive {
        return None;
    }
    let x = chol.solve(&DVector::from_column_slice(b));
    Some(x.iter().copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn c(r: f64, i: f64) -> Complex64 {
        Complex64::new(r, i)
    }

    #[test]
    fn solves_hermitian_system() {
        let a = vec![
            c(4.0, 0.0),
            c(1.0, 1.0),
            c(0.0, -0.5),
            c(1.0, -1.0),
            c(3.0, 0.0),
            c(0.2, 0.0),
            c(0.0, 0.5),
            c(0.2, 0.0),
            c(2.0, 0.0),
        ];
        let x = vec![c(1.0, 2.0), c(-1.0, 0.5), c(0.3, -0.7)];
        let b: Vec<Complex64> = (0..3)
            .map(|i| (0..3).map(|j| a[i * 3 + j] * x[j]).sum())
            .collect();
        let got = cholesky_solve(&a, &b).unwrap();
        for (g, w) in got.iter().zip(&x) {
            assert!((g - w).norm() < 1e-12);
        }
        let bad = vec![c(1.0, 0.0), c(2.0, 0.0), c(2.0, 0.0), c(1.0, 0.0)];
        assert!(cholesky_solve(&bad, &[c(1.0, 0.0), c(1.0, 0.0)]).is_none());
    }

    /// Not positive definite in every way: a negative or zero pivot, NaN, a wrong size.
    #[test]
    fn refuses_what_is_not_positive_definite() {
        let one = [c(1.0, 0.0), c(1.0, 0.0)];
        for a in [
            vec![c(-1.0, 0.0), c(0.0, 0.0), c(0.0, 0.0), c(1.0, 0.0)],
            vec![c(1.0, 0.0), c(0.0, 0.0), c(0.0, 0.0), c(0.0, 0.0)],
            vec![c(1.0, 0.0), c(0.0, 1.0), c(0.0, -1.0), c(1.0, 0.0)],
            vec![c(1.0, 0.0), c(f64::NAN, 0.0), c(f64::NAN, 0.0), c(1.0, 0.0)],
        ] {
            assert!(cholesky_solve(&a, &one).is_none(), "{a:?}");
        }
        assert!(cholesky_solve(&[c(1.0, 0.0)], &one).is_none());
        assert_eq!(cholesky_solve(&[], &[]), Some(vec![]));
    }

    /// The factorisation written out (row by row, as the canceller had it before nalgebra):
    /// the reference for the comparison below.
    fn reference_solve(a: &[Complex64], b: &[Complex64]) -> Vec<Complex64> {
        let n = b.len();
        let mut l = vec![c(0.0, 0.0); n * n];
        for j in 0..n {
            let d = a[j * n + j].re - (0..j).map(|k| l[j * n + k].norm_sqr()).sum::<f64>();
            let djj = d.sqrt();
            l[j * n + j] = c(djj, 0.0);
            for i in j + 1..n {
                let s = a[i * n + j]
                    - (0..j)
                        .map(|k| l[i * n + k] * l[j * n + k].conj())
                        .sum::<Complex64>();
                l[i * n + j] = s / djj;
            }
        }
        let mut y = b.to_vec();
        for i in 0..n {
            let s = y[i] - (0..i).map(|k| l[i * n + k] * y[k]).sum::<Complex64>();
            y[i] = s / l[i * n + i].re;
        }
        for i in (0..n).rev() {
            let s = y[i]
                - (i + 1..n)
                    .map(|k| l[k * n + i].conj() * y[k])
                    .sum::<Complex64>();
            y[i] = s / l[i * n + i].re;
        }
        y
    }

    /// Loaded Gram matrices like the canceller's (20 taps, 1e-6 loading): the same solution
    /// as the written-out factorisation to within rounding × the condition number.
    #[test]
    fn agrees_with_the_written_out_factorisation() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for n in [1usize, 2, 7, 20] {
            let rows = 3 * n;
            let basis: Vec<Complex64> = (0..rows * n)
                .map(|_| c(rng.gen::<f64>() - 0.5, rng.gen::<f64>() - 0.5))
                .collect();
            let mut g = vec![c(0.0, 0.0); n * n];
            for i in 0..n {
                for j in 0..n {
                    g[i * n + j] = (0..rows)
                        .map(|r| basis[r * n + i].conj() * basis[r * n + j])
                        .sum();
                }
            }
            let mean = (0..n).map(|i| g[i * n + i].re).sum::<f64>() / n as f64;
            for i in 0..n {
                g[i * n + i] += c(1e-6 * mean, 0.0);
            }
            let b: Vec<Complex64> = (0..n)
                .map(|_| c(rng.gen::<f64>(), rng.gen::<f64>()))
                .collect();
            let got = cholesky_solve(&g, &b).unwrap();
            let want = reference_solve(&g, &b);
            let scale = want.iter().map(|v| v.norm()).fold(0.0, f64::max);
            for (x, y) in got.iter().zip(&want) {
                assert!((x - y).norm() <= 1e-10 * scale, "n = {n}: {x} vs {y}");
            }
        }
    }
}
