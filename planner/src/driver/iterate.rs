//! The iteration loops of the schemes (exact-geometry SCA, Algorithm 1) and their records.

use std::time::Instant;

use crate::evaluate::{evaluate, evaluate_with_altitudes, Dynamics, Evaluation, ResolutionMode};
use crate::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use crate::schemes::paper::{PaperObjective, PaperState};
use crate::shortfall::total_deficit_m;
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

use super::options::Deadline;
pub(super) use super::progress::LoopEnd;
use super::progress::{relative_change, TrustRegion, MAX_REJECTS};
use super::{
    IterationRecord, Observer, PlanError, PlanOptions, PlanResult, Scheme, TerminationReason,
};

pub(super) fn record(
    iteration: usize,
    objective: f64,
    ev: &Evaluation,
    ipm: u32,
    seconds: f64,
    accepted: bool,
) -> IterationRecord {
    IterationRecord {
        iteration,
        objective,
        true_energy_j: ev.energy_j,
        sensing_violation_m: ev.violations.sensing_m,
        speed_violation_mps: ev.violations.min_speed_mps,
        ipm_iterations: ipm,
        seconds,
        accepted,
    }
}

/// The means a loop runs with: the cone-program solver, the observer it reports to, the
/// deadline.
pub(super) struct Means<'s> {
    pub solver: &'s mut SocpSolver,
    pub observer: &'s mut dyn Observer,
    pub deadline: Deadline<'s>,
}

/// The result of a loop that ended with `trajectory`.
pub(super) fn finish(mission: &Mission, trajectory: Trajectory, end: LoopEnd) -> PlanResult {
    let LoopEnd {
        objective,
        objective_history,
        true_energy_history,
        records,
        termination,
        cone_programs,
    } = end;
    let evaluation = evaluate(mission, &trajectory);
    PlanResult {
        scheme: Scheme::Exact,
        iterations: records.len(),
        converged: termination == TerminationReason::Converged,
        trajectory,
        evaluation,
        objective,
        objective_history,
        true_energy_history,
        records,
        termination,
        solve_seconds: 0.0,
        start_energy_j: 0.0,
        repair_iterations: 0,
        cone_programs,
        resolution: ResolutionMode::Paper,
        init_replaced: None,
        best_effort: None,
        dynamics: Dynamics::Paper,
        altitudes_m: None,
        bound: None,
    }
}

/// The exact-geometry SCA loop (monotone: a step is accepted only if it is feasible on the exact
/// geometry and does not increase the true objective; otherwise a trust region is tightened).
pub(super) fn run_exact(
    mission: &Mission,
    start: Trajectory,
    objective: ExactObjective,
    base: &ExactTuning,
    options: &PlanOptions,
    means: Means<'_>,
) -> Result<PlanResult, PlanError> {
    let Means {
        solver,
        observer,
        deadline,
    } = means;
    let judge = Judge {
        mission,
        objective,
        tuning: base,
    };
    let true_value = |ev: &Evaluation| judge.value(ev);
    let mut current = start;
    let mut ev = evaluate(mission, &current);
    let mut value = true_value(&ev);
    let mut tuning = *base;
    let mut end = LoopEnd::starting(value);
    let mut merits = vec![value];
    let mut trust = TrustRegion::default();
    for it in 1..=options.max_iterations {
        if deadline.passed() {
            end.termination = TerminationReason::TimeLimit;
            break;
        }
        let t0 = Instant::now();
        let sub = ExactSubproblem::build(mission, &current, objective, &tuning);
        end.cone_programs += 1;
        let sol = match solver.solve(&sub.builder) {
            Ok(s) => s,
            Err(e) => {
                if it == 1 && tuning.trust_radius_m.is_none() && end.records.is_empty() {
                    tracing::debug!(error = %e, "first subproblem failed; retrying with a trust region");
                }
                let stop = trust.reject(&mut tuning.trust_radius_m);
                end.records.push(record(
                    it,
                    f64::NAN,
                    &ev,
                    0,
                    t0.elapsed().as_secs_f64(),
                    false,
                ));
                if stop {
                    if end.objective_history.is_empty() && it <= MAX_REJECTS + 1 {
                        return Err(PlanError::Solver {
                            iteration: it,
                            error: e,
                        });
                    }
                    end.termination = TerminationReason::SubproblemFailed(e.to_string());
                    break;
                }
                continue;
            }
        };
        let cand = sub.trajectory(&sol.x, &current);
        let cand_ev = evaluate(mission, &cand);
        let cand_value = true_value(&cand_ev);
        let (cand, cand_ev, cand_value) = if options.over_relaxation {
            judge.over_relax(&current, value, (cand, cand_ev, cand_value))
        } else {
            (cand, cand_ev, cand_value)
        };
        let own = sub.physical_objective(sol.objective);
        let ok = judge.feasible(&cand_ev) && cand_value <= value * (1.0 + 1e-9) + 1e-9;
        let rec = record(
            it,
            own,
            &cand_ev,
            sol.iterations,
            t0.elapsed().as_secs_f64(),
            ok,
        );
        observer.on_iteration(&rec);
        end.records.push(rec);
        if !ok && tuning.kappa_scale < 1.0 {
            // the optimistic model overreached: fall back to the proven bound and re-solve
            tuning.kappa_scale = (tuning.kappa_scale * 2.0).min(1.0);
            continue;
        }
        if !ok {
            tracing::debug!(
                iteration = it,
                feasible = judge.feasible(&cand_ev),
                value = cand_value,
                previous = value,
                "step rejected"
            );
            if trust.reject(&mut tuning.trust_radius_m) {
                end.termination = TerminationReason::NoProgress;
                break;
            }
            continue;
        }
        let rel = relative_change(value, cand_value);
        current = cand;
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
        merits.push(value);
        if rel < options.tolerance || best_effort_stalled(base, &merits) {
            end.termination = TerminationReason::Converged;
            break;
        }
        // a successful step relaxes the trust region again and makes the centre model bolder
        trust.accept(&mut tuning.trust_radius_m);
        tuning.kappa_scale = (tuning.kappa_scale * 0.8).max(options.min_kappa_scale);
    }
    Ok(finish(mission, current, end))
}

