//! The starts phase I tries before the planner gives up, and what it reports when none can be
//! made feasible: [`PlanError::NotFound`] with the best plan it found, never a refusal (a stall
//! of a local method proves nothing about the mission).
//!
//! In order: the start the scheme chose (a given `--init` path, or the coarse levels' track);
//! the built-in start in place of a given path phase I cannot repair
//! ([`PlanOptions::replace_unrepairable_init`]; without it a given path is the only start); the
//! guidance law's track; and, for a strict general plan of the `exact` scheme, the best effort's
//! plan, which keeps every constraint but the resolution hard and often resolves every slot too.

use std::sync::atomic::AtomicBool;

use crate::evaluate::{evaluate, ResolutionMode};
use crate::init::guidance_start_with;
use crate::schemes::exact::{ExactObjective, ExactTuning};
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

use super::iterate::{finish, Made, Means};
use super::options::Deadline;
use super::phase_one::{make_feasible, total_violation, PhaseOneFailure};
use super::progress::LoopEnd;
use super::{Observer, PlanError, PlanOptions, TerminationReason};

/// What the search for a feasible start needs.
pub(super) struct StartSearch<'a> {
    pub mission: &'a Mission,
    pub options: &'a PlanOptions,
    pub objective: ExactObjective,
    pub base: &'a ExactTuning,
    /// The `exact` scheme's phase-I rules ([`make_feasible`]).
    pub exact_rules: bool,
    pub deadline: Deadline<'a>,
    pub stop: Option<&'a AtomicBool>,
    /// Whether the best effort's plan may be tried (not inside a best effort's own basis).
    pub best_effort_start: bool,
}

/// A start tried after the first ([`StartSearch::run`]).
#[derive(Debug, Clone, Copy)]
enum OtherStart {
    /// The guidance law's track.
    Guidance,
    /// The best effort's plan (strict general plans of the `exact` scheme).
    BestEffort,
}

/// A feasible start: the track, phase I's iterations, and why a given path was replaced.
pub(super) struct FeasibleStart {
    pub trajectory: Trajectory,
    pub repair_iterations: usize,
    pub init_replaced: Option<String>,
    /// The true energy of the start phase I began from (the one it was given, or the built-in
    /// start that replaced it).
    pub start_energy_j: f64,
}

/// The least-violation iterate over every start tried.
#[derive(Default)]
struct Stalls {
    best: Option<(f64, Trajectory)>,
    first_error: Option<PlanError>,
    tried: usize,
}

impl<'a> StartSearch<'a> {
    /// Phase I from `start`, then from the other starts (module documentation) while it
    /// stalls. `built_in` makes the built-in start (only called when a given path is replaced).
    pub fn run(
        &self,
        start: Trajectory,
        built_in: impl Fn() -> Trajectory,
        solver: &mut SocpSolver,
        observer: &mut dyn Observer,
    ) -> Result<FeasibleStart, PlanError> {
        let mut stalls = Stalls::default();
        let start_energy_j = evaluate(self.mission, &start).energy_j;
        match self.repair(start, solver, observer, &mut stalls)? {
            Some((trajectory, repair_iterations)) => {
                return Ok(FeasibleStart {
                    trajectory,
                    repair_iterations,
                    init_replaced: None,
                    start_energy_j,
                })
            }
            None if self.options.init.is_some() && self.options.replace_unrepairable_init => {
                // a given path phase I cannot repair (far outside the speed limits, or so far from
                // the landmarks that the elastic program is numerically infeasible): plan from the
                // built-in start rather than fail, and say so
                let reason = stalls
                    .first_error
                    .as_ref()
                    .map_or_else(|| "phase I stalled".to_string(), ToString::to_string);
                tracing::warn!(
                    error = %reason,
                    "the given start cannot be repaired; planning from the built-in start"
                );
                let start = built_in();
                let start_energy_j = evaluate(self.mission, &start).energy_j;
                if let Some((trajectory, repair_iterations)) =
                    self.repair(start, solver, observer, &mut stalls)?
                {
                    return Ok(FeasibleStart {
                        trajectory,
                        repair_iterations,
                        init_replaced: Some(reason),
                        start_energy_j,
                    });
                }
            }
            // a given path and no fallback asked for: that path alone
            None if self.options.init.is_some() => return Err(self.not_found(stalls)),
            None => {}
        }
        for other in [OtherStart::Guidance, OtherStart::BestEffort] {
            let Some(start) = self.other_start(other, observer) else {
                continue;
            };
            tracing::debug!(start = ?other, "phase I stalled; trying another start");
            let start_energy_j = evaluate(self.mission, &start).energy_j;
            if let Some((trajectory, repair_iterations)) =
                self.repair(start, solver, observer, &mut stalls)?
            {
                tracing::debug!(start = ?other, "phase I made this start feasible");
                return Ok(FeasibleStart {
                    trajectory,
                    repair_iterations,
                    init_replaced: None,
                    start_energy_j,
                });
            }
        }
        Err(self.not_found(stalls))
    }

