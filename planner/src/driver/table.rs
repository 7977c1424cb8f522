//! The scheme table: the [`Rules`] by which the executor runs each scheme's step. A new scheme
//! is a [`Step`](super::executor::Step) in its own file and a row here.

use crate::schemes::exact::ExactTuning;

use super::executor::{Acceptance, CentreRule, FailureRule, Measure, Rules, StallRule, TrustRule};
use super::{PlanOptions, ALTERNATION_TOLERANCE, MAX_ALTERNATIONS};

/// Best effort: the loop stops once the true merit (energy + weight × deficit) fell by less than
/// [`BEST_EFFORT_STALL_REL`] over the last [`BEST_EFFORT_STALL_STEPS`] accepted steps: the last
/// steps of the slack SCA move slots whose widths are already near d_min (on the default 30 m
/// mission the merit falls by 88 % in the first 8 accepted steps, no window is unresolved from
/// the 9th, and the merit falls by 0.8 % over the 5 steps before the rule stops it at the 18th;
/// BENCHMARKS.md, "Best-effort resolution").
pub(super) const BEST_EFFORT_STALL_STEPS: usize = 5;
/// See [`BEST_EFFORT_STALL_STEPS`].
pub(super) const BEST_EFFORT_STALL_REL: f64 = 1e-2;

/// Phase I's iteration limit.
pub(super) const PHASE_ONE_ITERATIONS: usize = 100;

/// The exact-geometry SCA at a fixed altitude (`exact`, `baseline-exact`, the best effort and
/// its polish, the coarse levels): descent on the true merit, the optimistic centre model made
/// bolder after each accepted step (×0.8 down to [`PlanOptions::min_kappa_scale`]) and restored
/// (×2) before the trust region shortens a step; a best effort (cell slacks in `base`) also stops
/// when it stalls.
pub(super) fn exact(options: &PlanOptions, base: &ExactTuning) -> Rules {
    Rules {
        max_iterations: options.max_iterations,
        tolerance: options.tolerance,
        measure: Measure::Merit,
        acceptance: Acceptance::Descent,
        centre: Some(CentreRule {
            accept_factor: 0.8,
            floor: options.min_kappa_scale,
            reject_factor: 2.0,
        }),
        trust: TrustRule::Counted,
        failure: FailureRule::Shorten {
            error_before_progress: true,
        },
        stall: base.cell_slack_weight.map(|_| StallRule {
            steps: BEST_EFFORT_STALL_STEPS,
            rel: BEST_EFFORT_STALL_REL,
        }),
        records: true,
        numbered_before: 0,
    }
}

/// The exact-geometry SCA with the altitude of every slot a decision, continuing a plan of
/// `done` iterations: descent on the true merit at the proven centre model, the trust region on
/// rejections.
pub(super) fn free_altitude(options: &PlanOptions, done: usize) -> Rules {
    Rules {
        max_iterations: options.max_iterations,
        tolerance: options.tolerance,
        measure: Measure::Merit,
        acceptance: Acceptance::Descent,
        centre: None,
        trust: TrustRule::Counted,
        failure: FailureRule::Shorten {
            error_before_progress: false,
        },
        stall: None,
        records: true,
        numbered_before: done,
    }
}

/// Algorithm 1 (`paper`, `baseline`) as printed, after `done` iterations: every iterate
/// accepted, stopped when its own objective changes by less than the tolerance; a failed (p5)
/// ends it.
pub(super) fn paper(options: &PlanOptions, done: usize) -> Rules {
    Rules {
        max_iterations: options.max_iterations,
        tolerance: options.tolerance,
        measure: Measure::Objective,
        acceptance: Acceptance::Every,
        centre: None,
        trust: TrustRule::Off,
        failure: FailureRule::Stop,
        stall: None,
        records: true,
        numbered_before: done,
    }
}

/// Phase I (elastic SCA): descent on objective + penalty × violation until the start is
/// feasible (its step's goal) or it stalls (its step's rule); the centre model halves towards
/// 1/16 after accepted steps and is restored (×4) after rejected ones. `exact_rules` (the `exact`
/// scheme): a step rejected at the proven model shortens the next (trust region); the comparison
/// schemes keep the earlier rules, so that their starts do not change.
pub(super) fn phase_one(exact_rules: bool) -> Rules {
    Rules {
        max_iterations: PHASE_ONE_ITERATIONS,
        tolerance: 0.0,
        measure: Measure::Merit,
        acceptance: Acceptance::Descent,
        centre: Some(CentreRule {
            accept_factor: 0.5,
            floor: 1.0 / 16.0,
            reject_factor: 4.0,
        }),
        trust: if exact_rules {
            TrustRule::Uncounted
        } else {
            TrustRule::Off
        },
        failure: FailureRule::ProvenCentre,
        stall: None,
        records: false,
        numbered_before: 0,
    }
}

/// The paper's alternating three-dimensional extension (free altitude with `paper`): each
/// alternation accepted when it uses no more energy and is no less feasible, the first rejected
/// one ending it ([`super::alternating`]), converged when the energy changes by less than
/// [`ALTERNATION_TOLERANCE`] or the altitude step stays put.
pub(super) fn alternation() -> Rules {
    Rules {
        max_iterations: MAX_ALTERNATIONS,
        tolerance: ALTERNATION_TOLERANCE,
        measure: Measure::Merit,
        acceptance: Acceptance::Descent,
        centre: None,
        trust: TrustRule::Off,
        failure: FailureRule::Stop,
        stall: None,
        records: false,
        numbered_before: 0,
    }
}
