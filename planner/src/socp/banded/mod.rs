//! A primal–dual interior-point method for cone programs whose constraints couple only nearby
//! variables: the planner's subproblems, where every cone involves one slot and the position
//! of the slot before it. Opt-in ([`super::Backend::Banded`], `cellsar-planner plan
//! --socp-backend banded`); Clarabel stays the default (measurements below).
//!
//! The problem is a [`ProblemBuilder`]'s: minimise ½xᵀPx + qᵀx subject to G x + s = h, s in a
//! product of nonnegative orthants and second-order cones (G, h from the builder's rows
//! s = b − A x, so G = A, h = b). After Ruiz equilibration (as Clarabel does), the method is
//! the infeasible-start, Nesterov–Todd-scaled, Mehrotra predictor–corrector of CVXOPT's
//! `coneqp` (Vandenberghe 2010). Its Newton systems are reduced to the normal equations
//!
//! H Δx = r,  H = P + Σ_c G_cᵀ W_c⁻² G_c,
//!
//! where each cone c contributes a dense block over the few variables it involves. After the
//! variables are ordered so that each cone's variables are close together (by the mean of the
//! first and last cone each one appears in), H is a band matrix (half bandwidth 9–10 on the
//! planner's programs) factored by a band Cholesky in O(n b²); iterative refinement runs on
//! the full Newton system near the optimum.
//!
//! Measured (BENCHMARKS.md, "An own interior-point method"): on the 600-slot programs it takes
//! 2.9–3.6 ms per iteration against Clarabel's 3.8–4.6 ms in the same runs (1.3×): the
//! factorisation is only ~5 % of its time, the passes over G, the cone scalings and the
//! triangular solves are the rest, as in any interior-point method. Whole default plans are 1.2× faster at 200 m and
//! no faster at 30 m. Known limits:
//! - the normal equations of second-order cones have a condition number ~ 1/μ², so the dual
//!   residual stalls at 1e-8…1e-7 while the primal objective is converged to ten digits: the
//!   dual tolerance is 1e-7 and the gap is the complementarity sᵀz (CVXOPT's definition);
//! - no homogeneous embedding: the planner's phase I programs (large elastic weights) diverge
//!   and some programs end with an iterate just outside a cone from rounding; both are reported
//!   as errors and a fifth (30 m) to a third (200 m) of a default plan's programs fall back to
//!   Clarabel;
//! - no equality cones, no certificates of infeasibility or unboundedness (Clarabel again).

// Parallel arrays (x, s, z and their steps and residuals) are clearest indexed together.
#![allow(clippy::needless_range_loop)]

mod band;
mod soc;

use band::{BandCholesky, BandMatrix};

use super::{Cone, ProblemBuilder};

/// Settings of the banded interior-point method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandedSettings {
    /// Largest number of interior-point iterations.
    pub max_iter: u32,
    /// Primal residual tolerance (relative, as Clarabel's `tol_feas`; like all tolerances
    /// here, tested on the equilibrated, cost-scaled program; the caller checks the answer's
    /// cone violation in the original units).
    pub tol_feas: f64,
    /// Dual residual tolerance (relative). Looser than the primal one: the normal equations
    /// of second-order cones have a condition number ~ 1/μ², and the dual residual stalls at
    /// 1e-8…1e-7 on the planner's programs while the primal objective is converged to ten
    /// digits (the planner uses only the primal solution, and checks it on its own).
    pub tol_dual: f64,
    /// Absolute gap tolerance on the complementarity sᵀz (CVXOPT's definition).
    pub tol_gap_abs: f64,
    /// Relative gap tolerance: sᵀz / max(1, |primal objective|).
    pub tol_gap_rel: f64,
    /// Largest half bandwidth of the normal equations worth solving this way (wider problems
    /// are left to the general solver).
    pub max_bandwidth: usize,
    /// Iterative-refinement steps on the full Newton system per solve.
    pub refine_steps: u32,
    /// Refinement stops once the full system's residual is below this, relative to 1 + the
    /// largest right-hand side entry.
    pub refine_tol: f64,
    /// Refine only once the relative gap is below this (early directions need no accuracy).
    pub refine_below_gap: f64,
    /// Ruiz-equilibrate the program first.
    pub equilibrate: bool,
}

impl Default for BandedSettings {
    fn default() -> Self {
        Self {
            max_iter: 100,
            tol_feas: 1e-8,
            tol_dual: 1e-7,
            tol_gap_abs: 1e-8,
            tol_gap_rel: 1e-8,
            max_bandwidth: 64,
            refine_steps: 1,
            refine_tol: 1e-10,
            refine_below_gap: 1e-4,
            equilibrate: true,
        }
    }
}

