//! The one loop every scheme runs (sequential convex programming, in the manner of argmin's
//! executor): a scheme is a [`Step`] (what it iterates on, how it proposes a candidate from its
//! cone programs, how the exact geometry judges a candidate) and a row of [`Rules`] (how the loop
//! accepts, backs off and stops). The executor owns everything else: the deadline, the iteration
//! count, the trust region and the centre model's scale, acceptance on the exact geometry, the
//! records and histories, and a typed reason for stopping ([`Stop`]).
//!
//! One iteration:
//!
//! 1. stop if the deadline has passed ([`Stop::TimeLimit`]);
//! 2. [`Step::propose`] with the current [`Control`] (trust radius, centre-model scale); a failed
//!    cone program is handled by [`Rules::failure`];
//! 3. judge the candidate: [`Acceptance::Descent`] accepts it when it is admissible
//!    ([`Step::admissible`]) and its merit ([`Step::merit`]) does not increase;
//!    [`Acceptance::Every`] (the paper's block-coordinate descent) accepts every candidate;
//! 4. a rejected candidate first restores the proven centre model ([`Rules::centre`]), then
//!    shortens the step ([`Rules::trust`]); an accepted one relaxes both;
//! 5. stop when the measure ([`Rules::measure`]) changed by less than [`Rules::tolerance`], when
//!    a best effort stalls ([`Rules::stall`]), or when the scheme says so ([`Step::review`]:
//!    phase I's goal and stall).
//!
//! Adding a scheme is one file with its [`Step`] and one [`Rules`] row where the planner picks
//! schemes (`docs/architecture.md`, "Adding a scheme").

use std::time::Instant;

use crate::evaluate::Evaluation;
use crate::socp::SolveError;

use super::iterate::record;
use super::options::Deadline;
use super::progress::{relative_change, LoopEnd, TrustRegion};
use super::{Observer, PlanError, TerminationReason};

/// What the step controls of the loop set for the next cone program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Control {
    /// The trust radius on each slot's step, m (`None`: unbounded).
    pub trust_radius_m: Option<f64>,
    /// The scale of the optimistic centre model (1: the proven bound).
    pub kappa_scale: f64,
}

/// A candidate a step proposes: the next iterate, its exact evaluation, the scheme's own
/// objective at it (J, or m for distance schemes) and the interior-point iterations spent.
pub(super) struct Candidate<I> {
    pub iterate: I,
    pub evaluation: Evaluation,
    pub objective: f64,
    pub ipm_iterations: u32,
}

/// Why a step gave no candidate.
pub(super) enum Failure {
    /// A cone program failed (handled by [`Rules::failure`]).
    Solver(SolveError),
    /// The candidate cannot be judged (its evaluation failed): a rejection at the proven model.
    Unusable(String),
    /// The scheme is at its own fixed point: nothing left to propose ([`Stop::Converged`]).
    Settled,
    /// A failure no back-off mends that leaves the last accepted iterate standing
    /// ([`Stop::SubproblemFailed`] with this reason).
    Ended(String),
    /// Something no back-off mends; the run ends with this error.
    Fatal(PlanError),
}

/// What a scheme says after the loop accepted a step, or rejected one at the proven model.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Review {
    /// Go on.
    Continue,
    /// Go on; the merit changed (phase I raised its penalty): judge the current iterate again.
    Remerit,
    /// Stop here.
    Stop(Stop),
}

/// One scheme's iteration, as the executor runs it.
pub(super) trait Step {
    /// What the scheme iterates on (a track; a track and its altitudes).
    type Iterate;

    /// The exact evaluation of `iterate` (the start's; candidates come evaluated).
    fn evaluate(&self, iterate: &Self::Iterate) -> Result<Evaluation, PlanError>;

    /// Solves the scheme's cone program(s) at `current` under `control`.
    fn propose(
        &mut self,
        current: &Self::Iterate,
        control: Control,
    ) -> Result<Candidate<Self::Iterate>, Failure>;

    /// The merit the loop accepts by (lower is better).
    fn merit(&self, evaluation: &Evaluation) -> f64;

    /// Whether an evaluated candidate meets what the scheme keeps hard (`current`: the
    /// evaluation of the iterate it would replace).
    fn admissible(&self, candidate: &Evaluation, current: &Evaluation) -> bool;

    /// A longer step along `current` → `candidate`, where it is better (over-relaxation);
    /// `value` is the current merit. Default: the candidate as it is.
    fn lengthen(
        &self,
        _current: &Self::Iterate,
        _value: f64,
        candidate: Candidate<Self::Iterate>,
    ) -> Candidate<Self::Iterate> {
        candidate
    }

