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

use crate::evaluate::{evaluate, Dynamics, Evaluation, ResolutionMode};
use crate::init::guidance_start_with;
use crate::schemes::exact::{ExactObjective, ExactTuning};
use crate::shortfall::{total_deficit_m, ResolutionShortfall};
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

use super::coarse::coarse_start;
use super::iterate::{finish, run_exact, Made, Means};
use super::options::Deadline;
use super::{BestEffort, Observer, PlanError, PlanOptions, PlanResult};

/// What every best-effort plan of a mission starts from (each computed once; the trade-off
/// reuses them): the least-energy plan and the best effort solved on the coarse levels.
#[derive(Debug, Clone)]
pub struct BestEffortBasis {
    /// The least-energy plan (`paper` resolution).
    pub least_energy: PlanResult,
    /// The best effort solved on the coarse levels (20, 10, 5 and 2.5 s slots, like the
    /// least-energy plan's start) and interpolated to the mission's slots, kept only when that
    /// track meets every constraint on them, the resolution in every slot included: then it
    /// starts the best effort. The best effort from the least-energy plan is a local method (on
    /// the far-start mission it stops at 4 unresolved slots), and from the guidance law the
    /// coarse levels find the track that resolves every slot there; elsewhere the least-energy
    /// plan is the better start (default 30 m mission: 0 of 30 windows unresolved from it, 1
    /// from a coarse track that leaves some slots unresolved). A mission too short for the
    /// coarse levels gets the strict general plan here instead, when one exists (cheap on so
    /// few slots).
    pub coarse: Option<Trajectory>,
}

