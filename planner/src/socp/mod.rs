//! Sparse second-order-cone problems on Clarabel: the only module that knows the solver.
//!
//! A scheme describes its convex subproblem to a [`ProblemBuilder`] as an objective plus cone
//! blocks of affine expressions ([`Lin`]). [`SocpSolver`] turns the first description into
//! Clarabel's CSC matrices once (the sparsity pattern and the permutation from the builder's
//! triplets to CSC storage are kept), and later descriptions of the same structure only scatter
//! new values and call Clarabel's in-place `update_*` (presolve off), so the KKT ordering and
//! symbolic factorisation are reused across SCA iterations.

mod error;
mod lin;
mod pattern;
mod settings;

use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};

pub use error::SolveError;
pub use lin::Lin;
use pattern::Pattern;
pub use settings::SocpSettings;

/// A cone of the constraint rows s = b − A x.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cone {
    /// s = 0.
    Zero,
    /// s ≥ 0 (one row).
    NonNeg,
    /// s_0 ≥ ‖s_1..‖ (dimension = number of rows).
    Soc,
}

/// A subproblem under construction: minimise ½ xᵀPx + qᵀx subject to cone blocks of affine
/// expressions. Build it identically (same calls in the same order) each iteration so that
/// [`SocpSolver`] can reuse the pattern.
#[derive(Debug, Clone, Default)]
pub struct ProblemBuilder {
    n: usize,
    q: Vec<f64>,
    /// Upper-triangular P entries (row ≤ col), value.
    p: Vec<(usize, usize, f64)>,
    /// Each row of s = b − A x: the affine expression s_i.
    rows: Vec<Lin>,
    /// Cone blocks: (kind, number of rows).
    cones: Vec<(Cone, usize)>,
    /// The first entry that names a variable beyond the problem, recorded as it is added
    /// (reported by [`ProblemBuilder::validate`]).
    invalid: Option<String>,
}

impl ProblemBuilder {
    /// An empty problem with `n` variables.
    pub fn new(n: usize) -> Self {
        Self {
            n,
            q: vec![0.0; n],
            ..Default::default()
        }
    }

    /// Number of variables.
    pub fn num_vars(&self) -> usize {
        self.n
    }

    /// Number of constraint rows.
    pub fn num_rows(&self) -> usize {
        self.rows.len()
    }

    /// Records `what` as the problem's first invalid entry unless one is recorded already.
    fn note_invalid(&mut self, what: impl FnOnce() -> String) {
        if self.invalid.is_none() {
            self.invalid = Some(what());
        }
    }

    /// Appends a constraint row, noting it when it names a variable beyond the problem.
    fn push_row(&mut self, row: Lin) {
        let (r, n) = (self.rows.len(), self.n);
        if let Some((j, _)) = row.terms().find(|&(j, _)| j >= n) {
            self.note_invalid(|| format!("constraint row {r} names variable {j} of {n}"));
        }
        self.rows.push(row);
    }

    /// Adds `c` to the linear objective coefficient of variable `j` (an index beyond the
    /// problem is reported by [`ProblemBuilder::validate`]).
    pub fn add_linear_cost(&mut self, j: usize, c: f64) {
        let n = self.n;
        match self.q.get_mut(j) {
            Some(q) => *q += c,
            None => {
                self.note_invalid(|| format!("linear cost entry {j} names a variable beyond {n}"))
            }
        }
    }

    /// Adds `c x_j²` to the objective (as P_jj = 2c; an index beyond the problem is reported
    /// by [`ProblemBuilder::validate`]).
    pub fn add_square_cost(&mut self, j: usize, c: f64) {
        let n = self.n;
        if j >= n {
            self.note_invalid(|| {
                format!("quadratic cost entry ({j}, {j}) names a variable beyond {n}")
            });
        }
        self.p.push((j, j, 2.0 * c));
    }

    /// `e ≥ 0`.
    pub fn nonneg(&mut self, e: Lin) {
        self.push_row(e);
        self.cones.push((Cone::NonNeg, 1));
    }

    /// `e = 0`.
    pub fn zero(&mut self, e: Lin) {
        self.push_row(e);
        self.cones.push((Cone::Zero, 1));
    }

    /// `head ≥ ‖tail‖`.
    pub fn soc(&mut self, head: Lin, tail: &[Lin]) {
        self.push_row(head);
        for row in tail {
            self.push_row(row.clone());
        }
        self.cones.push((Cone::Soc, 1 + tail.len()));
    }

