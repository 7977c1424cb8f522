//! The planning driver: feasibility pre-check, start trajectory (with phase-I repair), the SCA /
//! BCD iterations of each scheme, the stopping rule and the observer.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use crate::altitude::AltitudeMode;
use crate::evaluate::{evaluate, ResolutionMode};
use crate::geometry::{distance, Point2};
use crate::init::{guidance_start_with, precheck_with};
use crate::schemes::exact::{ExactObjective, ExactTuning};
use crate::schemes::paper::PaperState;
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

mod alternating;
mod altitude;
mod best_effort;
mod coarse;
mod error;
mod executor;
mod iterate;
mod observer;
mod options;
mod phase_one;
mod progress;
mod result;
mod scheme;
mod starts;
mod table;

pub use alternating::{ALTERNATION_PHASE, ALTERNATION_TOLERANCE, MAX_ALTERNATIONS};
pub use best_effort::{best_effort_from, BestEffortBasis};
pub use error::{NotFound, PlanError};
pub use observer::{IterationRecord, NoObserver, Observer};
pub use options::{
    OptionConflict, OptionName, PlanOptions, DEFAULT_DYNAMICS, DEFAULT_RESOLUTION,
    DEFAULT_RESOLUTION_WEIGHT_J_PER_M,
};
pub use result::{BestEffort, PlanResult, TerminationReason};
pub use scheme::Scheme;

use coarse::{coarse_start, coarse_start_from, LevelStart};
use iterate::{finish, run_exact, run_paper, Made, Means};
use options::Deadline;
use scheme::{Family, FreeAltitude};
use starts::StartSearch;

/// Plans `mission` with `options`.
pub fn plan(mission: &Mission, options: &PlanOptions) -> Result<PlanResult, PlanError> {
    plan_with_observer(mission, options, &mut NoObserver)
}

/// Plans `mission` with `options`, reporting progress to `observer`.
pub fn plan_with_observer(
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
) -> Result<PlanResult, PlanError> {
    run_plan(mission, options, observer, None)
}

/// Plans `mission` like [`plan_with_observer`], and stops early once `stop` is set (from
/// another thread or a signal handler; a host language's interrupt, say). The flag is read
/// where the time limit is checked, before every cone program, and a stopped run ends as if
/// [`PlanOptions::time_limit_s`] had passed: with [`TerminationReason::TimeLimit`] and the last
/// accepted iterate, or with [`PlanError::TimeLimit`] while it is still repairing its start.
pub fn plan_with_stop(
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: &AtomicBool,
) -> Result<PlanResult, PlanError> {
    run_plan(mission, options, observer, Some(stop))
}

