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
use crate::{Mission, Params};

use super::iterate::record;
use super::options::Deadline;
use super::progress::{relative_change, LoopEnd, TrustRegion};
use super::{BestEffort, Observer, PlanError, PlanOptions, PlanResult, Scheme, TerminationReason};

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
    let (fixed, start_profile) =
        match super::run_plan_from(started, &fixed_mission, options, observer, stop) {
            Ok(plan) => (plan, vec![p.altitude_m; n]),
            Err(error) => {
                let lowest = bounds_m(p).0;
                if lowest >= p.altitude_m || matches!(error, PlanError::TimeLimit { .. }) {
                    return Err(error);
                }
                tracing::info!(%error, lowest, "no plan at the fixed altitude; trying the lowest");
                let low_mission = fixed_at(mission, lowest)?;
                let profile = descent_profile(p, lowest, n);
                match super::run_plan_from(started, &low_mission, options, observer, stop) {
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

/// The exact SCA with free altitudes from the plan `fixed` flown at `profile`.
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
    let merit = |ev: &Evaluation| match tuning.cell_slack_weight {
        Some(w) => ev.energy_j + w * total_deficit_m(mission, ev),
        None => ev.energy_j,
    };
    let mut current = fixed.trajectory.clone();
    let mut altitudes = profile;
    let mut ev = evaluate_with_altitudes(mission, &current, &altitudes)
        .map_err(|e| PlanError::InvalidInit(format!("the fixed plan's altitude profile: {e}")))?;
    let mut value = merit(&ev);
    let mut tuning_now = tuning;
    let mut solver = SocpSolver::new(options.exact_socp);
    let mut end = LoopEnd::continuing(&fixed);
    let mut trust = TrustRegion::default();
    let first = end.records.len();
    for it in first + 1..=first + options.max_iterations {
        if deadline.passed() {
            end.termination = TerminationReason::TimeLimit;
            break;
        }
        let t0 = Instant::now();
        let sub = ExactSubproblem::build_with_altitudes(
            mission,
            &current,
            &altitudes,
            ExactObjective::Energy,
            &tuning_now,
        );
        end.cone_programs += 1;
        let step = solver.solve(&sub.builder).map(|sol| {
            let cand = sub.trajectory(&sol.x, &current);
            let z = sub.altitudes_m(&sol.x).unwrap_or_else(|| altitudes.clone());
            (sol, cand, z)
        });
        let accepted = match step {
            Ok((sol, cand, z)) => {
                let cand_ev = evaluate_with_altitudes(mission, &cand, &z).ok();
                let own = sub.physical_objective(sol.objective);
                let ok = cand_ev.as_ref().is_some_and(|e| {
                    judge_feasible(&fixed, options, e)
                        && merit(e) <= value * (1.0 + 1e-9) + 1e-9
                        && e.energy_j <= fixed.evaluation.energy_j * (1.0 + 1e-9)
                });
                let shown = cand_ev.as_ref().unwrap_or(&ev);
                let rec = record(
                    it,
                    own,
                    shown,
                    sol.iterations,
                    t0.elapsed().as_secs_f64(),
                    ok,
                );
                observer.on_iteration(&rec);
                end.records.push(rec);
                match cand_ev {
                    Some(cand_ev) if ok => Some((cand, z, cand_ev, own)),
                    _ => None,
                }
            }
            Err(error) => {
                tracing::debug!(%error, iteration = it, "free-altitude subproblem failed");
                end.records.push(record(
                    it,
                    f64::NAN,
                    &ev,
                    0,
                    t0.elapsed().as_secs_f64(),
                    false,
                ));
                None
            }
        };
        let Some((cand, z, cand_ev, own)) = accepted else {
            if trust.reject(&mut tuning_now.trust_radius_m) {
                end.termination = TerminationReason::NoProgress;
                break;
            }
            continue;
        };
        let cand_value = merit(&cand_ev);
        let rel = relative_change(value, cand_value);
        current = cand;
        altitudes = z;
        ev = cand_ev;
        value = cand_value;
        end.accept(own, ev.energy_j);
        tracing::debug!(
            iteration = it,
            objective = own,
            true_value = value,
            rel,
            "accepted"
        );
        if rel < options.tolerance {
            end.termination = TerminationReason::Converged;
            break;
        }
        trust.accept(&mut tuning_now.trust_radius_m);
    }
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
        ..end.into_free_plan(fixed, Scheme::Exact, current, altitudes, ev)
    })
}
