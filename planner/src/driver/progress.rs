//! The bookkeeping the planner's loops share: the trust region that a rejected step tightens and
//! an accepted one relaxes, the relative change that stops a loop, and what a loop adds to the
//! plan it continues (its histories, records and cone programs).

use crate::evaluate::Evaluation;
use crate::Trajectory;

use super::{IterationRecord, PlanResult, Scheme, TerminationReason};

/// Rejected steps in a row (each halving the trust radius) after which an exact loop stops.
pub(super) const MAX_REJECTS: usize = 8;

/// The trust radius a first rejection sets, m.
const FIRST_RADIUS_M: f64 = 2.0;

/// An accepted step multiplies the radius by this, and drops it once it reaches
/// [`RADIUS_DROPPED_M`].
const RADIUS_GROWTH: f64 = 4.0;

/// See [`RADIUS_GROWTH`], m.
const RADIUS_DROPPED_M: f64 = 50.0;

/// The trust region of the exact-geometry loops: the radius (none: unbounded steps) and the
/// rejections in a row.
#[derive(Debug, Default)]
pub(super) struct TrustRegion {
    rejects: usize,
}

impl TrustRegion {
    /// A rejected step (or a failed subproblem): the radius halves ([`FIRST_RADIUS_M`] when
    /// there was none). Whether the loop should stop: more than [`MAX_REJECTS`] in a row.
    pub fn reject(&mut self, radius_m: &mut Option<f64>) -> bool {
        self.rejects += 1;
        *radius_m = Some(radius_m.map_or(FIRST_RADIUS_M, |r| r * 0.5));
        self.rejects > MAX_REJECTS
    }

    /// An accepted step: the count of rejections restarts and the radius grows (see
    /// [`RADIUS_GROWTH`]).
    pub fn accept(&mut self, radius_m: &mut Option<f64>) {
        self.rejects = 0;
        *radius_m = radius_m
            .map(|r| r * RADIUS_GROWTH)
            .filter(|r| *r < RADIUS_DROPPED_M);
    }
}

/// The relative change from `previous` to `next` (the loops' stopping measure).
pub(super) fn relative_change(previous: f64, next: f64) -> f64 {
    (previous - next).abs() / previous.abs().max(1e-12)
}

/// What an iteration loop leaves: its last own objective, its histories, why it stopped, the
/// cone programs it solved.
pub(super) struct LoopEnd {
    pub objective: f64,
    pub objective_history: Vec<f64>,
    pub true_energy_history: Vec<f64>,
    pub records: Vec<IterationRecord>,
    pub termination: TerminationReason,
    pub cone_programs: usize,
}

impl LoopEnd {
    /// A loop that has accepted nothing yet, its objective `objective`.
    pub fn starting(objective: f64) -> Self {
        Self {
            objective,
            objective_history: Vec::new(),
            true_energy_history: Vec::new(),
            records: Vec::new(),
            termination: TerminationReason::MaxIterations,
            cone_programs: 0,
        }
    }

    /// A loop that continues `plan`: its objective, histories, records and cone programs, to
    /// which the loop's own are added.
    pub fn continuing(plan: &PlanResult) -> Self {
        Self {
            objective: plan.objective,
            objective_history: plan.objective_history.clone(),
            true_energy_history: plan.true_energy_history.clone(),
            records: plan.records.clone(),
            termination: TerminationReason::MaxIterations,
            cone_programs: plan.cone_programs,
        }
    }

    /// An accepted iterate: its own objective `objective` and true energy `energy_j`.
    pub fn accept(&mut self, objective: f64, energy_j: f64) {
        self.objective = objective;
        self.objective_history.push(objective);
        self.true_energy_history.push(energy_j);
    }

    /// The plan `fixed` (planned at one altitude) continued by this loop to `trajectory` flown at
    /// `altitudes_m`, evaluated `evaluation` there, by `scheme`.
    pub fn into_free_plan(
        self,
        fixed: PlanResult,
        scheme: Scheme,
        trajectory: Trajectory,
        altitudes_m: Vec<f64>,
        evaluation: Evaluation,
    ) -> PlanResult {
        PlanResult {
            scheme,
            trajectory,
            evaluation,
            objective: self.objective,
            objective_history: self.objective_history,
            true_energy_history: self.true_energy_history,
            iterations: self.records.len(),
            records: self.records,
            converged: self.termination == TerminationReason::Converged,
            termination: self.termination,
            cone_programs: self.cone_programs,
            altitudes_m: Some(altitudes_m),
            bound: None,
            ..fixed
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_radius_halves_on_rejection_and_grows_on_acceptance_until_dropped() {
        let mut tr = TrustRegion::default();
        let mut r = None;
        assert!(!tr.reject(&mut r));
        assert_eq!(r, Some(2.0));
        assert!(!tr.reject(&mut r));
        assert_eq!(r, Some(1.0));
        tr.accept(&mut r);
        assert_eq!(r, Some(4.0));
        tr.accept(&mut r);
        assert_eq!(r, Some(16.0));
        tr.accept(&mut r);
        assert_eq!(r, None, "64 m is dropped");
        tr.accept(&mut r);
        assert_eq!(r, None, "no radius stays none");
    }

    #[test]
    fn the_loop_stops_after_more_than_max_rejects_in_a_row() {
        let mut tr = TrustRegion::default();
        let mut r = None;
        for _ in 0..MAX_REJECTS {
            assert!(!tr.reject(&mut r));
        }
        tr.accept(&mut r);
        for _ in 0..MAX_REJECTS {
            assert!(!tr.reject(&mut r), "an acceptance restarts the count");
        }
        assert!(tr.reject(&mut r));
    }

    #[test]
    fn relative_change_is_guarded_at_zero() {
        assert_eq!(relative_change(100.0, 99.0), 0.01);
        assert_eq!(relative_change(-100.0, -99.0), 0.01);
        assert_eq!(relative_change(0.0, 1e-12), 1.0);
    }
}