    /// `‖w‖² ≤ a·b` with a, b ≥ 0 (rotated cone), as the SOC (a + b, a − b, 2w).
    pub fn rotated_soc(&mut self, a: Lin, b: Lin, w: &[Lin]) {
        let mut tail = Vec::with_capacity(1 + w.len());
        tail.push(a.clone().minus_lin(&b));
        tail.extend(w.iter().map(|wi| wi.clone().scaled(2.0)));
        self.soc(a.plus_lin(&b), &tail);
    }

    /// Value of an affine expression at `x`.
    pub fn eval(e: &Lin, x: &[f64]) -> f64 {
        e.eval(x)
    }

    /// Largest violation of any cone at `x`, using s = row expressions evaluated at `x`.
    pub fn max_cone_violation(&self, x: &[f64]) -> f64 {
        self.cone_violations(x).fold(0.0, |m, (v, _)| m.max(v))
    }

    /// Largest violation of any cone at `x`, each relative to 1 + the largest constant of its
    /// rows (the scale at which the solver's relative tolerances act on that cone).
    pub fn max_relative_cone_violation(&self, x: &[f64]) -> f64 {
        self.cone_violations(x)
            .fold(0.0, |m, (v, scale)| m.max(v / scale))
    }

    fn cone_violations<'a>(&'a self, x: &'a [f64]) -> impl Iterator<Item = (f64, f64)> + 'a {
        let mut r = 0;
        self.cones.iter().map(move |&(cone, dim)| {
            let rows = &self.rows[r..r + dim];
            r += dim;
            let s: Vec<f64> = rows.iter().map(|e| e.eval(x)).collect();
            let scale = 1.0 + rows.iter().fold(0.0f64, |m, e| m.max(e.constant().abs()));
            let v = match cone {
                Cone::Zero => s.iter().fold(0.0f64, |m, v| m.max(v.abs())),
                Cone::NonNeg => (-s[0]).max(0.0),
                Cone::Soc => {
                    let tail = s[1..].iter().map(|v| v * v).sum::<f64>().sqrt();
                    (tail - s[0]).max(0.0)
                }
            };
            (v, scale)
        })
    }

    /// Objective value at `x`.
    pub fn objective(&self, x: &[f64]) -> f64 {
        let lin: f64 = self.q.iter().zip(x).map(|(q, x)| q * x).sum();
        let quad: f64 = self
            .p
            .iter()
            .map(|&(i, j, v)| {
                let (xi, xj) = (
                    x.get(i).copied().unwrap_or(0.0),
                    x.get(j).copied().unwrap_or(0.0),
                );
                if i == j {
                    0.5 * v * xi * xj
                } else {
                    v * xi * xj
                }
            })
            .sum();
        lin + quad
    }

    /// Whether every entry names one of the problem's variables: the first one that does not
    /// was noted as it was added, so this costs nothing per solve.
    pub fn validate(&self) -> Result<(), SolveError> {
        match &self.invalid {
            Some(what) => Err(SolveError::Setup(what.clone())),
            None => Ok(()),
        }
    }

    fn a_triplets(&self) -> (Vec<usize>, Vec<usize>, Vec<f64>, Vec<f64>) {
        let nnz: usize = self.rows.iter().map(Lin::len).sum();
        let (mut ri, mut ci, mut v) = (
            Vec::with_capacity(nnz),
            Vec::with_capacity(nnz),
            Vec::with_capacity(nnz),
        );
        let mut b = Vec::with_capacity(self.rows.len());
        for (i, row) in self.rows.iter().enumerate() {
            // s_i = c + Σ a_j x_j = b_i − (A x)_i  ⇒  b_i = c, A_ij = −a_j
            b.push(row.constant());
            for (j, a) in row.terms() {
                ri.push(i);
                ci.push(j);
                v.push(-a);
            }
        }
        (ri, ci, v, b)
    }

    fn clarabel_cones(&self) -> Vec<SupportedConeT<f64>> {
        let mut out: Vec<SupportedConeT<f64>> = Vec::new();
        for &(cone, dim) in &self.cones {
            // merge runs of scalar cones of the same kind into one block
            match (cone, out.last_mut()) {
                (Cone::NonNeg, Some(SupportedConeT::NonnegativeConeT(k))) => *k += dim,
                (Cone::Zero, Some(SupportedConeT::ZeroConeT(k))) => *k += dim,
                (Cone::NonNeg, _) => out.push(SupportedConeT::NonnegativeConeT(dim)),
                (Cone::Zero, _) => out.push(SupportedConeT::ZeroConeT(dim)),
                (Cone::Soc, _) => out.push(SupportedConeT::SecondOrderConeT(dim)),
            }
        }
        out
    }

    fn structure_key(&self) -> Vec<(Cone, usize)> {
        self.cones.clone()
    }
}