/// Why the banded method gave no answer (the caller then uses the general solver).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BandedError {
    /// The problem has a cone this method does not handle, or is too wide.
    #[error("not a banded cone program: {0}")]
    Unsupported(String),
    /// The normal equations lost positive definiteness.
    #[error("interior-point iteration {iteration}: {source}")]
    Factorisation {
        /// Iteration at which it happened.
        iteration: u32,
        /// Where the factorisation failed.
        source: band::NotPositiveDefinite,
    },
    /// A residual that is not finite, or an iterate left the cones. (A non-finite search
    /// direction or a vanishing step ends the iteration as [`BandedError::NotConverged`].)
    #[error("interior-point iteration {iteration}: numerical breakdown ({what})")]
    Numerical {
        /// Iteration at which it happened.
        iteration: u32,
        /// What went wrong.
        what: &'static str,
    },
    /// The iteration limit was reached, or the steps stalled, before the tolerances were met
    /// (an infeasible or unbounded problem ends here too).
    #[error(
        "interior-point method stopped after {iterations} iterations: primal residual {pres:.2e}, \
         dual residual {dres:.2e}, gap {gap:.2e}"
    )]
    NotConverged {
        /// Iterations run.
        iterations: u32,
        /// Scaled primal residual at the end.
        pres: f64,
        /// Scaled dual residual at the end.
        dres: f64,
        /// Relative duality gap at the end.
        gap: f64,
    },
}

/// The answer of a converged solve.
#[derive(Debug, Clone)]
pub struct BandedSolution {
    /// Primal solution, in the builder's variable order.
    pub x: Vec<f64>,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Half bandwidth of the normal equations.
    pub bandwidth: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    NonNeg,
    Soc,
}

/// One cone of the program: its rows and the dense block of G over the variables it involves.
#[derive(Debug, Clone)]
struct Block {
    kind: Kind,
    /// First row and number of rows.
    row0: usize,
    dim: usize,
    /// Range in `Structure::vars` of this block's variables (sorted, permuted indices).
    var0: usize,
    nvar: usize,
    /// Offset in `Structure::g` of the dim × nvar row-major dense block.
    g0: usize,
}

/// The program in the permuted variable order.
#[derive(Debug, Clone)]
struct Structure {
    n: usize,
    m: usize,
    /// `perm[new] = old`.
    perm: Vec<usize>,
    q: Vec<f64>,
    /// Diagonal of P and its off-diagonal entries (i > j, permuted).
    p_diag: Vec<f64>,
    p_off: Vec<(usize, usize, f64)>,
    h: Vec<f64>,
    blocks: Vec<Block>,
    vars: Vec<usize>,
    g: Vec<f64>,
    bandwidth: usize,
    degree: usize,
}

