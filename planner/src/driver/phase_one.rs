//! Phase I (elastic SCA): repairing an infeasible start, as a step the executor runs.

use crate::evaluate::{evaluate, Dynamics, Evaluation, ResolutionMode, ACCEL_TOL_REL};
use crate::geometry::{distance, Point2, Vector2};
use crate::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use crate::{Mission, Trajectory};

use super::error::NotFound;
use super::executor::{execute, Candidate, Control, Failure, Review, Step, Stop};
use super::iterate::{over_relax, Means};
use super::progress::LoopEnd;
use super::table;
use super::PlanError;

/// Per-slot violation used by the elastic phase: the largest of the sensing excess (m), the
/// azimuth speed shortfall (m/s) and the range keep-out shortfall (m) of each landmark slot,
/// summed over slots (the same quantities that the subproblem's slack σ_t bounds). With
/// `whole_slot`, the sensing excess is the larger of the slot-end centre's and the slot-start
/// centre's (straight flight at the slot's heading), as [`ExactTuning::whole_slot_sensing`] imposes.
///
/// Under [`Dynamics::Vehicle`] it adds, over all slots, the velocity change beyond the limit,
/// ([`crate::evaluate::SlotEval::accel_mps2`] − a_max)⁺ δ in m/s (what the acceleration slack
/// τ_t/δ bounds, twice that in the first slot), and the acceleration change beyond a jerk limit
/// ([`crate::evaluate::jerk_excess_mps2`]).
pub(super) fn total_violation(
    mission: &Mission,
    ev: &Evaluation,
    (mode, dynamics): (ResolutionMode, Dynamics),
    whole_slot: bool,
) -> f64 {
    let p = mission.params();
    let accel_excess: f64 = match dynamics {
        Dynamics::Paper => 0.0,
        Dynamics::Vehicle => ev
            .slots
            .iter()
            .zip(1..)
            .map(|(s, t)| {
                (s.accel_mps2 - p.max_accel_mps2).max(0.0) * crate::evaluate::accel_window_s(p, t)
            })
            .sum(),
    };
    let v_min = p.min_speed_mps();
    let keepout = p.range_keepout_m();
    ev.slots
        .iter()
        .filter(|s| s.landmark_m.is_some())
        .map(|s| {
            let mut sens = s.centre_error_m.unwrap_or(0.0) - p.sensing_radius_m;
            if let (true, Some(g)) = (whole_slot, s.landmark_m) {
                // the centre at the start of the slot (straight flight, same heading)
                let start = Point2::from(s.centre_m) - Vector2::from(s.velocity_mps) * p.slot_s;
                sens = sens.max(distance(&start, &Point2::from(g)) - p.sensing_radius_m);
            }
            let speed = v_min - s.speed_mps;
            let bs = Point2::from(p.bs_m);
            let range = keepout.map_or(0.0, |k| k - distance(&Point2::from(s.centre_m), &bs));
            let width = match mode {
                ResolutionMode::General => s.worst_width_m - p.d_min_m,
                ResolutionMode::Paper => 0.0,
            };
            // a blind slot has an infinite width: count it as a large, finite violation
            sens.max(speed)
                .max(range)
                .max(width.min(10.0 * p.d_min_m))
                .max(0.0)
        })
        .sum::<f64>()
        + accel_excess
        + crate::evaluate::jerk_excess_mps2(p, ev, dynamics)
}