    /// Phase I from `start`: `Some` when it is made feasible; `None` when it stalls or its
    /// cone program fails (recorded in `stalls`); a time limit ends the search.
    fn repair(
        &self,
        start: Trajectory,
        solver: &mut SocpSolver,
        observer: &mut dyn Observer,
        stalls: &mut Stalls,
    ) -> Result<Option<(Trajectory, usize)>, PlanError> {
        stalls.tried += 1;
        let means = Means {
            solver,
            observer,
            deadline: self.deadline,
        };
        match make_feasible(
            self.mission,
            start,
            self.objective,
            self.base,
            self.exact_rules,
            means,
        ) {
            Ok(found) => Ok(Some(found)),
            Err(PhaseOneFailure { error, .. }) if matches!(error, PlanError::TimeLimit { .. }) => {
                Err(error)
            }
            Err(PhaseOneFailure { error, stalled }) => {
                if let Some(t) = stalled {
                    let ev = evaluate(self.mission, &t);
                    let v = total_violation(
                        self.mission,
                        &ev,
                        (self.base.resolution, self.base.dynamics),
                        false,
                    );
                    if stalls.best.as_ref().is_none_or(|(b, _)| v < *b) {
                        stalls.best = Some((v, t));
                    }
                }
                stalls.first_error.get_or_insert(error);
                Ok(None)
            }
        }
    }

    /// The start `other`, made when it is tried; `None` where it does not apply.
    fn other_start(&self, other: OtherStart, observer: &mut dyn Observer) -> Option<Trajectory> {
        match other {
            OtherStart::Guidance => Some(guidance_start_with(
                self.mission,
                self.base.resolution,
                self.base.dynamics,
            )),
            OtherStart::BestEffort => {
                let strict_general = self.options.scheme.spec().own_rules
                    && self.options.resolution == ResolutionMode::General
                    && self.options.strict_resolution;
                if !strict_general || !self.best_effort_start || self.deadline.passed() {
                    return None;
                }
                let options = PlanOptions {
                    strict_resolution: false,
                    init: None,
                    ..self.options.clone()
                };
                super::best_effort::plan_best_effort(self.mission, &options, observer, self.stop)
                    .map_err(|e| tracing::debug!(error = %e, "no best effort to start from"))
                    .ok()
                    .map(|plan| plan.trajectory)
            }
        }
    }

    /// [`PlanError::NotFound`] with the least-violation iterate as its plan.
    fn not_found(&self, stalls: Stalls) -> PlanError {
        let Stalls {
            best,
            first_error,
            tried,
        } = stalls;
        let Some((_, trajectory)) = best else {
            return first_error.unwrap_or_else(|| {
                PlanError::NotFound(Box::new(super::error::NotFound {
                    slot: 1,
                    t_s: self.mission.params().slot_s,
                    reason: "phase I made no start feasible".into(),
                    starts: tried,
                    best: None,
                }))
            });
        };
        let ev = evaluate(self.mission, &trajectory);
        let mut error = super::phase_one::stalled_error(
            self.mission,
            &ev,
            (self.base.resolution, self.base.dynamics),
        );
        if let PlanError::NotFound(nf) = &mut error {
            let mut end = LoopEnd::starting(ev.energy_j);
            end.termination = TerminationReason::NoProgress;
            let made = Made {
                scheme: self.options.scheme,
                resolution: self.base.resolution,
                dynamics: self.base.dynamics,
                start_energy_j: ev.energy_j,
                repair_iterations: 0,
                init_replaced: None,
                best_effort: None,
                programs_before: 0,
            };
            nf.starts = tried;
            nf.best = Some(finish(self.mission, trajectory, end, made));
        }
        error
    }
}