    /// The scheme's own word after an accepted step (`accepted`, `candidate` is then the
    /// current iterate) or a step rejected at the proven model. Default: go on.
    fn review(
        &mut self,
        _accepted: bool,
        _candidate: &Evaluation,
        _current: &Evaluation,
    ) -> Review {
        Review::Continue
    }

    /// Cone programs solved so far.
    fn cone_programs(&self) -> usize;
}

/// How the loop accepts a candidate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Acceptance {
    /// Admissible and no increase of the merit (relative 1e-9, absolute 1e-9).
    Descent,
    /// Every candidate (block-coordinate descent as printed).
    Every,
}

/// What the convergence test measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Measure {
    /// The merit of the accepted iterates.
    Merit,
    /// The scheme's own objective of consecutive accepted iterates.
    Objective,
}

/// The centre model's scale: an accepted step makes it bolder, a rejected one falls back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CentreRule {
    /// Multiplies the scale after an accepted step…
    pub accept_factor: f64,
    /// …down to this.
    pub floor: f64,
    /// Multiplies it (up to 1) after a step rejected while it was below 1; the same program is
    /// then solved again before the trust region shortens the step.
    pub reject_factor: f64,
}

/// The trust region's rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum TrustRule {
    /// No trust region (the radius stays as it starts).
    Off,
    /// A rejection halves the radius; more than `MAX_REJECTS` in a row stop the loop
    /// ([`Stop::NoProgress`]).
    Counted,
    /// A rejection halves the radius and never stops the loop (phase I, which stops on its own
    /// stall rule).
    Uncounted,
}

/// What a failed cone program does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum FailureRule {
    /// Counts as a rejection of the trust region. With `error_before_progress`, the loop's
    /// error is the solver's when the trust region gives up before any step was accepted,
    /// within its first `MAX_REJECTS` + 1 iterations.
    Shorten { error_before_progress: bool },
    /// The proven centre model is restored and the program solved again; a failure at the
    /// proven model is the loop's error (iteration 0: the start could not be worked on).
    ProvenCentre,
    /// Stops the loop ([`Stop::SubproblemFailed`]), or is its error before any accepted step.
    Stop,
}

/// The stall rule of a best effort: stop once the merit fell by less than `rel` (relative) over
/// the last `steps` accepted steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct StallRule {
    pub steps: usize,
    pub rel: f64,
}

/// One scheme's row: how the executor runs its [`Step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Rules {
    /// Largest number of iterations.
    pub max_iterations: usize,
    /// The convergence tolerance on [`Rules::measure`] (relative; 0: never).
    pub tolerance: f64,
    pub measure: Measure,
    pub acceptance: Acceptance,
    pub centre: Option<CentreRule>,
    pub trust: TrustRule,
    pub failure: FailureRule,
    pub stall: Option<StallRule>,
    /// Whether the loop keeps iteration records (and tells the observer).
    pub records: bool,
    /// Iterations already numbered before this loop (records continue after them).
    pub numbered_before: usize,
}

/// Why the executor stopped.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Stop {
    /// The measure changed by less than the tolerance (or a best effort stalled).
    Converged,
    /// [`Rules::max_iterations`] ran.
    MaxIterations,
    /// A cone program failed after the back-off.
    SubproblemFailed(String),
    /// Steps kept being rejected.
    NoProgress,
    /// The deadline passed (or the stop flag was set).
    TimeLimit,
    /// The scheme reached its goal ([`Step::review`]: phase I's feasible start).
    Goal,
    /// The scheme stalled by its own rule ([`Step::review`]).
    Stalled,
}

impl Stop {
    /// The plan's termination reason (a goal reached is convergence, a scheme's stall no
    /// progress).
    pub fn termination(&self) -> TerminationReason {
        match self {
            Stop::Converged | Stop::Goal => TerminationReason::Converged,
            Stop::MaxIterations => TerminationReason::MaxIterations,
            Stop::SubproblemFailed(e) => TerminationReason::SubproblemFailed(e.clone()),
            Stop::NoProgress | Stop::Stalled => TerminationReason::NoProgress,
            Stop::TimeLimit => TerminationReason::TimeLimit,
        }
    }
}

/// What a run of the executor leaves: the last accepted iterate and its evaluation, why it
/// stopped, the last iteration's number, and the records and histories.
pub(super) struct Outcome<I> {
    pub iterate: I,
    pub evaluation: Evaluation,
    pub stop: Stop,
    pub last_iteration: usize,
    pub end: LoopEnd,
}

/// The executor's state between iterations.
struct Run<I> {
    current: I,
    evaluation: Evaluation,
    value: f64,
    control: Control,
    trust: TrustRegion,
    /// The merits of the accepted iterates, the start's first.
    merits: Vec<f64>,
    end: LoopEnd,
}

