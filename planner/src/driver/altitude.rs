//! Free altitude (`altitude = "free"`, the `exact` scheme with
//! [`PlanOptions::altitude_profile`]): the plan at the fixed altitude `altitude_m` first (every
//! path of the fixed mission: least energy, strict general, best effort), then the exact SCA with
//! the altitude H_t of every slot a decision (`ExactSubproblem::build_with_altitudes`) from
//! that plan at H_t = `altitude_m`. Every iterate is checked by
//! [`evaluate_with_altitudes`] and accepted only when it is feasible and its true merit (the
//! energy with the climb power, plus the weighted resolution deficit while the plan is a best
//! effort that leaves slots unresolved) does not increase and whose energy is at most the
//! starting plan's (a best effort's subproblems are capped at it too): the plan never uses more
//! energy than the fixed one, and a best effort buys resolution with altitude only where it
//! costs no energy.
//!
//! A mission the fixed altitude cannot fly is started instead from its plan at the lowest
//! altitude `min_altitude_m`, flown along the fastest descent there from `altitude_m`, when that
//! is feasible (landmark windows that begin after the descent).

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use crate::altitude::{bounds_m, params_at, AltitudeMode};
use crate::evaluate::{evaluate_with_altitudes, Evaluation};
use crate::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use crate::shortfall::total_deficit_m;
use crate::socp::SocpSolver;
use crate::{Mission, Params, Trajectory};

use super::executor::{execute, Candidate, Control, Failure, Step};
use super::options::Deadline;
use super::progress::LoopEnd;
use super::table;
use super::{BestEffort, Observer, PlanError, PlanOptions, PlanResult, Scheme};

/// The mission at one fixed altitude `altitude_m` (its bounds dropped), the sensing radius of
/// the same antenna there.
pub(super) fn fixed_at(mission: &Mission, altitude_m: f64) -> Result<Mission, PlanError> {
    let mut p: Params = params_at(mission.params(), altitude_m);
    p.altitude = AltitudeMode::Fixed;
    p.min_altitude_m = None;
    p.max_altitude_m = None;
    mission
        .with_params(p)
        .map_err(|e| PlanError::InvalidInit(format!("the mission at {altitude_m} m: {e}")))
}

/// The fastest descent from the mission's `altitude_m` to `floor_m`, then level (one altitude
/// per slot).
fn descent_profile(p: &Params, floor_m: f64, slots: usize) -> Vec<f64> {
    (1..=slots)
        .map(|t| {
            (p.altitude_m - p.max_descent_mps * (1.0 - 1e-9) * p.slot_s * t as f64).max(floor_m)
        })
        .collect()
}