/// A solved subproblem.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Primal solution.
    pub x: Vec<f64>,
    /// Objective value ½xᵀPx + qᵀx at `x`.
    pub objective: f64,
    /// Clarabel's status (`Solved`, or `AlmostSolved` that passed our residual check).
    pub status: SolverStatus,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Wall time of the solve, s (both attempts when it was retried).
    pub seconds: f64,
    /// Largest cone violation of `x` by our own check.
    pub violation: f64,
}

/// A Clarabel solver that keeps the sparsity pattern across solves of the same structure.
pub struct SocpSolver {
    settings: SocpSettings,
    state: Option<Built>,
    /// Number of solver (re)constructions, for diagnostics.
    pub builds: usize,
    /// Number of solves repeated with refinement after a failure, for diagnostics.
    pub retries: usize,
}

struct Built {
    solver: DefaultSolver<f64>,
    a_pattern: Pattern,
    p_pattern: Pattern,
    key: Vec<(Cone, usize)>,
    n: usize,
}

impl std::fmt::Debug for SocpSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SocpSolver")
            .field("settings", &self.settings)
            .field("built", &self.state.is_some())
            .field("builds", &self.builds)
            .field("retries", &self.retries)
            .finish()
    }
}

impl SocpSolver {
    /// A solver with the given settings; nothing is built until the first solve.
    pub fn new(settings: SocpSettings) -> Self {
        Self {
            settings,
            state: None,
            builds: 0,
            retries: 0,
        }
    }

    fn clarabel_settings(&self) -> Result<DefaultSettings<f64>, SolveError> {
        DefaultSettingsBuilder::default()
            .verbose(false)
            .presolve_enable(false)
            .input_sparse_dropzeros(false)
            .max_iter(self.settings.max_iter)
            .tol_feas(self.settings.tol_feas)
            .tol_gap_rel(self.settings.tol_gap_rel)
            .tol_gap_abs(self.settings.tol_gap_rel)
            .iterative_refinement_max_iter(self.settings.refine_max_iter)
            .iterative_refinement_reltol(self.settings.refine_reltol)
            .build()
            .map_err(|e| SolveError::Setup(e.to_string()))
    }

    /// Solves `prob`; reuses the previous pattern when the structure is unchanged.
    /// A failed Clarabel solve is repeated once with more iterative refinement when the settings
    /// ask for it ([`SocpSettings::retry_refine_max_iter`]), and an inaccurate one with the
    /// [`SocpSettings::fallbacks`]; the last attempt's error is what the caller sees. A variable
    /// index beyond the problem is a [`SolveError::Setup`]. The answer's `seconds` count every
    /// attempt.
    pub fn solve(&mut self, prob: &ProblemBuilder) -> Result<Solution, SolveError> {
        let start = Instant::now();
        prob.validate()?;
        let mut result = self.solve_once(prob);
        if result.is_ok() {
            return result;
        }
        for (settings, after_certificate) in self.retry_ladder() {
            let Err(e) = &result else { break };
            let applies = if after_certificate {
                e.may_be_numerical()
            } else {
                matches!(e, SolveError::Inaccurate { .. })
            };
            if !applies {
                continue;
            }
            tracing::debug!(
                error = %e,
                refine_max_iter = settings.refine_max_iter,
                tol_feas = settings.tol_feas,
                "cone program retried"
            );
            self.retries += 1;
            result = SocpSolver::new(settings).solve_once(prob);
            match &result {
                Ok(sol) => tracing::debug!(status = ?sol.status, "retry solved"),
                Err(e) => tracing::debug!(error = %e, "retry failed too"),
            }
        }
        if let Ok(sol) = result.as_mut() {
            // a retried solve: every attempt counts
            sol.seconds = start.elapsed().as_secs_f64();
        }
        result
    }

    /// The settings of the retries, in order, each with whether it also follows a certificate
    /// of infeasibility or unboundedness (only the refinement retry does: an unrefined KKT solve
    /// can fake one). Each retry builds a fresh solver and does not retry again.
    fn retry_ladder(&self) -> Vec<(SocpSettings, bool)> {
        let base = SocpSettings {
            reuse: false,
            retry_refine_max_iter: 0,
            fallbacks: false,
            ..self.settings
        };
        let mut ladder: Vec<(SocpSettings, bool)> = Vec::new();
        if self.settings.retry_refine_max_iter > self.settings.refine_max_iter {
            ladder.push((
                SocpSettings {
                    refine_max_iter: self.settings.retry_refine_max_iter,
                    ..base
                },
                true,
            ));
        }
        if self.settings.fallbacks {
            let other_refine = if self.settings.refine_max_iter > 0 {
                0
            } else {
                10
            };
            let candidates = [
                SocpSettings {
                    refine_max_iter: other_refine,
                    ..base
                },
                SocpSettings {
                    tol_feas: base.tol_feas.max(1e-6),
                    tol_gap_rel: base.tol_gap_rel.max(1e-6),
                    ..base
                },
            ];
            // all derive from `base`: skip one that repeats the first attempt or a retry
            for c in candidates {
                if c != base && !ladder.iter().any(|(o, _)| *o == c) {
                    ladder.push((c, false));
                }
            }
        }
        ladder
    }