impl<I> Run<I> {
    /// Whether no step has been accepted in this run.
    fn before_progress(&self) -> bool {
        self.merits.len() == 1
    }
}

/// Runs `step` from `start` by `rules`, the trust radius and centre scale starting at
/// `control`, reporting to `observer` until `deadline`. `end` holds what an earlier loop left
/// (its histories and records continue; [`LoopEnd::starting`] for a fresh plan).
pub(super) fn execute<S: Step>(
    step: &mut S,
    start: S::Iterate,
    rules: &Rules,
    control: Control,
    end: LoopEnd,
    observer: &mut dyn Observer,
    deadline: Deadline<'_>,
) -> Result<Outcome<S::Iterate>, PlanError> {
    let evaluation = step.evaluate(&start)?;
    let value = step.merit(&evaluation);
    let programs_before = end.cone_programs;
    let mut run = Run {
        current: start,
        evaluation,
        value,
        control,
        trust: TrustRegion::default(),
        merits: vec![value],
        end,
    };
    let first = rules.numbered_before + 1;
    let mut stop = Stop::MaxIterations;
    let mut last_iteration = rules.numbered_before;
    for it in first..first + rules.max_iterations {
        if deadline.passed() {
            stop = Stop::TimeLimit;
            break;
        }
        last_iteration = it;
        let t0 = Instant::now();
        let proposal = step.propose(&run.current, run.control);
        run.end.cone_programs = programs_before + step.cone_programs();
        let outcome = match proposal {
            Ok(candidate) => judge(step, rules, &mut run, candidate, it, t0, observer),
            Err(Failure::Fatal(error)) => return Err(error),
            Err(Failure::Solver(error)) => fail(rules, &mut run, error, it, t0)?,
            Err(Failure::Settled) => Some(Stop::Converged),
            Err(Failure::Ended(reason)) => Some(Stop::SubproblemFailed(reason)),
            Err(Failure::Unusable(reason)) => {
                tracing::debug!(iteration = it, %reason, "candidate unusable");
                push_failed(rules, &mut run, it, t0);
                reject_at_proven(step, rules, &mut run, None)
            }
        };
        if let Some(s) = outcome {
            stop = s;
            break;
        }
    }
    run.end.termination = stop.termination();
    Ok(Outcome {
        iterate: run.current,
        evaluation: run.evaluation,
        stop,
        last_iteration,
        end: run.end,
    })
}

/// The record of iteration `it` that gave no candidate (when the rules keep records; the
/// observer is not told).
fn push_failed<I>(rules: &Rules, run: &mut Run<I>, it: usize, t0: Instant) {
    if rules.records {
        let rec = record(
            it,
            f64::NAN,
            &run.evaluation,
            0,
            t0.elapsed().as_secs_f64(),
            false,
        );
        run.end.records.push(rec);
    }
}

/// A failed cone program at iteration `it` ([`Rules::failure`]): `Some` when the loop stops,
/// an error when it ends the run.
fn fail<I>(
    rules: &Rules,
    run: &mut Run<I>,
    error: SolveError,
    it: usize,
    t0: Instant,
) -> Result<Option<Stop>, PlanError> {
    let before_progress = run.before_progress();
    match rules.failure {
        FailureRule::ProvenCentre if run.control.kappa_scale < 1.0 => {
            run.control.kappa_scale = 1.0;
            Ok(None)
        }
        FailureRule::ProvenCentre => Err(PlanError::Solver {
            iteration: 0,
            error,
        }),
        FailureRule::Stop if before_progress => Err(PlanError::Solver {
            iteration: it,
            error,
        }),
        FailureRule::Stop => Ok(Some(Stop::SubproblemFailed(error.to_string()))),
        FailureRule::Shorten {
            error_before_progress,
        } => {
            if it == rules.numbered_before + 1 && run.control.trust_radius_m.is_none() {
                tracing::debug!(%error, "first subproblem failed; retrying with a trust region");
            }
            let gives_up = run.trust.reject(&mut run.control.trust_radius_m);
            push_failed(rules, run, it, t0);
            if !gives_up {
                return Ok(None);
            }
            let early = it - rules.numbered_before <= super::progress::MAX_REJECTS + 1;
            if error_before_progress && before_progress && early {
                return Err(PlanError::Solver {
                    iteration: it,
                    error,
                });
            }
            Ok(Some(Stop::SubproblemFailed(error.to_string())))
        }
    }
}

