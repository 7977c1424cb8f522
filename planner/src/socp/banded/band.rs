//! Symmetric band matrices: assembly, products, Cholesky factorisation and solves.
//!
//! Only the lower band is stored, row by row: row i holds columns i − b … i (b = half
//! bandwidth), so that both the factorisation's inner products and the triangular solves run
//! over contiguous memory. Cost: O(n b²) to factor, O(n b) per solve.

/// A symmetric n × n matrix with half bandwidth `bw` (entries with |i − j| > bw are zero).
#[derive(Debug, Clone)]
pub struct BandMatrix {
    n: usize,
    bw: usize,
    /// Row-major lower band: entry (i, j), i − bw ≤ j ≤ i, at `i (bw + 1) + j + bw − i`.
    a: Vec<f64>,
}

impl BandMatrix {
    /// The zero matrix.
    pub fn new(n: usize, bw: usize) -> Self {
        Self {
            n,
            bw,
            a: vec![0.0; n * (bw + 1)],
        }
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Sets every entry to zero.
    pub fn clear(&mut self) {
        self.a.iter_mut().for_each(|v| *v = 0.0);
    }

    #[inline]
    fn idx(&self, i: usize, j: usize) -> usize {
        i * (self.bw + 1) + j + self.bw - i
    }

    /// Adds `v` to entries (i, j) and (j, i) (once on the diagonal). Entries outside the band
    /// are a caller bug: they are ignored in release builds (the caller sizes the band from the
    /// same structure it assembles).
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        debug_assert!(
            i - j <= self.bw && i < self.n,
            "({i}, {j}) outside the band"
        );
        if i - j <= self.bw && i < self.n {
            let k = self.idx(i, j);
            self.a[k] += v;
        }
    }

    /// Entry (i, j) (zero outside the band).
    #[cfg(test)]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i - j <= self.bw && i < self.n {
            self.a[self.idx(i, j)]
        } else {
            0.0
        }
    }

    /// Largest diagonal entry.
    pub fn max_diag(&self) -> f64 {
        (0..self.n).fold(0.0f64, |m, i| m.max(self.a[self.idx(i, i)]))
    }

    /// y = A x.
    #[cfg(test)]
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for i in 0..self.n {
            let j0 = i.saturating_sub(self.bw);
            let row = &self.a[self.idx(i, j0)..=self.idx(i, i)];
            let mut acc = 0.0;
            for (k, &aij) in row.iter().enumerate() {
                let j = j0 + k;
                acc += aij * x[j];
                if j < i {
                    y[j] += aij * x[i];
                }
            }
            y[i] += acc;
        }
    }
}

/// The Cholesky factor L (A = L Lᵀ) of a [`BandMatrix`], same band and storage.
#[derive(Debug, Clone)]
pub struct BandCholesky {
    n: usize,
    bw: usize,
    l: Vec<f64>,
}

/// The factorisation met a pivot that is not positive (the matrix is not positive definite to
/// working precision); names the row.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("band Cholesky: pivot {pivot:e} at row {row} is not positive")]
pub struct NotPositiveDefinite {
    /// Row of the failed pivot.
    pub row: usize,
    /// Its value.
    pub pivot: f64,
}

impl BandCholesky {
    /// Storage for factors of n × n matrices with half bandwidth `bw`.
    pub fn new(n: usize, bw: usize) -> Self {
        Self {
            n,
            bw,
            l: vec![0.0; n * (bw + 1)],
        }
    }

    #[inline]
    fn idx(&self, i: usize, j: usize) -> usize {
        i * (self.bw + 1) + j + self.bw - i
    }

