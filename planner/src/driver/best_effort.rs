//! Best effort under the general resolution: when no trajectory keeps the resolution cell within
//! d_min in every landmark slot, the plan that minimises the resolution deficit
//! ([`crate::shortfall`]) and, at that deficit, the energy, with every other constraint hard.
//!
//! The deficit enters the `exact` subproblem through one slack per landmark slot on the cell
//! constraints ([`ExactTuning::cell_slack_weight`]), tight at the previous iterate; the loop
//! accepts a step only if it lowers the true merit (energy + weight × deficit, measured on the
//! exact geometry) and keeps every other constraint, so it improves monotonically on the
//! least-energy plan it starts from. An energy cap ([`PlanOptions::max_extra_energy_pct`]) is a
//! constraint on the surrogate energy, which over-estimates the true one.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use crate::evaluate::ResolutionMode;
use crate::schemes::exact::{ExactObjective, ExactTuning};
use crate::shortfall::ResolutionShortfall;
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

use super::iterate::{run_exact, Means};
use super::options::Deadline;
use super::{BestEffort, Observer, PlanError, PlanOptions, PlanResult, Scheme};

/// What every best-effort plan of a mission starts from: the least-energy plan and, when it
/// exists, the strict general plan (each computed once; the trade-off reuses them).
#[derive(Debug, Clone)]
pub struct BestEffortBasis {
    /// The least-energy plan (`paper` resolution).
    pub least_energy: PlanResult,
    /// The strict general plan, or why it was refused. The best effort from the least-energy
    /// plan is a local method: on the far-start mission it stops at 2 unresolved windows,
    /// while the strict plan resolves every slot.
    pub strict: Result<PlanResult, String>,
}

impl BestEffortBasis {
    /// Plans the least-energy plan and, unless that one already meets the general resolution
    /// everywhere, the strict general plan (a refusal is kept as its message; any other error
    /// is returned).
    pub fn new(
        mission: &Mission,
        options: &PlanOptions,
        observer: &mut dyn Observer,
    ) -> Result<Self, PlanError> {
        Self::new_until(mission, options, observer, None)
    }

    /// [`BestEffortBasis::new`], stopping early once `stop` is set.
    fn new_until(
        mission: &Mission,
        options: &PlanOptions,
        observer: &mut dyn Observer,
        stop: Option<&AtomicBool>,
    ) -> Result<Self, PlanError> {
        let least_energy = super::run_plan(
            mission,
            &PlanOptions {
                resolution: ResolutionMode::Paper,
                max_extra_energy_pct: None,
                ..options.clone()
            },
            observer,
            stop,
        )?;
        let general = ResolutionMode::General;
        let strict = if least_energy.evaluation.is_feasible_for(general) {
            Ok(least_energy.clone())
        } else {
            let strict_options = PlanOptions {
                resolution: general,
                strict_resolution: true,
                ..options.clone()
            };
            match super::run_plan(mission, &strict_options, observer, stop) {
                Ok(plan) => Ok(plan),
                Err(PlanError::Infeasible(why)) => Err(why.to_string()),
                Err(e) => return Err(e),
            }
        };
        Ok(Self {
            least_energy,
            strict,
        })
    }

    /// True energy of the least-energy plan, J.
    pub fn least_energy_j(&self) -> f64 {
        self.least_energy.evaluation.energy_j
    }
}

/// The best-effort plan of `mission` (the `exact` scheme under the general resolution, not
/// strict): see the module documentation.
pub(super) fn plan_best_effort(
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Result<PlanResult, PlanError> {
    let started = Instant::now();
    let basis = BestEffortBasis::new_until(mission, options, observer, stop)?;
    let mut out = best_effort_until(mission, options, &basis, None, observer, stop)?;
    out.solve_seconds = started.elapsed().as_secs_f64();
    Ok(out)
}

/// The best-effort plan of `mission` from an already planned `basis`, under
/// `options.max_extra_energy_pct`, its iterations started from `start` (default: the
/// least-energy plan; a given start must meet every constraint but the resolution, and the
/// energy cap). Its `solve_seconds` counts only this step.
///
/// The strict general plan, when there is one within the cap, is the answer (no shortfall,
/// least energy). Otherwise the best effort runs; when it resolves every slot, the strict
/// general SCA continues from it with the cell constraints hard, lowering the energy.
/// `strict_refusal` says why the strict plan was refused (`None`: it exists, beyond the cap).
pub fn best_effort_from(
    mission: &Mission,
    options: &PlanOptions,
    basis: &BestEffortBasis,
    start: Option<&Trajectory>,
    observer: &mut dyn Observer,
) -> Result<PlanResult, PlanError> {
    best_effort_until(mission, options, basis, start, observer, None)
}

/// [`best_effort_from`], stopping early once `stop` is set.
fn best_effort_until(
    mission: &Mission,
    options: &PlanOptions,
    basis: &BestEffortBasis,
    start: Option<&Trajectory>,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Result<PlanResult, PlanError> {
    options.validate()?;
    let started = Instant::now();
    let deadline = Deadline::after(started, options.time_limit_s, stop);
    let least_j = basis.least_energy_j();
    let cap_j = options
        .max_extra_energy_pct
        .map(|pct| least_j * (1.0 + pct / 100.0));
    let info = BestEffort {
        least_energy_j: least_j,
        least_energy_shortfall: ResolutionShortfall::new(mission, &basis.least_energy.evaluation),
        max_extra_energy_pct: options.max_extra_energy_pct,
        strict_refusal: basis.strict.as_ref().err().cloned(),
    };
    let general = ResolutionMode::General;
    let finish = |mut out: PlanResult, programs: usize| {
        out.scheme = Scheme::Exact;
        out.resolution = general;
        out.start_energy_j = least_j;
        out.cone_programs += programs;
        out.best_effort = Some(info.clone());
        out.solve_seconds = started.elapsed().as_secs_f64();
        out
    };
    if let Ok(plan) = &basis.strict {
        if cap_j.is_none_or(|cap| plan.evaluation.energy_j <= cap) {
            return Ok(finish(plan.clone(), 0));
        }
    }
    observer.on_phase("best effort");
    let tuning = ExactTuning {
        resolution: general,
        cell_slack_weight: Some(options.resolution_weight_j_per_m),
        energy_cap_j: cap_j,
        ..ExactTuning::default()
    };
    let mut solver = SocpSolver::new(options.exact_socp);
    let out = run_exact(
        mission,
        start.unwrap_or(&basis.least_energy.trajectory).clone(),
        ExactObjective::Energy,
        &tuning,
        options,
        Means {
            solver: &mut solver,
            observer: &mut *observer,
            deadline,
        },
    )?;
    if !out.evaluation.is_feasible_for(general) {
        return Ok(finish(out, 0));
    }
    // every slot resolved: the least energy with the cell constraints hard, from here
    let strict = ExactTuning {
        cell_slack_weight: None,
        ..tuning
    };
    let programs = out.cone_programs;
    let polished = run_exact(
        mission,
        out.trajectory.clone(),
        ExactObjective::Energy,
        &strict,
        options,
        Means {
            solver: &mut solver,
            observer,
            deadline,
        },
    )?;
    Ok(finish(polished, programs))
}