/// Plans the free-altitude `mission` (see the module documentation); `started` is the run's
/// clock.
pub(super) fn plan_free(
    started: Instant,
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Result<PlanResult, PlanError> {
    let p = mission.params();
    let n = mission.slots();
    let fixed_mission = fixed_at(mission, p.altitude_m)?;
    let (fixed, start_profile) = match super::plan_fixed(
        started,
        &fixed_mission,
        options,
        observer,
        stop,
        Default::default(),
    ) {
        Ok(plan) => (plan, vec![p.altitude_m; n]),
        Err(error) => {
            let lowest = bounds_m(p).0;
            if lowest >= p.altitude_m || matches!(error, PlanError::TimeLimit { .. }) {
                return Err(error);
            }
            tracing::info!(%error, lowest, "no plan at the fixed altitude; trying the lowest");
            let low_mission = fixed_at(mission, lowest)?;
            let profile = descent_profile(p, lowest, n);
            match super::plan_fixed(
                started,
                &low_mission,
                options,
                observer,
                stop,
                Default::default(),
            ) {
                Ok(plan)
                    if evaluate_with_altitudes(mission, &plan.trajectory, &profile)
                        .is_ok_and(|ev| judge_feasible(&plan, options, &ev)) =>
                {
                    (plan, profile)
                }
                _ => return Err(error),
            }
        }
    };
    let deadline = Deadline::after(started, options.time_limit_s, stop);
    observer.on_phase("altitude");
    refine(mission, fixed, start_profile, options, observer, deadline)
}

/// Whether `ev` meets what the fixed plan `plan` was planned for, at its own altitudes.
fn judge_feasible(plan: &PlanResult, options: &PlanOptions, ev: &Evaluation) -> bool {
    let slack = plan
        .best_effort
        .as_ref()
        .is_some_and(|b| b.strict_refusal.is_some());
    let constraints = if slack {
        ev.is_feasible()
    } else {
        ev.is_feasible_for(plan.resolution)
    };
    let cap = plan.best_effort.as_ref().and_then(|b| {
        b.max_extra_energy_pct
            .map(|pct| b.least_energy_j * (1.0 + pct / 100.0))
    });
    constraints && ev.meets(options.dynamics) && cap.is_none_or(|c| ev.energy_j <= c * (1.0 + 1e-9))
}

/// The exact SCA with free altitudes from the plan `fixed` flown at `profile`, run by the
/// executor with the row [`table::free_altitude`].
fn refine(
    mission: &Mission,
    fixed: PlanResult,
    profile: Vec<f64>,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    deadline: Deadline<'_>,
) -> Result<PlanResult, PlanError> {
    let best_effort = fixed.best_effort.clone();
    let slack = best_effort
        .as_ref()
        .is_some_and(|b| b.strict_refusal.is_some());
    let tuning = ExactTuning {
        resolution: fixed.resolution,
        dynamics: options.dynamics,
        cell_slack_weight: slack.then_some(options.resolution_weight_j_per_m),
        // free altitude never costs more energy than the fixed plan it starts from: a best
        // effort (whose merit also counts the resolution deficit) is capped at that energy too
        energy_cap_j: best_effort.as_ref().map(|b| {
            let fixed_j = fixed.evaluation.energy_j;
            b.max_extra_energy_pct.map_or(fixed_j, |pct| {
                fixed_j.min(b.least_energy_j * (1.0 + pct / 100.0))
            })
        }),
        ..ExactTuning::default()
    };
    let mut step = FreeAltitudeStep {
        mission,
        fixed: &fixed,
        options,
        tuning,
        solver: SocpSolver::new(options.exact_socp),
        programs: 0,
    };
    let start = (fixed.trajectory.clone(), profile);
    let out = execute(
        &mut step,
        start,
        &table::free_altitude(options, fixed.records.len()),
        Control::of(&tuning),
        LoopEnd::continuing(&fixed),
        observer,
        deadline,
    )
    .map_err(|e| match e {
        PlanError::InvalidInit(why) => {
            PlanError::InvalidInit(format!("the fixed plan's altitude profile: {why}"))
        }
        other => other,
    })?;
    let ((current, altitudes), ev) = (out.iterate, out.evaluation);
    // a best effort's refusal names a slot the free plan leaves unresolved
    let best_effort = best_effort.map(|b| BestEffort {
        strict_refusal: b
            .strict_refusal
            .as_ref()
            .and(super::best_effort::strict_refusal(mission, &ev)),
        ..b
    });
    Ok(PlanResult {
        best_effort,
        ..out
            .end
            .into_free_plan(fixed, Scheme::Exact, current, altitudes, ev)
    })
}

/// One step of the free-altitude SCA: the cone program with every slot's altitude a decision
/// ([`ExactSubproblem::build_with_altitudes`]), judged at the candidate's altitudes against what
/// the fixed plan `fixed` was planned for, and never above its energy.
struct FreeAltitudeStep<'a> {
    mission: &'a Mission,
    fixed: &'a PlanResult,
    options: &'a PlanOptions,
    tuning: ExactTuning,
    solver: SocpSolver,
    programs: usize,
}

impl Step for FreeAltitudeStep<'_> {
    /// The track and the altitude of every slot, m.
    type Iterate = (Trajectory, Vec<f64>);

    fn evaluate(&self, (track, altitudes): &Self::Iterate) -> Result<Evaluation, PlanError> {
        evaluate_with_altitudes(self.mission, track, altitudes)
            .map_err(|e| PlanError::InvalidInit(e.to_string()))
    }

    fn propose(
        &mut self,
        (track, altitudes): &Self::Iterate,
        control: Control,
    ) -> Result<Candidate<Self::Iterate>, Failure> {
        let tuning = control.applied_to(&self.tuning);
        let sub = ExactSubproblem::build_with_altitudes(
            self.mission,
            track,
            altitudes,
            ExactObjective::Energy,
            &tuning,
        );
        self.programs += 1;
        let sol = self.solver.solve(&sub.builder).map_err(Failure::Solver)?;
        let cand = sub.trajectory(&sol.x, track);
        let z = sub.altitudes_m(&sol.x).unwrap_or_else(|| altitudes.clone());
        let evaluation = evaluate_with_altitudes(self.mission, &cand, &z)
            .map_err(|e| Failure::Unusable(e.to_string()))?;
        Ok(Candidate {
            iterate: (cand, z),
            evaluation,
            objective: sub.physical_objective(sol.objective),
            ipm_iterations: sol.iterations,
        })
    }

    /// The energy with the climb power, plus the weighted resolution deficit in a best effort.
    fn merit(&self, ev: &Evaluation) -> f64 {
        match self.tuning.cell_slack_weight {
            Some(w) => ev.energy_j + w * total_deficit_m(self.mission, ev),
            None => ev.energy_j,
        }
    }

    fn admissible(&self, ev: &Evaluation, _current: &Evaluation) -> bool {
        judge_feasible(self.fixed, self.options, ev)
            && ev.energy_j <= self.fixed.evaluation.energy_j * (1.0 + 1e-9)
    }

    fn cone_programs(&self) -> usize {
        self.programs
    }
}