    /// Factors `a` (same dimension and bandwidth as this storage).
    pub fn factor(&mut self, a: &BandMatrix) -> Result<(), NotPositiveDefinite> {
        debug_assert!(a.n == self.n && a.bw == self.bw);
        self.l.copy_from_slice(&a.a);
        let bw = self.bw;
        for i in 0..self.n {
            let j0 = i.saturating_sub(bw);
            for j in j0..=i {
                // L_ij = (A_ij − Σ_k L_ik L_jk) / L_jj over k from max(i−bw, 0) to j − 1
                let k0 = j0.max(j.saturating_sub(bw));
                let ri = self.idx(i, k0);
                let rj = self.idx(j, k0);
                let len = j - k0;
                let mut acc = self.l[self.idx(i, j)];
                let (li, lj) = (&self.l[ri..ri + len], &self.l[rj..rj + len]);
                for (a, b) in li.iter().zip(lj) {
                    acc -= a * b;
                }
                let k = self.idx(i, j);
                if j < i {
                    self.l[k] = acc / self.l[self.idx(j, j)];
                } else {
                    if !(acc > 0.0 && acc.is_finite()) {
                        return Err(NotPositiveDefinite { row: i, pivot: acc });
                    }
                    self.l[k] = acc.sqrt();
                }
            }
        }
        Ok(())
    }

    /// Solves A x = b in place (b becomes x).
    pub fn solve(&self, b: &mut [f64]) {
        let bw = self.bw;
        // L y = b
        for i in 0..self.n {
            let j0 = i.saturating_sub(bw);
            let row = &self.l[self.idx(i, j0)..self.idx(i, i)];
            let mut acc = b[i];
            for (a, y) in row.iter().zip(&b[j0..i]) {
                acc -= a * y;
            }
            b[i] = acc / self.l[self.idx(i, i)];
        }
        // Lᵀ x = y, column-oriented over the rows of L
        for i in (0..self.n).rev() {
            let xi = b[i] / self.l[self.idx(i, i)];
            b[i] = xi;
            let j0 = i.saturating_sub(bw);
            let row = &self.l[self.idx(i, j0)..self.idx(i, i)];
            for (a, y) in row.iter().zip(&mut b[j0..i]) {
                *y -= a * xi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn dense(a: &BandMatrix) -> Vec<Vec<f64>> {
        (0..a.n)
            .map(|i| (0..a.n).map(|j| a.get(i, j)).collect())
            .collect()
    }

    proptest! {
        /// A random diagonally dominant band matrix: the factor solves A x = b to rounding, and
        /// the band product agrees with the dense one.
        #[test]
        fn cholesky_solves_band_systems(
            n in 1usize..40,
            bw in 0usize..6,
            seed in proptest::collection::vec(-1.0f64..1.0, 40 * 7 + 40),
        ) {
            let bw = bw.min(n.saturating_sub(1));
            let mut a = BandMatrix::new(n, bw);
            let mut k = 0;
            for i in 0..n {
                for j in i.saturating_sub(bw)..i {
                    a.add(i, j, seed[k % seed.len()]);
                    k += 1;
                }
            }
            for i in 0..n {
                let off: f64 = (0..n).filter(|&j| j != i).map(|j| a.get(i, j).abs()).sum();
                a.add(i, i, off + 0.5 + seed[(i + 7) % seed.len()].abs());
            }
            let x_true: Vec<f64> = (0..n).map(|i| seed[(3 * i + 1) % seed.len()] * 10.0).collect();
            let mut b = vec![0.0; n];
            a.mul(&x_true, &mut b);
            let d = dense(&a);
            for i in 0..n {
                let bi: f64 = (0..n).map(|j| d[i][j] * x_true[j]).sum();
                prop_assert!((bi - b[i]).abs() < 1e-12 * (1.0 + bi.abs()));
            }
            let mut f = BandCholesky::new(n, bw);
            f.factor(&a).unwrap();
            f.solve(&mut b);
            for i in 0..n {
                prop_assert!((b[i] - x_true[i]).abs() < 1e-10, "{} vs {}", b[i], x_true[i]);
            }
        }
    }

    #[test]
    fn indefinite_matrix_is_rejected_naming_the_row() {
        let mut a = BandMatrix::new(3, 1);
        a.add(0, 0, 1.0);
        a.add(1, 0, 2.0);
        a.add(1, 1, 1.0);
        a.add(2, 2, 1.0);
        let err = BandCholesky::new(3, 1).factor(&a).unwrap_err();
        assert_eq!(err.row, 1);
    }
}
