//! Phase I (elastic SCA): repairing an infeasible start.

use crate::evaluate::{evaluate, Dynamics, Evaluation, ResolutionMode, ACCEL_TOL_REL};
use crate::geometry::{distance, Point2, Vector2};
use crate::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use crate::{Mission, Trajectory};

use super::error::NotFound;
use super::iterate::{extrapolate, Means};
use super::PlanError;

/// Per-slot violation used by the elastic phase: the largest of the sensing excess (m), the
/// azimuth speed shortfall (m/s) and the range keep-out shortfall (m) of each landmark slot,
/// summed over slots (the same quantities that the subproblem's slack σ_t bounds). With
/// `whole_slot`, the sensing excess is the larger of the slot-end centre's and the slot-start
/// centre's (straight flight at the slot's heading), as [`ExactTuning::whole_slot_sensing`] imposes.
///
/// Under [`Dynamics::Vehicle`] it adds, over all slots, the velocity change beyond the limit,
/// ([`crate::evaluate::SlotEval::accel_mps2`] − a_max)⁺ δ in m/s (what the acceleration slack
/// τ_t/δ bounds, twice that in the first slot).
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
/// of repeating the same subproblem. The comparison schemes keep the earlier rules, so that
/// their starts, and the results compared with the paper, do not change.
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
    let mut current = start;
    let mut ev = evaluate(mission, &current);
    if ev.is_feasible_with(mode, base.dynamics) {
        return Ok((current, 0));
    }
    observer.on_phase("repair");
    let value = |ev: &Evaluation| objective.true_value(ev);
    let mut weight = match objective {
        ExactObjective::Energy => 1000.0,
        ExactObjective::Distance => 100.0,
    };
    let mut tuning = ExactTuning {
        elastic_weight: Some(weight),
        ..*base
    };
    let slot_start = exact_rules && base.whole_slot_sensing;
    let violation_of =
        |ev: &Evaluation| total_violation(mission, ev, (mode, base.dynamics), slot_start);
    let mut merit = value(&ev) + weight * violation_of(&ev);
    let mut best_violation = violation_of(&ev);
    let mut stalls = 0;
    for it in 1..=100 {
        if deadline.passed() {
            return Err(PhaseOneFailure {
                error: PlanError::TimeLimit {
                    limit_s: deadline.limit_s,
                    iterations: it - 1,
                    sensing_violation_m: ev.violations.sensing_m,
                },
                stalled: Some(current),
            });
        }
        tuning.elastic_weight = Some(weight);
        let sub = ExactSubproblem::build(mission, &current, objective, &tuning);
        let sol = match solver.solve(&sub.builder) {
            Ok(sol) => sol,
            Err(source) if tuning.kappa_scale >= 1.0 => {
                return Err(PhaseOneFailure {
                    error: PlanError::Solver {
                        iteration: 0,
                        error: source,
                    },
                    stalled: None,
                })
            }
            Err(_) => {
                tuning.kappa_scale = 1.0;
                continue;
            }
        };
        let merit_of = |ev: &Evaluation| value(ev) + weight * violation_of(ev);
        let mut cand = sub.trajectory(&sol.x, &current);
        let mut cand_ev = evaluate(mission, &cand);
        let mut cand_merit = merit_of(&cand_ev);
        if cand_merit < merit {
            // over-relaxation along the step, as in the main loop
            for alpha in [2.0, 4.0] {
                let trial = extrapolate(&current, &cand, alpha);
                let ev = evaluate(mission, &trial);
                let m = merit_of(&ev);
                if m < cand_merit {
                    cand = trial;
                    cand_ev = ev;
                    cand_merit = m;
                } else {
                    break;
                }
            }
        }
        let violation = violation_of(&cand_ev);
        tracing::debug!(
            iteration = it,
            violation,
            merit = cand_merit,
            weight,
            kappa_scale = tuning.kappa_scale,
            "phase I"
        );
        if cand_merit <= merit * (1.0 + 1e-9) + 1e-9 {
            current = cand;
            ev = cand_ev;
            merit = cand_merit;
            if ev.is_feasible_with(mode, base.dynamics) {
                return Ok((current, it));
            }
            tuning.kappa_scale = (tuning.kappa_scale * 0.5).max(1.0 / 16.0);
            // a successful step relaxes the trust region again, as in the main loop
            tuning.trust_radius_m = tuning.trust_radius_m.map(|r| r * 4.0).filter(|r| *r < 50.0);
        } else if tuning.kappa_scale < 1.0 {
            // the optimistic centre model overreached: back to the proven bound
            tuning.kappa_scale = (tuning.kappa_scale * 4.0).min(1.0);
            continue;
        } else if exact_rules {
            // rejected at the proven bound: the same subproblem would give the same step, so
            // shorten it (trust region on the velocity change, as in the main loop)
            tuning.trust_radius_m = Some(tuning.trust_radius_m.map_or(2.0, |r| r * 0.5));
        }
        if violation < best_violation * 0.99 {
            best_violation = violation;
            stalls = 0;
        } else {
            stalls += 1;
            if stalls >= 8 {
                break;
            }
            if stalls % 3 == 0 && weight < 1e5 {
                // the penalty may not be exact yet: charge violations more
                weight *= 10.0;
                merit = value(&ev) + weight * violation_of(&ev);
            }
        }
    }
    let error = stalled_error(mission, &ev, (mode, base.dynamics));
    Err(PhaseOneFailure {
        error,
        stalled: Some(current),
    })
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
