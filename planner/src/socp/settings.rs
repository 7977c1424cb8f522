//! Settings of the subproblem solver: [`SocpSettings`].

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