impl Structure {
    fn new(prob: &ProblemBuilder, max_bandwidth: usize) -> Result<Self, BandedError> {
        // every index names a variable (the builder noted any that does not)
        prob.validate()
            .map_err(|e| BandedError::Unsupported(e.to_string()))?;
        let n = prob.n;
        let m = prob.rows.len();
        // first and last cone each variable appears in
        let mut first = vec![usize::MAX; n];
        let mut last = vec![0usize; n];
        let mut r = 0;
        for (c, &(_, dim)) in prob.cones.iter().enumerate() {
            for row in &prob.rows[r..r + dim] {
                for (j, _) in row.terms() {
                    first[j] = first[j].min(c);
                    last[j] = last[j].max(c);
                }
            }
            r += dim;
        }
        let key = |j: usize| -> f64 {
            if first[j] == usize::MAX {
                f64::INFINITY
            } else {
                (first[j] + last[j]) as f64 / 2.0
            }
        };
        let mut by_key: Vec<usize> = (0..n).collect();
        by_key.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        let identity: Vec<usize> = (0..n).collect();
        let width = |perm: &[usize]| -> usize {
            let mut inv = vec![0usize; n];
            for (new, &old) in perm.iter().enumerate() {
                inv[old] = new;
            }
            let mut bw = 0usize;
            let mut r = 0;
            for &(_, dim) in &prob.cones {
                let (mut lo, mut hi) = (usize::MAX, 0usize);
                for row in &prob.rows[r..r + dim] {
                    for (j, _) in row.terms() {
                        lo = lo.min(inv[j]);
                        hi = hi.max(inv[j]);
                    }
                }
                if lo <= hi {
                    bw = bw.max(hi - lo);
                }
                r += dim;
            }
            for &(i, j, _) in &prob.p {
                bw = bw.max(inv[i].abs_diff(inv[j]));
            }
            bw
        };
        let (w_key, w_id) = (width(&by_key), width(&identity));
        let (perm, bandwidth) = if w_key <= w_id {
            (by_key, w_key)
        } else {
            (identity, w_id)
        };
        if bandwidth > max_bandwidth {
            return Err(BandedError::Unsupported(format!(
                "half bandwidth {bandwidth} > {max_bandwidth}"
            )));
        }
        let mut inv = vec![0usize; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old] = new;
        }
        let q: Vec<f64> = perm.iter().map(|&old| prob.q[old]).collect();
        let mut p_diag = vec![0.0; n];
        let mut p_off = Vec::new();
        for &(i, j, v) in &prob.p {
            let (a, b) = (inv[i], inv[j]);
            if a == b {
                p_diag[a] += v;
            } else {
                p_off.push((a.max(b), a.min(b), v));
            }
        }
        let mut blocks = Vec::with_capacity(prob.cones.len());
        let mut vars = Vec::new();
        let mut g = Vec::new();
        let mut h = Vec::with_capacity(m);
        let mut degree = 0;
        let mut r = 0;
        let mut local: Vec<usize> = Vec::new();
        for &(cone, dim) in &prob.cones {
            let kind = match cone {
                Cone::NonNeg => Kind::NonNeg,
                Cone::Soc => Kind::Soc,
                Cone::Zero => return Err(BandedError::Unsupported("equality constraints".into())),
            };
            if kind == Kind::Soc && dim < 2 {
                return Err(BandedError::Unsupported(format!(
                    "second-order cone of dimension {dim} at row {r}"
                )));
            }
            let rows = &prob.rows[r..r + dim];
            local.clear();
            for row in rows {
                local.extend(row.terms().map(|(j, _)| inv[j]));
            }
            local.sort_unstable();
            local.dedup();
            let (var0, nvar, g0) = (vars.len(), local.len(), g.len());
            vars.extend_from_slice(&local);
            g.resize(g0 + dim * nvar, 0.0);
            for (k, row) in rows.iter().enumerate() {
                h.push(row.constant());
                for (j, a) in row.terms() {
                    // s = c + Σ a_j x_j = h − G x  ⇒  G_kj = −a_j
                    if let Ok(pos) = local.binary_search(&inv[j]) {
                        g[g0 + k * nvar + pos] -= a;
                    }
                }
            }
            blocks.push(Block {
                kind,
                row0: r,
                dim,
                var0,
                nvar,
                g0,
            });
            degree += 1;
            r += dim;
        }
        Ok(Self {
            n,
            m,
            perm,
            q,
            p_diag,
            p_off,
            h,
            blocks,
            vars,
            g,
            bandwidth,
            degree,
        })
    }

    /// Ruiz equilibration (as Clarabel does before solving): variables x = D x̂, each cone's
    /// rows scaled by one factor (a second-order cone must keep its shape), and the cost by c,
    /// so that every column and row of [P Gᵀ; G 0] has an infinity norm near 1. Returns D.
    fn equilibrate(&mut self, passes: usize) -> Vec<f64> {
        let n = self.n;
        let mut dtot = vec![1.0; n];
        let mut col = vec![0.0f64; n];
        let clamp = |v: f64| {
            if v > 0.0 && v.is_finite() {
                v.clamp(1e-4, 1e4)
            } else {
                1.0
            }
        };
        for _ in 0..passes {
            col.iter_mut()
                .zip(&self.p_diag)
                .for_each(|(c, p)| *c = p.abs());
            for &(i, j, v) in &self.p_off {
                col[i] = col[i].max(v.abs());
                col[j] = col[j].max(v.abs());
            }
            let mut row_scale = Vec::with_capacity(self.blocks.len());
            for b in &self.blocks {
                let vars = &self.vars[b.var0..b.var0 + b.nvar];
                let g = &self.g[b.g0..b.g0 + b.dim * b.nvar];
                let mut rmax = 0.0f64;
                for k in 0..b.dim {
                    for (a, &j) in g[k * b.nvar..(k + 1) * b.nvar].iter().zip(vars) {
                        col[j] = col[j].max(a.abs());
                        rmax = rmax.max(a.abs());
                    }
                }
                row_scale.push(1.0 / clamp(rmax).sqrt());
            }
            let d: Vec<f64> = col.iter().map(|&c| 1.0 / clamp(c).sqrt()).collect();
            for (b, &e) in self.blocks.iter().zip(&row_scale) {
                let vars = &self.vars[b.var0..b.var0 + b.nvar];
                for k in 0..b.dim {
                    self.h[b.row0 + k] *= e;
                    let row = &mut self.g[b.g0 + k * b.nvar..b.g0 + (k + 1) * b.nvar];
                    for (a, &j) in row.iter_mut().zip(vars) {
                        *a *= e * d[j];
                    }
                }
            }
            for i in 0..n {
                self.p_diag[i] *= d[i] * d[i];
                self.q[i] *= d[i];
                dtot[i] *= d[i];
            }
            for (i, j, v) in self.p_off.iter_mut() {
                *v *= d[*i] * d[*j];
            }
        }
        // cost scaling
        let pmax = self.p_diag.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let c = 1.0 / clamp(inf_norm(&self.q).max(pmax).max(1.0));
        self.q.iter_mut().for_each(|v| *v *= c);
        self.p_diag.iter_mut().for_each(|v| *v *= c);
        self.p_off.iter_mut().for_each(|t| t.2 *= c);
        dtot
    }

    /// y = G x (y has m rows).
    fn g_mul(&self, x: &[f64], y: &mut [f64]) {
        for b in &self.blocks {
            let vars = &self.vars[b.var0..b.var0 + b.nvar];
            for k in 0..b.dim {
                let row = &self.g[b.g0 + k * b.nvar..b.g0 + (k + 1) * b.nvar];
                y[b.row0 + k] = row.iter().zip(vars).map(|(a, &j)| a * x[j]).sum();
            }
        }
    }

    /// y = Gᵀ z (y has n entries).
    fn gt_mul(&self, z: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for b in &self.blocks {
            let vars = &self.vars[b.var0..b.var0 + b.nvar];
            for k in 0..b.dim {
                let zk = z[b.row0 + k];
                let row = &self.g[b.g0 + k * b.nvar..b.g0 + (k + 1) * b.nvar];
                for (a, &j) in row.iter().zip(vars) {
                    y[j] += a * zk;
                }
            }
        }
    }

    /// y = P x.
    fn p_mul(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.n {
            y[i] = self.p_diag[i] * x[i];
        }
        for &(i, j, v) in &self.p_off {
            y[i] += v * x[j];
            y[j] += v * x[i];
        }
    }
}

