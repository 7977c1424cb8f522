//! Affine expressions c + Σ a_j x_j over problem variables.

/// An affine expression `c + Σ a_j x_j`. Terms keep their insertion order (the solver's sparsity
/// pattern depends on it) and may repeat a variable (repeats are summed).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lin {
    terms: Vec<(usize, f64)>,
    c: f64,
}

impl Lin {
    /// `a x_j`.
    pub fn var(j: usize, a: f64) -> Self {
        Self {
            terms: vec![(j, a)],
            c: 0.0,
        }
    }

    /// The constant `c`.
    pub fn constant_only(c: f64) -> Self {
        Self {
            terms: Vec::new(),
            c,
        }
    }

    /// Adds the term `a x_j` (kept even when `a` is 0, so the pattern stays fixed).
    pub fn plus(mut self, j: usize, a: f64) -> Self {
        self.terms.push((j, a));
        self
    }

    /// Adds the constant `c`.
    pub fn plus_const(mut self, c: f64) -> Self {
        self.c += c;
        self
    }

    /// `self + other`.
    pub fn plus_lin(mut self, other: &Lin) -> Self {
        self.terms.extend_from_slice(&other.terms);
        self.c += other.c;
        self
    }

    /// `self − other`.
    pub fn minus_lin(mut self, other: &Lin) -> Self {
        self.terms.extend(other.terms.iter().map(|&(j, a)| (j, -a)));
        self.c -= other.c;
        self
    }

    /// `k · self`.
    pub fn scaled(mut self, k: f64) -> Self {
        for t in &mut self.terms {
            t.1 *= k;
        }
        self.c *= k;
        self
    }

    /// Value at `x` (variables beyond `x` count as 0).
    pub fn eval(&self, x: &[f64]) -> f64 {
        self.c
            + self
                .terms
                .iter()
                .map(|&(j, a)| a * x.get(j).copied().unwrap_or(0.0))
                .sum::<f64>()
    }

    /// The terms (variable, coefficient).
    pub fn terms(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.terms.iter().copied()
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// True when there are no variable terms.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// The constant part.
    pub fn constant(&self) -> f64 {
        self.c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic() {
        let a = Lin::var(0, 2.0).plus(1, 3.0).plus_const(1.0);
        let b = Lin::var(1, 1.0).plus_const(4.0);
        let x = [1.0, 2.0];
        assert_eq!(a.eval(&x), 9.0);
        assert_eq!(a.clone().minus_lin(&b).eval(&x), 9.0 - 6.0);
        assert_eq!(a.clone().plus_lin(&b).eval(&x), 15.0);
        assert_eq!(a.scaled(-2.0).eval(&x), -18.0);
    }
}