/// Phase I (elastic SCA): while `start` violates the exact constraints, minimise the objective
/// plus a penalty on the total violation (a merit function that decreases monotonically); stops
/// at the first iterate that is feasible on the exact geometry. Returns it and the iterations.
/// When it stalls instead, the error carries the last accepted (least-merit) iterate.
///
/// `exact_rules` (the `exact` scheme): the merit also counts the slot-start centre where the
/// subproblem imposes whole-slot sensing (as its slacks do; otherwise its steps, which trade
/// slot-start against slot-end violation, look uphill and phase I stalls: random-3 of Fig. 11),
/// and a step rejected at the proven centre bound shortens the next one (trust region) instead
/// of repeating the same subproblem ([`table::phase_one`]). The comparison schemes keep the
/// earlier rules, so that their starts, and the results compared with the paper, do not change.
pub(super) fn make_feasible(
    mission: &Mission,
    start: Trajectory,
    objective: ExactObjective,
    base: &ExactTuning,
    exact_rules: bool,
    means: Means<'_>,
) -> Result<(Trajectory, usize), PhaseOneFailure> {
    let Means {
        solver,
        observer,
        deadline,
    } = means;
    let mode = base.resolution;
    if evaluate(mission, &start).is_feasible_with(mode, base.dynamics) {
        return Ok((start, 0));
    }
    observer.on_phase("repair");
    let mut step = PhaseOneStep {
        mission,
        objective,
        base,
        solver,
        slot_start: exact_rules && base.whole_slot_sensing,
        weight: match objective {
            ExactObjective::Energy => 1000.0,
            ExactObjective::Distance => 100.0,
        },
        best_violation: f64::INFINITY,
        stalls: 0,
        programs: 0,
    };
    step.best_violation = step.violation(&evaluate(mission, &start));
    let out = execute(
        &mut step,
        start,
        &table::phase_one(exact_rules),
        Control::of(base),
        LoopEnd::starting(f64::NAN),
        observer,
        deadline,
    )
    .map_err(|error| PhaseOneFailure {
        error,
        stalled: None,
    })?;
    let error = match out.stop {
        Stop::Goal => return Ok((out.iterate, out.last_iteration)),
        Stop::TimeLimit => PlanError::TimeLimit {
            limit_s: deadline.limit_s,
            iterations: out.last_iteration,
            sensing_violation_m: out.evaluation.violations.sensing_m,
        },
        _ => stalled_error(mission, &out.evaluation, (mode, base.dynamics)),
    };
    Err(PhaseOneFailure {
        error,
        stalled: Some(out.iterate),
    })
}

/// One step of phase I: the elastic cone program (the subproblem with its violations as slacks,
/// charged `weight` each), judged by objective + `weight` × [`total_violation`].
struct PhaseOneStep<'a> {
    mission: &'a Mission,
    objective: ExactObjective,
    base: &'a ExactTuning,
    solver: &'a mut crate::socp::SocpSolver,
    /// Whether the violation counts the slot-start centre ([`total_violation`]'s `whole_slot`).
    slot_start: bool,
    /// The penalty on the violation.
    weight: f64,
    /// The least violation of a candidate so far, and the steps since it last fell by 1 %.
    best_violation: f64,
    stalls: usize,
    programs: usize,
}

/// Steps in a row without the violation falling by 1 % after which phase I stalls; every third
/// raises the penalty ×10 (up to 1e5) first.
const PHASE_ONE_STALLS: usize = 8;

impl PhaseOneStep<'_> {
    fn violation(&self, ev: &Evaluation) -> f64 {
        let rules = (self.base.resolution, self.base.dynamics);
        total_violation(self.mission, ev, rules, self.slot_start)
    }
}