/// The scaling of every cone at the current iterate.
#[derive(Debug, Clone)]
struct Scaling {
    /// Per row: NonNeg rows hold √(s/z) (W = diag of it); SOC rows hold w̄.
    w: Vec<f64>,
    /// Per block: β (SOC) or 1.
    beta: Vec<f64>,
    /// λ = W z = W⁻¹ s, per row.
    lambda: Vec<f64>,
}

impl Scaling {
    fn new(m: usize, blocks: usize) -> Self {
        Self {
            w: vec![0.0; m],
            beta: vec![1.0; blocks],
            lambda: vec![0.0; m],
        }
    }

    /// Computes W and λ from interior s, z; false when one of them is not interior.
    fn update(&mut self, st: &Structure, s: &[f64], z: &[f64]) -> bool {
        for (bi, b) in st.blocks.iter().enumerate() {
            let rows = b.row0..b.row0 + b.dim;
            match b.kind {
                Kind::NonNeg => {
                    let (si, zi) = (s[b.row0], z[b.row0]);
                    if !(si > 0.0 && zi > 0.0) {
                        return false;
                    }
                    self.w[b.row0] = (si / zi).sqrt();
                    self.lambda[b.row0] = (si * zi).sqrt();
                }
                Kind::Soc => {
                    let Some(beta) = soc::scaling(
                        &s[rows.clone()],
                        &z[rows.clone()],
                        &mut self.w[rows.clone()],
                    ) else {
                        return false;
                    };
                    self.beta[bi] = beta;
                    let lam = &mut self.lambda[rows.clone()];
                    lam.copy_from_slice(&z[rows.clone()]);
                    soc::apply_w(beta, &self.w[rows], lam);
                }
            }
        }
        true
    }

    /// y ← W y over all blocks.
    fn apply_w(&self, st: &Structure, y: &mut [f64]) {
        for (bi, b) in st.blocks.iter().enumerate() {
            match b.kind {
                Kind::NonNeg => y[b.row0] *= self.w[b.row0],
                Kind::Soc => {
                    let rows = b.row0..b.row0 + b.dim;
                    soc::apply_w(self.beta[bi], &self.w[rows.clone()], &mut y[rows]);
                }
            }
        }
    }

    /// y ← W⁻¹ y over all blocks.
    fn apply_winv(&self, st: &Structure, y: &mut [f64]) {
        for (bi, b) in st.blocks.iter().enumerate() {
            match b.kind {
                Kind::NonNeg => y[b.row0] /= self.w[b.row0],
                Kind::Soc => {
                    let rows = b.row0..b.row0 + b.dim;
                    soc::apply_winv(self.beta[bi], &self.w[rows.clone()], &mut y[rows]);
                }
            }
        }
    }

