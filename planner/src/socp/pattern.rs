//! A fixed CSC sparsity pattern built from triplets, with the map from each triplet to its
//! stored non-zero, so that new values of the same triplet sequence scatter in O(nnz).

use clarabel::algebra::CscMatrix;

/// CSC structure of an m × n matrix and the triplet → non-zero map.
#[derive(Debug, Clone)]
pub struct Pattern {
    m: usize,
    n: usize,
    colptr: Vec<usize>,
    rowval: Vec<usize>,
    /// `slot[k]` is the index in `rowval`/`nzval` of triplet k (duplicates share one).
    slot: Vec<usize>,
    rows: Vec<usize>,
    cols: Vec<usize>,
}

impl Pattern {
    /// The pattern of the triplets (rows[k], cols[k]); duplicates are merged.
    pub fn new(m: usize, n: usize, rows: &[usize], cols: &[usize]) -> Self {
        let mut order: Vec<usize> = (0..rows.len()).collect();
        order.sort_by_key(|&k| (cols[k], rows[k]));
        let mut colptr = vec![0usize; n + 1];
        let mut rowval = Vec::with_capacity(rows.len());
        let mut slot = vec![0usize; rows.len()];
        let mut last: Option<(usize, usize)> = None;
        for &k in &order {
            let key = (cols[k], rows[k]);
            if last != Some(key) {
                rowval.push(rows[k]);
                colptr[cols[k] + 1] += 1;
                last = Some(key);
            }
            slot[k] = rowval.len() - 1;
        }
        for j in 0..n {
            colptr[j + 1] += colptr[j];
        }
        Self {
            m,
            n,
            colptr,
            rowval,
            slot,
            rows: rows.to_vec(),
            cols: cols.to_vec(),
        }
    }

    /// True when the triplet positions are exactly those the pattern was built from.
    pub fn matches(&self, rows: &[usize], cols: &[usize]) -> bool {
        self.rows == rows && self.cols == cols
    }

    /// Non-zero values in CSC order for the triplet values `v` (duplicates summed).
    pub fn values(&self, v: &[f64]) -> Vec<f64> {
        let mut nz = vec![0.0; self.rowval.len()];
        for (k, &s) in self.slot.iter().enumerate() {
            nz[s] += v.get(k).copied().unwrap_or(0.0);
        }
        nz
    }

    /// The CSC matrix for triplet values `v`.
    pub fn csc(&self, v: &[f64]) -> CscMatrix<f64> {
        CscMatrix::new(
            self.m,
            self.n,
            self.colptr.clone(),
            self.rowval.clone(),
            self.values(v),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicates_are_summed_and_order_is_csc() {
        let p = Pattern::new(2, 2, &[1, 0, 1, 0], &[0, 1, 0, 0]);
        let m = p.csc(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m.colptr, vec![0, 2, 3]);
        assert_eq!(m.rowval, vec![0, 1, 0]);
        assert_eq!(m.nzval, vec![4.0, 4.0, 2.0]);
    }
}