    fn solve_once(&mut self, prob: &ProblemBuilder) -> Result<Solution, SolveError> {
        let start = Instant::now();
        let (ai, aj, av, b) = prob.a_triplets();
        let (pi, pj, pv): (Vec<usize>, Vec<usize>, Vec<f64>) = {
            let mut pi = Vec::with_capacity(prob.p.len());
            let mut pj = Vec::with_capacity(prob.p.len());
            let mut pv = Vec::with_capacity(prob.p.len());
            for &(i, j, v) in &prob.p {
                pi.push(i.min(j));
                pj.push(i.max(j));
                pv.push(v);
            }
            (pi, pj, pv)
        };
        let key = prob.structure_key();
        let reusable = self.settings.reuse
            && self.state.as_ref().is_some_and(|s| {
                s.key == key
                    && s.n == prob.n
                    && s.a_pattern.matches(&ai, &aj)
                    && s.p_pattern.matches(&pi, &pj)
            });
        if reusable {
            if let Some(st) = self.state.as_mut() {
                let a_vals = st.a_pattern.values(&av);
                let p_vals = st.p_pattern.values(&pv);
                st.solver
                    .update_data(&p_vals, &prob.q, &a_vals, &b)
                    .map_err(|e| SolveError::Setup(format!("in-place update: {e:?}")))?;
            }
        } else {
            let m = prob.rows.len();
            let a_pattern = Pattern::new(m, prob.n, &ai, &aj);
            let p_pattern = Pattern::new(prob.n, prob.n, &pi, &pj);
            let a = a_pattern.csc(&av);
            let p = p_pattern.csc(&pv);
            let cones = prob.clarabel_cones();
            let solver = DefaultSolver::new(&p, &prob.q, &a, &b, &cones, self.clarabel_settings()?)
                .map_err(|e| SolveError::Setup(format!("{e:?}")))?;
            self.builds += 1;
            self.state = Some(Built {
                solver,
                a_pattern,
                p_pattern,
                key,
                n: prob.n,
            });
        }
        let st = self
            .state
            .as_mut()
            .ok_or_else(|| SolveError::Setup("solver state missing after build".into()))?;
        st.solver.solve();
        let sol = &st.solver.solution;
        let status = sol.status;
        let x = sol.x.clone();
        let iterations = sol.iterations;
        let seconds = start.elapsed().as_secs_f64();
        let violation = prob.max_cone_violation(&x);
        let relative = prob.max_relative_cone_violation(&x);
        let finite = x.iter().all(|v| v.is_finite());
        tracing::trace!(
            variables = prob.n,
            ?status,
            iterations,
            seconds,
            relative_violation = relative,
            "cone program solved"
        );
        let accept = |ok: bool| -> Result<Solution, SolveError> {
            if ok && finite {
                Ok(Solution {
                    objective: prob.objective(&x),
                    x: x.clone(),
                    status,
                    iterations,
                    seconds,
                    violation,
                })
            } else {
                Err(SolveError::Inaccurate { status, violation })
            }
        };
        match status {
            SolverStatus::Solved => accept(relative <= 1e-6),
            SolverStatus::AlmostSolved
            | SolverStatus::MaxIterations
            | SolverStatus::MaxTime
            | SolverStatus::InsufficientProgress
            | SolverStatus::NumericalError => {
                // accepted only after our own residual check (the scheme then re-checks the
                // trajectory on the exact geometry)
                let ok = matches!(status, SolverStatus::AlmostSolved)
                    && relative <= self.settings.almost_solved_violation;
                accept(ok)
            }
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                Err(SolveError::Infeasible(status))
            }
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => {
                Err(SolveError::Unbounded(status))
            }
            SolverStatus::Unsolved | SolverStatus::CallbackTerminated => {
                Err(SolveError::Inaccurate { status, violation })
            }
        }
    }
}

/// Builds a CSC matrix directly (used by tests and benchmarks).
pub fn csc_from_triplets(
    m: usize,
    n: usize,
    i: &[usize],
    j: &[usize],
    v: &[f64],
) -> CscMatrix<f64> {
    Pattern::new(m, n, i, j).csc(v)
}

#[cfg(test)]
mod tests;