    /// H = P + Σ (W⁻¹G_c)ᵀ(W⁻¹G_c) into `hm`; `u` is scratch.
    fn assemble(&self, st: &Structure, hm: &mut BandMatrix, u: &mut Vec<f64>) {
        hm.clear();
        for i in 0..st.n {
            hm.add(i, i, st.p_diag[i]);
        }
        for &(i, j, v) in &st.p_off {
            hm.add(i, j, v);
        }
        let mut col = [0.0f64; 64];
        for (bi, b) in st.blocks.iter().enumerate() {
            let vars = &st.vars[b.var0..b.var0 + b.nvar];
            let g = &st.g[b.g0..b.g0 + b.dim * b.nvar];
            match b.kind {
                Kind::NonNeg => {
                    let d = 1.0 / (self.w[b.row0] * self.w[b.row0]);
                    for a in 0..b.nvar {
                        let ga = g[a] * d;
                        for c in 0..=a {
                            hm.add(vars[a], vars[c], ga * g[c]);
                        }
                    }
                }
                Kind::Soc => {
                    // U = W⁻¹ G_c column by column (dim × nvar, row-major)
                    u.clear();
                    u.resize(b.dim * b.nvar, 0.0);
                    let rows = b.row0..b.row0 + b.dim;
                    let w = &self.w[rows];
                    let mut heap;
                    let colbuf: &mut [f64] = if b.dim <= col.len() {
                        &mut col[..b.dim]
                    } else {
                        heap = vec![0.0; b.dim];
                        &mut heap
                    };
                    for a in 0..b.nvar {
                        for k in 0..b.dim {
                            colbuf[k] = g[k * b.nvar + a];
                        }
                        soc::apply_winv(self.beta[bi], w, colbuf);
                        for k in 0..b.dim {
                            u[k * b.nvar + a] = colbuf[k];
                        }
                    }
                    for a in 0..b.nvar {
                        for c in 0..=a {
                            let mut acc = 0.0;
                            for k in 0..b.dim {
                                acc += u[k * b.nvar + a] * u[k * b.nvar + c];
                            }
                            hm.add(vars[a], vars[c], acc);
                        }
                    }
                }
            }
        }
    }

    /// Step to the boundary of the cones from λ along d (scaled space).
    fn max_step(&self, st: &Structure, d: &[f64]) -> f64 {
        max_step(st, &self.lambda, d)
    }
}

/// Largest α with u + α d in the cones (u interior).
fn max_step(st: &Structure, u: &[f64], d: &[f64]) -> f64 {
    let mut alpha = f64::INFINITY;
    for b in &st.blocks {
        let a = match b.kind {
            Kind::NonNeg => {
                if d[b.row0] < 0.0 {
                    -u[b.row0] / d[b.row0]
                } else {
                    f64::INFINITY
                }
            }
            Kind::Soc => {
                let rows = b.row0..b.row0 + b.dim;
                soc::max_step(&u[rows.clone()], &d[rows])
            }
        };
        alpha = alpha.min(a);
    }
    alpha
}

/// out = u ∘ v over all blocks.
fn product(st: &Structure, u: &[f64], v: &[f64], out: &mut [f64]) {
    for b in &st.blocks {
        let rows = b.row0..b.row0 + b.dim;
        match b.kind {
            Kind::NonNeg => out[b.row0] = u[b.row0] * v[b.row0],
            Kind::Soc => soc::product(&u[rows.clone()], &v[rows.clone()], &mut out[rows]),
        }
    }
}

/// out = λ ⋄ r over all blocks.
fn inverse_product(st: &Structure, lambda: &[f64], r: &[f64], out: &mut [f64]) {
    for b in &st.blocks {
        let rows = b.row0..b.row0 + b.dim;
        match b.kind {
            Kind::NonNeg => out[b.row0] = r[b.row0] / lambda[b.row0],
            Kind::Soc => {
                soc::inverse_product(&lambda[rows.clone()], &r[rows.clone()], &mut out[rows])
            }
        }
    }
}

/// Shifts u into the cones' interior when it is not (CVXOPT's start rule): u ← u + (1 + t) e
/// with t the largest shift any cone needs, when t ≥ −1e-8 max(‖u‖, 1).
fn shift_into_cones(st: &Structure, u: &mut [f64]) {
    let mut t = f64::NEG_INFINITY;
    for b in &st.blocks {
        let rows = b.row0..b.row0 + b.dim;
        t = t.max(match b.kind {
            Kind::NonNeg => -u[b.row0],
            Kind::Soc => soc::min_shift(&u[rows]),
        });
    }
    let nrm = u.iter().map(|v| v * v).sum::<f64>().sqrt();
    if t >= -1e-8 * nrm.max(1.0) {
        add_identity(st, u, 1.0 + t);
    }
}