/// Best effort: the loop stops once the true merit (energy + weight × deficit) fell by less than
/// [`BEST_EFFORT_STALL_REL`] over the last [`BEST_EFFORT_STALL_STEPS`] accepted steps: the last
/// steps of the slack SCA move slots whose widths are already near d_min (on the default 30 m
/// mission the merit falls by 88 % in the first 8 accepted steps, no window is unresolved from
/// the 9th, and the merit falls by 0.8 % over the 5 steps before the rule stops it at the 18th;
/// BENCHMARKS.md, "Best-effort resolution").
pub(super) const BEST_EFFORT_STALL_STEPS: usize = 5;
/// See [`BEST_EFFORT_STALL_STEPS`].
pub(super) const BEST_EFFORT_STALL_REL: f64 = 1e-2;

/// Whether a best-effort loop (cell slacks on) with the accepted merits `merits` (its start
/// first) has stalled ([`BEST_EFFORT_STALL_STEPS`]).
fn best_effort_stalled(tuning: &ExactTuning, merits: &[f64]) -> bool {
    if tuning.cell_slack_weight.is_none() || merits.len() <= BEST_EFFORT_STALL_STEPS {
        return false;
    }
    let last = merits[merits.len() - 1];
    let before = merits[merits.len() - 1 - BEST_EFFORT_STALL_STEPS];
    (before - last) < BEST_EFFORT_STALL_REL * before.abs()
}

/// How the exact loop judges an iterate on the exact geometry.
struct Judge<'a> {
    mission: &'a Mission,
    objective: ExactObjective,
    tuning: &'a ExactTuning,
}

impl Judge<'_> {
    /// The true merit: the objective's true value, plus, in best effort, the weighted
    /// resolution deficit.
    fn value(&self, ev: &Evaluation) -> f64 {
        let own = self.objective.true_value(ev);
        match self.tuning.cell_slack_weight {
            Some(w) => own + w * total_deficit_m(self.mission, ev),
            None => own,
        }
    }

    /// Over-relaxation: SCA steps limited by the conservative centre bound tend to repeat in
    /// the same direction; try longer steps (2× and 4×) from `current` (of true value `value`)
    /// along the step to the candidate and keep the best that stays feasible.
    fn over_relax(
        &self,
        current: &Trajectory,
        value: f64,
        cand: (Trajectory, Evaluation, f64),
    ) -> (Trajectory, Evaluation, f64) {
        let (mut cand, mut cand_ev, mut cand_value) = cand;
        if !(self.feasible(&cand_ev) && cand_value < value) {
            return (cand, cand_ev, cand_value);
        }
        for alpha in [2.0, 4.0] {
            let trial = extrapolate(current, &cand, alpha);
            let ev = evaluate(self.mission, &trial);
            let v = self.value(&ev);
            if self.feasible(&ev) && v < cand_value {
                cand = trial;
                cand_ev = ev;
                cand_value = v;
            } else {
                break;
            }
        }
        (cand, cand_ev, cand_value)
    }

    /// Feasible for the loop's requirements: every constraint, the cell ones only when they
    /// are hard, and the energy cap.
    fn feasible(&self, ev: &Evaluation) -> bool {
        let constraints = match self.tuning.cell_slack_weight {
            Some(_) => ev.is_feasible(),
            None => ev.is_feasible_for(self.tuning.resolution),
        };
        constraints
            && ev.meets(self.tuning.dynamics)
            && self
                .tuning
                .energy_cap_j
                .is_none_or(|cap| ev.energy_j <= cap * (1.0 + 1e-9))
    }
}