/// The strict general plan's track, `None` when it is refused or fails (it is only a start).
fn strict_plan(
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Option<Trajectory> {
    let strict_options = PlanOptions {
        resolution: ResolutionMode::General,
        strict_resolution: true,
        max_extra_energy_pct: None,
        init: None,
        ..options.clone()
    };
    // not from the best effort's plan: this is the best effort's own basis
    let started = Instant::now();
    let run = super::FixedRun {
        paper_state: None,
        no_best_effort_start: true,
    };
    match super::plan_fixed(started, mission, &strict_options, observer, stop, run) {
        Ok(plan) => Some(plan.trajectory),
        Err(e) => {
            tracing::debug!(error = %e, "no strict general plan");
            None
        }
    }
}

impl BestEffortBasis {
    /// Plans the least-energy plan and, unless that one already meets the general resolution
    /// everywhere, the coarse best effort.
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
        let started = Instant::now();
        let least_energy = super::run_plan(
            mission,
            &PlanOptions {
                resolution: ResolutionMode::Paper,
                strict_resolution: false,
                max_extra_energy_pct: None,
                // a given start is the best effort's, not the basis's
                init: None,
                ..options.clone()
            },
            observer,
            stop,
        )?;
        let coarse = if least_energy
            .evaluation
            .is_feasible_with(ResolutionMode::General, options.dynamics)
            || !options.coarse
        {
            None
        } else {
            let coarse_options = PlanOptions {
                resolution: ResolutionMode::General,
                strict_resolution: false,
                init: None,
                ..options.clone()
            };
            let deadline = Deadline::after(started, options.time_limit_s, stop);
            coarse_start(
                mission,
                ExactObjective::Energy,
                true,
                &coarse_options,
                deadline,
            )
            .filter(|t| {
                evaluate(mission, t).is_feasible_with(ResolutionMode::Paper, options.dynamics)
            })
            .or_else(|| strict_plan(mission, options, observer, stop))
            .filter(|t| {
                evaluate(mission, t).is_feasible_with(ResolutionMode::General, options.dynamics)
            })
        };
        Ok(Self {
            least_energy,
            coarse,
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
    if let Some(given) = &options.init {
        super::check_given(mission, given)?;
    }
    let basis = BestEffortBasis::new_until(mission, options, observer, stop)?;
    let given = options.init.as_ref();
    let mut out = best_effort_until(mission, options, &basis, given, observer, stop)?;
    out.solve_seconds = started.elapsed().as_secs_f64();
    Ok(out)
}

/// The best-effort plan of `mission` from an already planned `basis`, under
/// `options.max_extra_energy_pct`, its iterations started from `start` (default: the basis's
/// coarse track where it has one within the cap, else the least-energy plan). A given start
/// must meet every constraint but the resolution, and the energy cap; one that does not is
/// replaced by the default start (noted in `init_replaced`) under
/// [`PlanOptions::replace_unrepairable_init`], else refused ([`PlanError::InvalidInit`]). Its
/// `solve_seconds` counts only this step.
///
/// When the least-energy plan resolves every slot it is the answer (unless the given start or the
/// guidance law's track is better on the merit). Otherwise the best effort
/// runs; when it resolves every slot, the strict general SCA continues from it with the cell
/// constraints hard, lowering the energy. The plan is never worse on the merit than any of the
/// starts it could have taken (the least-energy plan, the basis's coarse or strict track, the
/// given start, the guidance law's track; [`Starts`]): where one is, that start is the plan.
pub fn best_effort_from(
    mission: &Mission,
    options: &PlanOptions,
    basis: &BestEffortBasis,
    start: Option<&Trajectory>,
    observer: &mut dyn Observer,
) -> Result<PlanResult, PlanError> {
    // `run_plan` gives its plans their bound; this entry point gives its own
    let mut out = best_effort_until(mission, options, basis, start, observer, None)?;
    out.bound = Some(crate::bound::energy_bound(mission, options.dynamics)?);
    Ok(out)
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
    let general = ResolutionMode::General;
    let mut info = BestEffort {
        least_energy_j: least_j,
        least_energy_shortfall: ResolutionShortfall::new(mission, &basis.least_energy.evaluation),
        max_extra_energy_pct: options.max_extra_energy_pct,
        strict_refusal: None,
    };
    let weight = options.resolution_weight_j_per_m;
    let starts = Starts {
        mission,
        weight_j_per_m: weight,
        cap_j,
        dynamics: options.dynamics,
    };
    let (given, init_replaced) = match start.map(|t| (t, starts.inadmissible(t))) {
        None => (None, None),
        Some((t, None)) => (Some(t), None),
        Some((_, Some(why))) if options.replace_unrepairable_init => {
            tracing::info!(%why, "the given start cannot start a best effort; the default does");
            (None, Some(why))
        }
        Some((_, Some(why))) => return Err(PlanError::InvalidInit(why)),
    };
    let made = |info: BestEffort, programs_before: usize| Made {
        scheme: options.scheme,
        resolution: general,
        dynamics: options.dynamics,
        start_energy_j: least_j,
        repair_iterations: 0,
        init_replaced: init_replaced.clone(),
        best_effort: Some(info),
        programs_before,
    };
    let timed = |plan: PlanResult| PlanResult {
        solve_seconds: started.elapsed().as_secs_f64(),
        ..plan
    };
    let guidance = guidance_start_with(mission, general, options.dynamics);
    // the starts the loop does not come from, scored once (the admissible ones); the
    // least-energy plan is the answer when it resolves every slot, unless one of them is better
    // on the merit (a local optimum can be beaten by a given flight)
    let least_merit = starts.merit(&basis.least_energy.evaluation);
    let others: Vec<(f64, &Trajectory)> = [given, Some(&guidance)]
        .into_iter()
        .flatten()
        .filter_map(|t| starts.scored(t).map(|m| (m, t)))
        .collect();
    let other_better = others.iter().any(|(m, _)| *m < least_merit * (1.0 - 1e-9));
    if !other_better
        && basis
            .least_energy
            .evaluation
            .is_feasible_with(general, options.dynamics)
    {
        return Ok(timed(PlanResult {
            scheme: options.scheme,
            resolution: general,
            dynamics: options.dynamics,
            start_energy_j: least_j,
            best_effort: Some(info),
            ..basis.least_energy.clone()
        }));
    }
    observer.on_phase("best effort");
    let start = match given {
        Some(t) => t.clone(),
        None => basis
            .coarse
            .as_ref()
            .filter(|t| cap_j.is_none_or(|cap| evaluate(mission, t).energy_j <= cap))
            .cloned()
            .unwrap_or_else(|| basis.least_energy.trajectory.clone()),
    };
    let tuning = ExactTuning {
        resolution: general,
        cell_slack_weight: Some(weight),
        energy_cap_j: cap_j,
        dynamics: options.dynamics,
        ..ExactTuning::default()
    };
    let mut solver = SocpSolver::new(options.exact_socp);
    // the proven centre bound throughout: with the optimistic deficit model, an optimistic
    // centre model too only adds rejected steps (default 30 m mission: 24 cone programs against
    // 18, to the same 0 unresolved windows)
    let slack_options = PlanOptions {
        min_kappa_scale: 1.0,
        ..options.clone()
    };
    let (track, end) = run_exact(
        mission,
        start,
        ExactObjective::Energy,
        &tuning,
        &slack_options,
        Means {
            solver: &mut solver,
            observer: &mut *observer,
            deadline,
        },
    )?;
    let coarse = basis
        .coarse
        .as_ref()
        .and_then(|t| starts.scored(t).map(|m| (m, t)));
    let least = starts
        .admits(&basis.least_energy.evaluation)
        .then_some((least_merit, &basis.least_energy.trajectory));
    let candidates = least.into_iter().chain(coarse).chain(others);
    let track = starts.never_worse(track, candidates);
    if let Some(refusal) = strict_refusal(mission, &evaluate(mission, &track)) {
        info.strict_refusal = Some(refusal);
        return Ok(timed(finish(mission, track, end, made(info, 0))));
    }
    // every slot resolved: the least energy with the cell constraints hard, from here
    let strict = ExactTuning {
        cell_slack_weight: None,
        ..tuning
    };
    let programs = end.cone_programs;
    let (polished, end) = run_exact(
        mission,
        track,
        ExactObjective::Energy,
        &strict,
        options,
        Means {
            solver: &mut solver,
            observer,
            deadline,
        },
    )?;
    Ok(timed(finish(mission, polished, end, made(info, programs))))
}

/// The starts a best effort is measured against, and how: its merit (energy + weight ×
/// resolution deficit, [`crate::shortfall::total_deficit_m`]) on the exact geometry, where a
/// start is admissible when it meets every constraint but the resolution, and the energy cap.
struct Starts<'a> {
    mission: &'a Mission,
    weight_j_per_m: f64,
    cap_j: Option<f64>,
    dynamics: Dynamics,
}

impl Starts<'_> {
    /// The merit of `ev`.
    fn merit(&self, ev: &Evaluation) -> f64 {
        ev.energy_j + self.weight_j_per_m * total_deficit_m(self.mission, ev)
    }

    /// Whether `ev` could start a best effort: every constraint but the resolution, and the cap.
    fn admits(&self, ev: &Evaluation) -> bool {
        ev.is_feasible_with(ResolutionMode::Paper, self.dynamics)
            && self
                .cap_j
                .is_none_or(|cap| ev.energy_j <= cap * (1.0 + 1e-9))
    }

    /// The merit of `track` when it could start a best effort; `None` when it could not.
    fn scored(&self, track: &Trajectory) -> Option<f64> {
        let ev = evaluate(self.mission, track);
        self.admits(&ev).then(|| self.merit(&ev))
    }

    /// Why the given start `track` cannot start a best effort; `None` when it can.
    fn inadmissible(&self, track: &Trajectory) -> Option<String> {
        let ev = evaluate(self.mission, track);
        if self.admits(&ev) {
            return None;
        }
        if !ev.is_feasible_with(ResolutionMode::Paper, self.dynamics) {
            return Some(format!(
                "the given start does not meet every constraint but the resolution under the \
                 {} vehicle model: {:?}",
                self.dynamics.name(),
                ev.violations
            ));
        }
        Some(format!(
            "the given start uses {:.1} J, over the energy cap of {:.1} J",
            ev.energy_j,
            self.cap_j.unwrap_or(f64::NAN)
        ))
    }

    /// `end` (a best effort's last iterate), or the track of the scored admissible `starts`
    /// (merit, track) with the least merit where that is lower than the end's. The loop is
    /// monotone from the start it took, so only a start it did not take can be better; this
    /// makes the plan never worse than any.
    fn never_worse<'t>(
        &self,
        end: Trajectory,
        starts: impl Iterator<Item = (f64, &'t Trajectory)>,
    ) -> Trajectory {
        let end_merit = self.merit(&evaluate(self.mission, &end));
        match starts.min_by(|a, b| a.0.total_cmp(&b.0)) {
            Some((merit, t)) if merit < end_merit * (1.0 - 1e-9) => {
                tracing::info!(
                    start_merit = merit,
                    end_merit,
                    "a start the best effort did not take is better than its end: it is the plan"
                );
                t.clone()
            }
            _ => end,
        }
    }
}

/// Why a best effort evaluated as `ev` is not a strict general plan
/// ([`BestEffort::strict_refusal`]): the first landmark slot it leaves unresolved, `None` when it
/// resolves every one.
pub(super) fn strict_refusal(mission: &Mission, ev: &crate::Evaluation) -> Option<String> {
    ResolutionShortfall::new(mission, ev)
        .first_unresolved_slot
        .map(|slot| {
            format!(
                "the best effort leaves landmark slot {slot} (t = {:.1} s) with a cell wider \
                 than d_min",
                slot as f64 * mission.params().slot_s
            )
        })
}