/// u ← u + a e (e = the cones' identity).
fn add_identity(st: &Structure, u: &mut [f64], a: f64) {
    for b in &st.blocks {
        u[b.row0] += a;
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn inf_norm(a: &[f64]) -> f64 {
    a.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// A vector of the Newton system's three blocks: as a right-hand side (bx, bz, ξ) or as a
/// direction (Δx, Δz̃, Δs̃ in the scaled space).
#[derive(Debug, Clone)]
struct Kkt {
    /// Primal block (n entries).
    x: Vec<f64>,
    /// Dual block (m entries): bz, or Δz̃ = W Δz.
    z: Vec<f64>,
    /// Complementarity block (m entries): ξ, or Δs̃ = W⁻¹ Δs.
    s: Vec<f64>,
}

impl Kkt {
    fn zeros(n: usize, m: usize) -> Self {
        Self {
            x: vec![0.0; n],
            z: vec![0.0; m],
            s: vec![0.0; m],
        }
    }

    fn inf_norm(&self) -> f64 {
        inf_norm(&self.x)
            .max(inf_norm(&self.z))
            .max(inf_norm(&self.s))
    }
}

/// Workspace of the Newton solves.
struct Newton {
    hm: BandMatrix,
    chol: BandCholesky,
    u: Vec<f64>,
    /// Scratch of n and m entries.
    tn: Vec<f64>,
    tn2: Vec<f64>,
    tm: Vec<f64>,
    tm2: Vec<f64>,
    /// Residual of the full system and its correction, for iterative refinement.
    residual: Kkt,
    correction: Kkt,
    /// See [`BandedSettings::refine_tol`].
    refine_tol: f64,
}

impl Newton {
    fn new(n: usize, m: usize, bw: usize, refine_tol: f64) -> Self {
        Self {
            hm: BandMatrix::new(n, bw),
            chol: BandCholesky::new(n, bw),
            u: Vec::new(),
            tn: vec![0.0; n],
            tn2: vec![0.0; n],
            tm: vec![0.0; m],
            tm2: vec![0.0; m],
            residual: Kkt::zeros(n, m),
            correction: Kkt::zeros(n, m),
            refine_tol,
        }
    }

    /// One reduced solve with the factored H, no refinement (`tm`: scratch of m entries).
    fn reduced(
        chol: &BandCholesky,
        tm: &mut [f64],
        st: &Structure,
        sc: &Scaling,
        rhs: &Kkt,
        out: &mut Kkt,
    ) {
        // H Δx = bx + Gᵀ W⁻¹ (W⁻¹ bz − ξ)
        tm.copy_from_slice(&rhs.z);
        sc.apply_winv(st, tm);
        for (t, x) in tm.iter_mut().zip(&rhs.s) {
            *t -= x;
        }
        sc.apply_winv(st, tm);
        st.gt_mul(tm, &mut out.x);
        for (t, b) in out.x.iter_mut().zip(&rhs.x) {
            *t += b;
        }
        chol.solve(&mut out.x);
        // Δz̃ = W⁻¹(G Δx − bz) + ξ ; Δs̃ = ξ − Δz̃
        st.g_mul(&out.x, tm);
        for (t, b) in tm.iter_mut().zip(&rhs.z) {
            *t -= b;
        }
        sc.apply_winv(st, tm);
        for i in 0..st.m {
            out.z[i] = tm[i] + rhs.s[i];
            out.s[i] = rhs.s[i] - out.z[i];
        }
    }

    /// Solves P Δx + Gᵀ Δz = bx, G Δx + Δs = bz, Δs̃ + Δz̃ = ξ (Δs̃ = W⁻¹Δs, Δz̃ = WΔz) with H
    /// already factored. Iterative refinement runs on this full system (the reduced one alone
    /// loses the dual equation's accuracy as the scaling grows ill-conditioned near the
    /// optimum).
    fn solve(&mut self, st: &Structure, sc: &Scaling, refine_steps: u32, rhs: &Kkt, out: &mut Kkt) {
        Self::reduced(&self.chol, &mut self.tm, st, sc, rhs, out);
        let scale = 1.0 + rhs.inf_norm();
        for _ in 0..refine_steps {
            let e = &mut self.residual;
            // ex = bx − P Δx − Gᵀ W⁻¹ Δz̃
            st.p_mul(&out.x, &mut self.tn);
            self.tm.copy_from_slice(&out.z);
            sc.apply_winv(st, &mut self.tm);
            st.gt_mul(&self.tm, &mut self.tn2);
            for i in 0..st.n {
                e.x[i] = rhs.x[i] - self.tn[i] - self.tn2[i];
            }
            // ez = bz − G Δx − W Δs̃ ; eξ = ξ − Δs̃ − Δz̃
            st.g_mul(&out.x, &mut self.tm);
            self.tm2.copy_from_slice(&out.s);
            sc.apply_w(st, &mut self.tm2);
            for i in 0..st.m {
                e.z[i] = rhs.z[i] - self.tm[i] - self.tm2[i];
                e.s[i] = rhs.s[i] - out.s[i] - out.z[i];
            }
            if e.inf_norm() <= self.refine_tol * scale {
                break;
            }
            Self::reduced(&self.chol, &mut self.tm, st, sc, e, &mut self.correction);
            let c = &self.correction;
            for (d, c) in out.x.iter_mut().zip(&c.x) {
                *d += c;
            }
            for i in 0..st.m {
                out.s[i] += c.s[i];
                out.z[i] += c.z[i];
            }
        }
    }
}

/// Solves the cone program of `prob` with the banded interior-point method.
pub fn solve(
    prob: &ProblemBuilder,
    settings: &BandedSettings,
) -> Result<BandedSolution, BandedError> {
    let mut st = Structure::new(prob, settings.max_bandwidth)?;
    let d_scale = if settings.equilibrate {
        st.equilibrate(10)
    } else {
        vec![1.0; st.n]
    };
    let (n, m) = (st.n, st.m);
    let bw = st.bandwidth;
    let mut nw = Newton::new(n, m, bw, settings.refine_tol);
    let mut sc = Scaling::new(m, st.blocks.len());

    // start (W = I): (P + GᵀG) x = −q + Gᵀh, s = h − G x, z = −s, both shifted into the cones
    for v in sc.w.iter_mut() {
        *v = 1.0;
    }
    for (bi, b) in st.blocks.iter().enumerate() {
        sc.beta[bi] = 1.0;
        if b.kind == Kind::Soc {
            // w̄ = e gives Q(w̄) = I
            sc.w[b.row0 + 1..b.row0 + b.dim]
                .iter_mut()
                .for_each(|v| *v = 0.0);
        }
    }
    sc.assemble(&st, &mut nw.hm, &mut nw.u);
    regularise(&mut nw.hm);
    nw.chol
        .factor(&nw.hm)
        .map_err(|source| BandedError::Factorisation {
            iteration: 0,
            source,
        })?;
    let mut x = vec![0.0; n];
    st.gt_mul(&st.h, &mut x);
    for (xi, qi) in x.iter_mut().zip(&st.q) {
        *xi -= qi;
    }
    nw.chol.solve(&mut x);
    let mut s = vec![0.0; m];
    st.g_mul(&x, &mut s);
    for (si, hi) in s.iter_mut().zip(&st.h) {
        *si = hi - *si;
    }
    let mut z: Vec<f64> = s.iter().map(|v| -v).collect();
    shift_into_cones(&st, &mut s);
    shift_into_cones(&st, &mut z);

    let norm_h = inf_norm(&st.h);
    let norm_q = inf_norm(&st.q);
    let mut px = vec![0.0; n];
    let mut gtz = vec![0.0; n];
    let mut gx = vec![0.0; m];
    // right-hand side: the negated residuals −r_x, −r_z and, per solve, ξ
    let mut rhs = Kkt::zeros(n, m);
    let mut affine = Kkt::zeros(n, m);
    let mut dir = Kkt::zeros(n, m);
    let mut rs = vec![0.0; m];
    let mut tmp = vec![0.0; m];
    let (mut pres, mut dres, mut gap_rel) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let mut gap0 = 0.0f64;
    let mut ran = 0;

    for iteration in 0..=settings.max_iter {
        // residuals and stopping rule (Clarabel's normalisation)
        st.p_mul(&x, &mut px);
        st.gt_mul(&z, &mut gtz);
        st.g_mul(&x, &mut gx);
        for i in 0..n {
            rhs.x[i] = -(px[i] + gtz[i] + st.q[i]);
        }
        for i in 0..m {
            rhs.z[i] = -(gx[i] + s[i] - st.h[i]);
        }
        let xpx = dot(&x, &px);
        let pobj = 0.5 * xpx + dot(&st.q, &x);
        // the gap is the complementarity sᵀz (as in CVXOPT): |pobj − dobj| = |xᵀr_x + sᵀz −
        // zᵀr_z| would charge the dual residual once more, times the large positions
        let gap_abs = dot(&s, &z);
        gap_rel = gap_abs / pobj.abs().max(1.0);
        pres = inf_norm(&rhs.z) / (1.0 + norm_h.max(inf_norm(&x)).max(inf_norm(&s)));
        dres = inf_norm(&rhs.x) / (1.0 + norm_q.max(inf_norm(&px)).max(inf_norm(&gtz)));
        tracing::trace!(
            iteration,
            pobj,
            pres,
            dres,
            gap_rel,
            "banded interior-point iteration"
        );
        if !(pobj.is_finite() && pres.is_finite() && dres.is_finite() && gap_abs.is_finite()) {
            return Err(BandedError::Numerical {
                iteration,
                what: "non-finite residual",
            });
        }
        if pres <= settings.tol_feas
            && dres <= settings.tol_dual
            && (gap_abs <= settings.tol_gap_abs || gap_rel <= settings.tol_gap_rel)
        {
            let mut out = vec![0.0; n];
            for (new, &old) in st.perm.iter().enumerate() {
                out[old] = x[new] * d_scale[new];
            }
            return Ok(BandedSolution {
                x: out,
                iterations: iteration,
                bandwidth: bw,
            });
        }
        ran = iteration;
        if iteration == settings.max_iter {
            break;
        }

        // scaling and normal equations
        if !sc.update(&st, &s, &z) {
            return Err(BandedError::Numerical {
                iteration,
                what: "iterate left the cones",
            });
        }
        sc.assemble(&st, &mut nw.hm, &mut nw.u);
        regularise(&mut nw.hm);
        nw.chol
            .factor(&nw.hm)
            .map_err(|source| BandedError::Factorisation { iteration, source })?;
        let mu = gap_abs / st.degree as f64;
        if iteration == 0 {
            gap0 = gap_abs;
        } else if gap_abs > 1e8 * gap0.max(1.0) {
            // s and z grow without bound: no solution this method can reach
            break;
        }

        // refinement only pays near the optimum, where the scaling is ill-conditioned
        let refine_steps = if gap_rel <= settings.refine_below_gap {
            settings.refine_steps
        } else {
            0
        };
        // predictor: λ ∘ (Δs̃ + Δz̃) = −λ∘λ, i.e. ξ = −λ
        for (x, l) in rhs.s.iter_mut().zip(&sc.lambda) {
            *x = -l;
        }
        nw.solve(&st, &sc, refine_steps, &rhs, &mut affine);
        let alpha_a = sc
            .max_step(&st, &affine.s)
            .min(sc.max_step(&st, &affine.z))
            .min(1.0);
        // σ from the gap the affine step would leave (in the scaled space, sᵀz = λᵀλ)
        let mut new_gap = 0.0;
        for i in 0..m {
            new_gap +=
                (sc.lambda[i] + alpha_a * affine.s[i]) * (sc.lambda[i] + alpha_a * affine.z[i]);
        }
        let sigma = (new_gap / gap_abs).clamp(0.0, 1.0).powi(3);

        // corrector: r = −λ∘λ − Δs̃_a ∘ Δz̃_a + σ μ e
        product(&st, &sc.lambda, &sc.lambda, &mut rs);
        product(&st, &affine.s, &affine.z, &mut tmp);
        for i in 0..m {
            rs[i] = -rs[i] - tmp[i];
        }
        add_identity(&st, &mut rs, sigma * mu);
        inverse_product(&st, &sc.lambda, &rs, &mut rhs.s);
        nw.solve(&st, &sc, refine_steps, &rhs, &mut dir);
        let scaled_max = sc.max_step(&st, &dir.s).min(sc.max_step(&st, &dir.z));
        // back to the unscaled space: Δs = W Δs̃, Δz = W⁻¹ Δz̃
        let Kkt {
            x: dx,
            z: dz,
            s: ds,
        } = &mut dir;
        sc.apply_w(&st, ds);
        sc.apply_winv(&st, dz);
        // the same step limit in the unscaled space: near the optimum the scaling is so
        // ill-conditioned that rounding in W could otherwise put s or z just outside a cone
        let alpha_max = scaled_max
            .min(max_step(&st, &s, ds))
            .min(max_step(&st, &z, dz));
        let alpha = (0.99 * alpha_max).min(1.0);
        if !(alpha.is_finite() && alpha > 1e-10)
            || dx
                .iter()
                .chain(ds.iter())
                .chain(dz.iter())
                .any(|v| !v.is_finite())
        {
            break;
        }
        for i in 0..n {
            x[i] += alpha * dx[i];
        }
        for i in 0..m {
            s[i] += alpha * ds[i];
            z[i] += alpha * dz[i];
        }
    }
    Err(BandedError::NotConverged {
        iterations: ran,
        pres,
        dres,
        gap: gap_rel,
    })
}

/// Static regularisation of the normal equations: a diagonal shift of 1e-13 of their largest
/// diagonal entry, far below the tolerances (refinement works against the shifted matrix).
fn regularise(hm: &mut BandMatrix) {
    let eps = 1e-13 * hm.max_diag().max(1e-300);
    for i in 0..hm.dim() {
        hm.add(i, i, eps);
    }
}

#[cfg(test)]
mod tests;
