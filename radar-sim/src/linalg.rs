//! Small dense complex linear algebra: Hermitian positive-definite solve by Cholesky.

use rustfft::num_complex::Complex64;

/// Solves `A x = b` for Hermitian positive-definite `A` (n × n, row-major) in place of a copy.
/// Returns `None` when `A` is not numerically positive definite.
pub fn cholesky_solve(a: &[Complex64], b: &[Complex64]) -> Option<Vec<Complex64>> {
    let n = b.len();
    if a.len() != n * n {
        return None;
    }
    // L lower-triangular with A = L L^H
    let mut l = vec![Complex64::new(0.0, 0.0); n * n];
    for j in 0..n {
        let mut d = a[j * n + j].re;
        for k in 0..j {
            d -= l[j * n + k].norm_sqr();
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let djj = d.sqrt();
        l[j * n + j] = Complex64::new(djj, 0.0);
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= l[i * n + k] * l[j * n + k].conj();
            }
            l[i * n + j] = s / djj;
        }
    }
    // forward: L y = b
    let mut y = b.to_vec();
    for i in 0..n {
        let mut s = y[i];
        for k in 0..i {
            s -= l[i * n + k] * y[k];
        }
        y[i] = s / l[i * n + i].re;
    }
    // backward: L^H x = y
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= l[k * n + i].conj() * y[k];
        }
        y[i] = s / l[i * n + i].re;
    }
    Some(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_hermitian_system() {
        let c = |r: f64, i: f64| Complex64::new(r, i);
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
}