/// The body of [`plan_with_observer`] and [`plan_with_stop`]: [`run_planned`] on the mission
/// less its margins, judged on the mission ([`crate::margins::within`]).
fn run_plan(
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Result<PlanResult, PlanError> {
    crate::margins::within(mission, |planned| {
        run_planned(planned, options, observer, stop)
    })
}

/// [`run_plan`] on `mission` as given. `solve_seconds` is read here,
/// after the run's workspaces are freed (about 0.4 ms of the default mission's plan).
fn run_planned(
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Result<PlanResult, PlanError> {
    let started = Instant::now();
    options.validate()?;
    // the bound, or the proof that no trajectory meets the mission (a certified refusal)
    let bound = crate::bound::energy_bound(mission, options.dynamics)?;
    let free = mission.params().altitude == AltitudeMode::Free && options.altitude_profile;
    let mut out = match (free, options.scheme.spec().free_altitude) {
        (true, Some(FreeAltitude::Joint)) => {
            altitude::plan_free(started, mission, options, observer, stop)?
        }
        (true, Some(FreeAltitude::Alternating)) => {
            alternating::plan_free_paper(started, mission, options, observer, stop)?
        }
        _ => plan_fixed(
            started,
            mission,
            options,
            observer,
            stop,
            FixedRun::default(),
        )?,
    };
    out.bound = Some(bound);
    out.solve_seconds = started.elapsed().as_secs_f64();
    Ok(out)
}

/// Refuses a free-altitude mission on the fixed-altitude paths ([`PlanError::AltitudeConflict`]):
/// [`run_plan`] sends the free missions it plans (scheme `exact` with
/// [`PlanOptions::altitude_profile`]) elsewhere, so any that arrives here is one the caller or
/// the scheme does not plan per-slot altitudes for.
pub(crate) fn check_altitude(mission: &Mission, options: &PlanOptions) -> Result<(), PlanError> {
    match mission.params().altitude {
        AltitudeMode::Fixed => Ok(()),
        AltitudeMode::Free => Err(PlanError::AltitudeConflict {
            scheme: options.scheme,
        }),
    }
}

/// How a plan at the mission's fixed altitude ([`plan_fixed`]) is asked for, beyond its options.
#[derive(Default)]
pub(super) struct FixedRun<'a> {
    /// Where the paper's schemes leave the BCD state of their last iterate.
    pub paper_state: Option<&'a mut Option<PaperState>>,
    /// Whether a strict general plan whose phase I stalls may not start from the best effort's
    /// plan (set when the best effort itself asks for the strict plan).
    pub no_best_effort_start: bool,
}

/// The plan of `mission` at its fixed altitude, its clock started at `started`: the best effort
/// of the `exact` scheme, or the scheme's start (phase I) and iterations. [`run_plan`] gives it
/// its bound and wall time.
fn plan_fixed(
    started: Instant,
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
    run: FixedRun<'_>,
) -> Result<PlanResult, PlanError> {
    let FixedRun {
        mut paper_state,
        no_best_effort_start,
    } = run;
    let best_effort_start = !no_best_effort_start;
    options.validate()?;
    check_altitude(mission, options)?;
    let spec = options.scheme.spec();
    if spec.own_rules && options.resolution == ResolutionMode::General && !options.strict_resolution
    {
        return best_effort::plan_best_effort(mission, options, observer, stop);
    }
    let deadline = Deadline::after(started, options.time_limit_s, stop);
    precheck_with(mission, options.dynamics)?;
    let start = match &options.init {
        Some(tr) => given_start(mission, options, deadline, tr)?,
        None => built_in_start(mission, options, deadline),
    };
    let mut start_energy_j = evaluate(mission, &start).energy_j;
    let resolution = if spec.exact_geometry {
        options.resolution
    } else {
        ResolutionMode::Paper
    };
    let mut solver = SocpSolver::new(options.scheme_socp());
    let mut repair_solver = SocpSolver::new(options.scheme_socp());
    // Every scheme needs a start that is feasible on the exact geometry, except the paper's
    // schemes started from a given path: that path is used as it is (its first (p5) is the
    // reproduction check).
    let phase1 = match spec.family {
        Family::ExactGeometry => Some(spec.objective),
        Family::PaperBcd => options.init.is_none().then_some(ExactObjective::Energy),
    };
    let base = ExactTuning {
        resolution,
        dynamics: options.dynamics,
        ..ExactTuning::default()
    };
    let (start, repair_iterations, init_replaced) = match phase1 {
        Some(objective) => {
            let search = StartSearch {
                mission,
                options,
                objective,
                base: &base,
                exact_rules: spec.own_rules,
                deadline,
                stop,
                best_effort_start,
            };
            let found = search.run(
                start,
                || built_in_start(mission, options, deadline),
                &mut repair_solver,
                observer,
            )?;
            start_energy_j = found.start_energy_j;
            (
                found.trajectory,
                found.repair_iterations,
                found.init_replaced,
            )
        }
        None => (start, 0, None),
    };
    observer.on_phase("solve");
    let means = Means {
        solver: &mut solver,
        observer: &mut *observer,
        deadline,
    };
    let (trajectory, end) = match spec.family {
        Family::ExactGeometry => run_exact(mission, start, spec.objective, &base, options, means)?,
        Family::PaperBcd => run_paper(
            mission,
            start,
            spec.paper_objective(),
            options,
            means,
            paper_state.take(),
        )?,
    };
    let made = Made {
        scheme: options.scheme,
        resolution,
        dynamics: options.dynamics,
        start_energy_j,
        repair_iterations,
        init_replaced,
        best_effort: None,
        programs_before: repair_solver.builds.max(repair_iterations),
    };
    Ok(finish(mission, trajectory, end, made))
}

/// A start given in the options ([`PlanOptions::init`]), checked against the mission; an
/// infeasible one is first re-optimised on the coarse grid (exact-geometry schemes).
fn given_start(
    mission: &Mission,
    options: &PlanOptions,
    deadline: Deadline,
    tr: &Trajectory,
) -> Result<Trajectory, PlanError> {
    check_given(mission, tr)?;
    // A given start that is infeasible (a warm start after the mission changed, say)
    // is repaired and re-optimised on the coarse grid first, like the built-in start:
    // large steps fix large violations in few iterations.
    let spec = options.scheme.spec();
    let objective = (spec.family == Family::ExactGeometry).then_some(spec.objective);
    Ok(match objective {
        Some(obj)
            if options.coarse
                && !evaluate(mission, tr)
                    .is_feasible_with(options.resolution, options.dynamics) =>
        {
            coarse_start_from(mission, obj, true, options, deadline, Some(tr), 0)
                .and_then(LevelStart::solved)
                .unwrap_or_else(|| tr.clone())
        }
        _ => tr.clone(),
    })
}

/// Whether a given start `tr` ([`PlanOptions::init`]) fits `mission`: its slots, finite
/// positions, and the mission's start point.
pub(super) fn check_given(mission: &Mission, tr: &Trajectory) -> Result<(), PlanError> {
    let p = mission.params();
    if tr.slots() != mission.slots() || (tr.slot_s - p.slot_s).abs() > 1e-12 {
        return Err(PlanError::InvalidInit(format!(
            "{} slots of {} s, but the mission has {} slots of {} s",
            tr.slots(),
            tr.slot_s,
            mission.slots(),
            p.slot_s
        )));
    }
    if tr.pos_m.iter().flatten().any(|v| !v.is_finite()) {
        return Err(PlanError::InvalidInit("non-finite position".into()));
    }
    if distance(&Point2::from(tr.start_m), &Point2::from(p.start_m)) > 1e-6 {
        return Err(PlanError::InvalidInit(format!(
            "it starts at ({}, {}) m (its t = 0 row), but the mission starts at \
             start_m = ({}, {}) m",
            tr.start_m[0], tr.start_m[1], p.start_m[0], p.start_m[1]
        )));
    }
    Ok(())
}

/// The built-in start: the guidance law on a coarse grid made feasible there (phase I); for the
/// exact-geometry schemes also optimised there. The paper's schemes get the plain feasible path,
/// as Algorithm 1's step 1 asks ("a feasible initial flight path").
fn built_in_start(mission: &Mission, options: &PlanOptions, deadline: Deadline) -> Trajectory {
    let spec = options.scheme.spec();
    let (objective, optimise) = match spec.family {
        Family::ExactGeometry => (spec.objective, options.coarse),
        Family::PaperBcd => (ExactObjective::Energy, false),
    };
    coarse_start(mission, objective, optimise, options, deadline)
        .unwrap_or_else(|| guidance_start_with(mission, options.resolution, options.dynamics))
}