/// `from + alpha (to − from)`, slot by slot.
pub(super) fn extrapolate(from: &Trajectory, to: &Trajectory, alpha: f64) -> Trajectory {
    Trajectory {
        slot_s: to.slot_s,
        start_m: to.start_m,
        pos_m: from
            .pos_m
            .iter()
            .zip(&to.pos_m)
            .map(|(a, b)| [a[0] + alpha * (b[0] - a[0]), a[1] + alpha * (b[1] - a[1])])
            .collect(),
    }
}

/// Algorithm 1 (or the baseline) exactly as printed: alternate (p5) and (p6) from the start.
/// `state_out` receives the BCD state {q, V, q_aux, w, u} of the last iterate.
#[allow(clippy::too_many_arguments)]
pub(super) fn run_paper(
    mission: &Mission,
    start: Trajectory,
    objective: PaperObjective,
    options: &PlanOptions,
    deadline: Deadline,
    solver: &mut SocpSolver,
    observer: &mut dyn Observer,
    state_out: Option<&mut Option<PaperState>>,
) -> Result<PlanResult, PlanError> {
    let mut state = PaperState::from_trajectory(mission, &start);
    let (traj, end) = paper_bcd(
        mission,
        &mut state,
        start,
        objective,
        options,
        Means {
            solver,
            observer,
            deadline,
        },
        0,
    )?;
    if let Some(out) = state_out {
        *out = Some(state);
    }
    Ok(finish(mission, traj, end))
}

/// The BCD loop of Algorithm 1 from `state` (whose positions are `start`'s), at the state's
/// altitudes (per slot when it has them, each iterate then evaluated at them); records are
/// numbered after `done` earlier iterations. Returns the last iterate's path and the loop's end.
pub(super) fn paper_bcd(
    mission: &Mission,
    state: &mut PaperState,
    start: Trajectory,
    objective: PaperObjective,
    options: &PlanOptions,
    means: Means<'_>,
    done: usize,
) -> Result<(Trajectory, LoopEnd), PlanError> {
    let Means {
        solver,
        observer,
        deadline,
    } = means;
    let mut p6_solver = SocpSolver::new(options.socp);
    let mut end = LoopEnd::starting(f64::NAN);
    let mut traj = start;
    for it in done + 1..=done + options.max_iterations {
        if deadline.passed() {
            end.termination = TerminationReason::TimeLimit;
            break;
        }
        let t0 = Instant::now();
        let p5 = state.solve_p5(mission, objective, solver);
        end.cone_programs += 1;
        let (own, ipm) = match p5 {
            Ok(v) => v,
            Err(e) => {
                if end.objective_history.is_empty() {
                    return Err(PlanError::Solver {
                        iteration: it,
                        error: e,
                    });
                }
                end.termination = TerminationReason::SubproblemFailed(e.to_string());
                break;
            }
        };
        let ipm6 = state.solve_p6(mission, &mut p6_solver);
        end.cone_programs += 1;
        traj = state.trajectory(&traj);
        let ev = match state.altitudes_m() {
            Some(z) => evaluate_with_altitudes(mission, &traj, z)
                .map_err(|e| PlanError::InvalidInit(format!("the altitude profile: {e}")))?,
            None => evaluate(mission, &traj),
        };
        let rec = record(it, own, &ev, ipm + ipm6, t0.elapsed().as_secs_f64(), true);
        observer.on_iteration(&rec);
        end.records.push(rec);
        let prev = end.objective_history.last().copied();
        end.accept(own, ev.energy_j);
        if prev.is_some_and(|prev| relative_change(prev, own) < options.tolerance) {
            end.termination = TerminationReason::Converged;
            break;
        }
    }
    Ok((traj, end))
}