impl Step for PhaseOneStep<'_> {
    type Iterate = Trajectory;

    fn evaluate(&self, iterate: &Trajectory) -> Result<Evaluation, PlanError> {
        Ok(evaluate(self.mission, iterate))
    }

    fn propose(
        &mut self,
        current: &Trajectory,
        control: Control,
    ) -> Result<Candidate<Trajectory>, Failure> {
        let tuning = ExactTuning {
            elastic_weight: Some(self.weight),
            ..control.applied_to(self.base)
        };
        let sub = ExactSubproblem::build(self.mission, current, self.objective, &tuning);
        self.programs += 1;
        let sol = self.solver.solve(&sub.builder).map_err(Failure::Solver)?;
        let iterate = sub.trajectory(&sol.x, current);
        Ok(Candidate {
            evaluation: evaluate(self.mission, &iterate),
            iterate,
            objective: sub.physical_objective(sol.objective),
            ipm_iterations: sol.iterations,
        })
    }

    fn merit(&self, ev: &Evaluation) -> f64 {
        self.objective.true_value(ev) + self.weight * self.violation(ev)
    }

    fn admissible(&self, _ev: &Evaluation, _current: &Evaluation) -> bool {
        true
    }

    /// Over-relaxation along the step, as in the main loop, by the merit alone.
    fn lengthen(
        &self,
        current: &Trajectory,
        value: f64,
        candidate: Candidate<Trajectory>,
    ) -> Candidate<Trajectory> {
        over_relax(self.mission, current, value, candidate, |ev| {
            Some(self.merit(ev))
        })
    }

    /// The goal (an accepted step that is feasible), and the stall: the candidate's violation
    /// must fall by 1 % every [`PHASE_ONE_STALLS`] steps; every third step that it does not, the
    /// penalty may not be exact yet and is raised.
    fn review(&mut self, accepted: bool, candidate: &Evaluation, current: &Evaluation) -> Review {
        if accepted && current.is_feasible_with(self.base.resolution, self.base.dynamics) {
            return Review::Stop(Stop::Goal);
        }
        let violation = self.violation(candidate);
        tracing::debug!(accepted, violation, weight = self.weight, "phase I");
        if violation < self.best_violation * 0.99 {
            self.best_violation = violation;
            self.stalls = 0;
            return Review::Continue;
        }
        self.stalls += 1;
        if self.stalls >= PHASE_ONE_STALLS {
            return Review::Stop(Stop::Stalled);
        }
        if self.stalls.is_multiple_of(3) && self.weight < 1e5 {
            self.weight *= 10.0;
            return Review::Remerit;
        }
        Review::Continue
    }

    fn cone_programs(&self) -> usize {
        self.programs
    }
}

/// What a phase I that stalled at `ev` reports ([`PlanError::NotFound`], its best plan filled in
/// by the driver): the first slot that is out of view, too slow, (under the general resolution)
/// wider than d_min or (under the vehicle dynamics) above the acceleration limit. A stall proves
/// nothing about the mission.
pub(super) fn stalled_error(
    mission: &Mission,
    ev: &Evaluation,
    (mode, dynamics): (ResolutionMode, Dynamics),
) -> PlanError {
    let p = mission.params();
    let vehicle = dynamics == Dynamics::Vehicle;
    let too_fast = |a: f64| vehicle && a > p.max_accel_mps2 * (1.0 + ACCEL_TOL_REL);
    let first = ev
        .slots
        .iter()
        .find(|s| {
            !s.in_view
                || too_fast(s.accel_mps2)
                || (vehicle && crate::evaluate::over_jerk_limit(p, s.jerk_mps3))
                || (s.landmark_m.is_some()
                    && (s.speed_mps < p.min_speed_mps() - 1e-4
                        || (mode == ResolutionMode::General && s.worst_width_m > p.d_min_m + 1e-4)))
        })
        .map(|s| s.t)
        .unwrap_or(1);
    let accel = if vehicle {
        let v0 = mission.start_velocity_mps();
        format!(
            ", an acceleration excess of {:.3} m/s² over max_accel_mps2 = {:.3} m/s² from \
             start_velocity_mps = ({:.2}, {:.2}) m/s",
            ev.violations.accel_mps2, p.max_accel_mps2, v0[0], v0[1]
        )
    } else {
        String::new()
    };
    PlanError::NotFound(Box::new(NotFound {
        slot: first,
        t_s: first as f64 * p.slot_s,
        reason: format!(
            "the best trajectory found ({} resolution, {} dynamics) has a sensing violation of \
             {:.2} m, a speed shortfall of {:.3} m/s{accel} and a worst cell width of d_min + \
             {:.2} m",
            mode.name(),
            dynamics.name(),
            ev.violations.sensing_m,
            ev.violations.min_speed_mps,
            ev.violations.worst_width_m
        ),
        starts: 1,
        best: None,
    }))
}

/// Why phase I gave no feasible start.
pub(super) struct PhaseOneFailure {
    pub(super) error: PlanError,
    /// Its last accepted (least-merit) iterate when it stalled (not after a solver failure).
    pub(super) stalled: Option<Trajectory>,
}

impl From<PhaseOneFailure> for PlanError {
    fn from(f: PhaseOneFailure) -> Self {
        f.error
    }
}