/// Judges `candidate` at iteration `it`: accepts or rejects it, updates the controls and says
/// whether the loop stops.
fn judge<S: Step>(
    step: &mut S,
    rules: &Rules,
    run: &mut Run<S::Iterate>,
    candidate: Candidate<S::Iterate>,
    it: usize,
    t0: Instant,
    observer: &mut dyn Observer,
) -> Option<Stop> {
    let candidate = step.lengthen(&run.current, run.value, candidate);
    let value = step.merit(&candidate.evaluation);
    let ok = match rules.acceptance {
        Acceptance::Every => true,
        Acceptance::Descent => {
            step.admissible(&candidate.evaluation, &run.evaluation)
                && value <= run.value * (1.0 + 1e-9) + 1e-9
        }
    };
    if rules.records {
        let rec = record(
            it,
            candidate.objective,
            &candidate.evaluation,
            candidate.ipm_iterations,
            t0.elapsed().as_secs_f64(),
            ok,
        );
        observer.on_iteration(&rec);
        run.end.records.push(rec);
    }
    if !ok {
        return reject(step, rules, run, &candidate.evaluation, it, value);
    }
    let previous_objective = run.end.objective_history.last().copied();
    let rel = relative_change(run.value, value);
    run.current = candidate.iterate;
    run.evaluation = candidate.evaluation;
    run.value = value;
    run.end.accept(candidate.objective, run.evaluation.energy_j);
    run.merits.push(value);
    tracing::debug!(
        iteration = it,
        objective = candidate.objective,
        true_value = value,
        rel,
        "accepted"
    );
    let converged = match rules.measure {
        Measure::Merit => rel < rules.tolerance,
        Measure::Objective => previous_objective
            .is_some_and(|prev| relative_change(prev, candidate.objective) < rules.tolerance),
    };
    if converged || stalled(rules.stall, &run.merits) {
        return Some(Stop::Converged);
    }
    if let Some(centre) = rules.centre {
        run.control.kappa_scale =
            (run.control.kappa_scale * centre.accept_factor).max(centre.floor);
    }
    if rules.trust != TrustRule::Off {
        run.trust.accept(&mut run.control.trust_radius_m);
    }
    let verdict = step.review(true, &run.evaluation, &run.evaluation);
    settle(step, run, verdict)
}

/// A rejected candidate (evaluated `evaluation`, merit `value`) at iteration `it`.
fn reject<S: Step>(
    step: &mut S,
    rules: &Rules,
    run: &mut Run<S::Iterate>,
    evaluation: &Evaluation,
    it: usize,
    value: f64,
) -> Option<Stop> {
    if let Some(centre) = rules.centre {
        if run.control.kappa_scale < 1.0 {
            // the optimistic model overreached: fall back towards the proven bound, re-solve
            run.control.kappa_scale = (run.control.kappa_scale * centre.reject_factor).min(1.0);
            return None;
        }
    }
    tracing::debug!(
        iteration = it,
        admissible = step.admissible(evaluation, &run.evaluation),
        value,
        previous = run.value,
        "step rejected"
    );
    reject_at_proven(step, rules, run, Some(evaluation))
}

/// A step rejected at the proven model (`candidate`: its evaluation, when it has one): the
/// trust region shortens the next step, and the scheme reviews.
fn reject_at_proven<S: Step>(
    step: &mut S,
    rules: &Rules,
    run: &mut Run<S::Iterate>,
    candidate: Option<&Evaluation>,
) -> Option<Stop> {
    match rules.trust {
        TrustRule::Off => {}
        TrustRule::Counted => {
            if run.trust.reject(&mut run.control.trust_radius_m) {
                return Some(Stop::NoProgress);
            }
        }
        TrustRule::Uncounted => {
            run.trust.reject(&mut run.control.trust_radius_m);
        }
    }
    let verdict = step.review(false, candidate.unwrap_or(&run.evaluation), &run.evaluation);
    settle(step, run, verdict)
}

/// What the scheme's review ([`Step::review`]) says the loop does next.
fn settle<S: Step>(step: &S, run: &mut Run<S::Iterate>, verdict: Review) -> Option<Stop> {
    match verdict {
        Review::Continue => None,
        Review::Remerit => {
            run.value = step.merit(&run.evaluation);
            None
        }
        Review::Stop(stop) => Some(stop),
    }
}

/// Whether the accepted merits `merits` (the start's first) have stalled by `rule`.
fn stalled(rule: Option<StallRule>, merits: &[f64]) -> bool {
    let Some(rule) = rule else {
        return false;
    };
    if merits.len() <= rule.steps {
        return false;
    }
    let last = merits[merits.len() - 1];
    let before = merits[merits.len() - 1 - rule.steps];
    (before - last) < rule.rel * before.abs()
}

#[cfg(test)]
mod tests;
