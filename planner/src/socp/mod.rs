//! Sparse second-order-cone problems on Clarabel: the only module that knows the solver.
//!
//! A scheme describes its convex subproblem to a [`ProblemBuilder`] as an objective plus cone
//! blocks of affine expressions ([`Lin`]). [`SocpSolver`] turns the first description into
//! Clarabel's CSC matrices once (the sparsity pattern and the permutation from the builder's
//! triplets to CSC storage are kept), and later descriptions of the same structure only scatter
//! new values and call Clarabel's in-place `update_*` (presolve off), so the KKT ordering and
//! symbolic factorisation are reused across SCA iterations.

mod lin;
mod pattern;

use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};

pub use lin::Lin;
use pattern::Pattern;

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

/// Why a subproblem did not give a usable solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// Clarabel rejected the problem data (a bug in the assembly; names the cause).
    #[error("solver setup failed: {0}")]
    Setup(String),
    /// Clarabel proved the subproblem infeasible.
    #[error("subproblem is infeasible (solver status {0:?})")]
    Infeasible(SolverStatus),
    /// Clarabel proved the subproblem unbounded.
    #[error("subproblem is unbounded (solver status {0:?})")]
    Unbounded(SolverStatus),
    /// Clarabel stopped without a solution of the required accuracy.
    #[error("solver stopped with status {status:?} (cone violation {violation:.3e})")]
    Inaccurate {
        /// Clarabel's status.
        status: SolverStatus,
        /// Our residual check: largest cone violation of the returned point.
        violation: f64,
    },
}

impl SolveError {
    /// Whether a more accurate linear algebra could change the outcome (everything but a setup
    /// error: an inaccurate stop, or an infeasibility or unboundedness certificate).
    pub fn may_be_numerical(&self) -> bool {
        !matches!(self, SolveError::Setup(_))
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

/// Settings of the subproblem solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SocpSettings {
    /// Maximum interior-point iterations per solve.
    pub max_iter: u32,
    /// Feasibility tolerance passed to Clarabel.
    pub tol_feas: f64,
    /// Relative duality-gap tolerance passed to Clarabel.
    pub tol_gap_rel: f64,
    /// Largest cone violation, relative to 1 + the largest constant of the cone's rows,
    /// accepted for `AlmostSolved` (and 1e-6 for `Solved`).
    pub almost_solved_violation: f64,
    /// Reuse the pattern and update values in place (true), or build a new solver each time.
    pub reuse: bool,
    /// Largest number of iterative-refinement steps per KKT solve.
    pub refine_max_iter: u32,
    /// Relative tolerance of iterative refinement.
    pub refine_reltol: f64,
    /// When a solve with fewer than this many refinement steps fails (inaccurate, or a
    /// certificate of infeasibility or unboundedness that an unrefined KKT solve can fake), it is
    /// repeated once from scratch with this many; 0 = no retry.
    pub retry_refine_max_iter: u32,
    /// When a solve still stops inaccurate (not a certificate), try it again with other
    /// linear-algebra settings, in order: the other refinement setting (none ↔ 10 steps), then
    /// tolerances of 1e-6. Every answer must still pass our residual check, so a fallback can
    /// only turn a failure into an accepted solution, never weaken what is accepted. (Found on
    /// Fig. 11's random realisations 3 and 19, whose first `baseline` program Clarabel stopped
    /// `AlmostSolved` at a relative cone violation of 1.5e-4 and 2.9e-4: the plan failed.)
    pub fallbacks: bool,
}

impl SocpSettings {
    /// The settings of the `exact` scheme's cone programs: Clarabel's iterative refinement off
    /// (it is about half of the interior-point time on these well-scaled, banded programs and
    /// changes the planned energies by less than 1 J), and a failed solve repeated with
    /// Clarabel's default refinement (10 steps). The comparison schemes keep the defaults: the
    /// paper's later iterates depend on the solver's path (erratum 10 (docs/paper-notes.md)), and the
    /// least-distance SCA lands on slightly longer local optima without refinement.
    pub fn exact_geometry() -> Self {
        Self {
            refine_max_iter: 0,
            retry_refine_max_iter: 10,
            ..Self::default()
        }
    }
}

impl Default for SocpSettings {
    fn default() -> Self {
        Self {
            max_iter: 200,
            tol_feas: 1e-8,
            tol_gap_rel: 1e-8,
            almost_solved_violation: 1e-4,
            reuse: true,
            refine_max_iter: 10,
            refine_reltol: 1e-13,
            retry_refine_max_iter: 0,
            fallbacks: true,
        }
    }
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
mod tests {
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
}
