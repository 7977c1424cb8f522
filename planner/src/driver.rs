//! The planning driver: feasibility pre-check, start trajectory (with phase-I repair), the SCA /
//! BCD iterations of each scheme, the stopping rule and the observer.

use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::evaluate::{evaluate, Evaluation, ResolutionMode};
use crate::geometry::{distance, Point2, Vector2};
use crate::init::{guidance_start, precheck, Infeasibility};
use crate::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use crate::schemes::paper::{PaperObjective, PaperState};
use crate::socp::{SocpSettings, SocpSolver, SolveError};
use crate::{Mission, Trajectory};

/// Which planner to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// SCA on the exact geometry; every iterate feasible on it (the default).
    Exact,
    /// The paper's Algorithm 1 as printed: SCA + BCD between (p5) and (p6).
    Paper,
    /// The paper's baseline: least flight distance under the paper's convexification.
    Baseline,
    /// Least flight distance on the exact geometry (a baseline that is truly feasible).
    BaselineExact,
}

impl Scheme {
    /// All schemes.
    pub const ALL: [Scheme; 4] = [
        Scheme::Exact,
        Scheme::Paper,
        Scheme::Baseline,
        Scheme::BaselineExact,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Exact => "exact",
            Scheme::Paper => "paper",
            Scheme::Baseline => "baseline",
            Scheme::BaselineExact => "baseline-exact",
        }
    }
}

impl std::fmt::Display for Scheme {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Options of a planning run.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOptions {
    /// The scheme.
    pub scheme: Scheme,
    /// Largest number of SCA/BCD iterations.
    pub max_iterations: usize,
    /// Stop when the relative change of the objective is below this.
    pub tolerance: f64,
    /// Start from this trajectory instead of the built-in guidance start.
    pub init: Option<Trajectory>,
    /// Settings of the cone-program solver for the comparison schemes (`paper`, `baseline`,
    /// `baseline-exact`).
    pub socp: SocpSettings,
    /// Settings of the cone-program solver for the `exact` scheme, its coarse start and its
    /// repair. Its default skips Clarabel's iterative refinement (about twice as fast, the same
    /// energies); the comparison schemes keep the refinement because their flat or
    /// solver-dependent objectives land on other local optima without it (`baseline-exact`
    /// up to 1.2 % longer).
    pub exact_socp: SocpSettings,
    /// Smallest factor on the proven centre-error bound that the exact scheme tries after
    /// successful steps (1 = always use the proven bound).
    pub min_kappa_scale: f64,
    /// For the exact-geometry schemes without a given start: first solve the mission on slots
    /// about 2 s long and start from that solution (fewer, larger steps make the SCA converge
    /// in far fewer iterations; the fine solve then only polishes). When false, the coarse grid
    /// only provides a feasible start.
    pub coarse: bool,
    /// Try longer steps along each accepted SCA step of the exact scheme (2× and 4×, kept when
    /// still feasible and better). Off gives the plain SCA sequence.
    pub over_relaxation: bool,
    /// Resolution requirement of the exact-geometry schemes (the paper's schemes always use the
    /// paper's, as printed).
    pub resolution: ResolutionMode,
    /// Wall-time limit of the whole run, s (`None`: none). The coarse levels are skipped once it
    /// has passed; the iterations stop at the first check after it with
    /// [`TerminationReason::TimeLimit`] and return the last accepted iterate (feasible on the
    /// exact geometry for the exact-geometry schemes); a phase I that has not found a feasible
    /// start by then fails with [`PlanError::TimeLimit`]. A check comes before every cone
    /// program, so the run ends within about one program's time (~0.1 s at 600 slots) after it.
    pub time_limit_s: Option<f64>,
    /// When a given start ([`PlanOptions::init`]) cannot be repaired, plan from the built-in
    /// start instead (saying so in [`PlanResult::init_replaced`]); when false, fail with phase
    /// I's error.
    pub replace_unrepairable_init: bool,
}

impl PlanOptions {
    /// Checks the numeric options; the error names the first bad one.
    pub fn validate(&self) -> Result<(), PlanError> {
        let bad = |field, value, reason| {
            Err(PlanError::InvalidOption {
                field,
                value,
                reason,
            })
        };
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad("tolerance", self.tolerance, "must be a finite number > 0");
        }
        if !(self.min_kappa_scale.is_finite()
            && self.min_kappa_scale > 0.0
            && self.min_kappa_scale <= 1.0)
        {
            return bad(
                "min_kappa_scale",
                self.min_kappa_scale,
                "must lie in (0, 1]",
            );
        }
        if let Some(limit) = self.time_limit_s {
            if !(limit.is_finite() && limit > 0.0) {
                return bad(
                    "time_limit_s",
                    limit,
                    "must be a finite number of seconds > 0",
                );
            }
        }
        Ok(())
    }

    /// The cone-program settings of this run's scheme.
    pub fn scheme_socp(&self) -> SocpSettings {
        match self.scheme {
            Scheme::Exact => self.exact_socp,
            Scheme::BaselineExact | Scheme::Paper | Scheme::Baseline => self.socp,
        }
    }
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            scheme: Scheme::Exact,
            max_iterations: 200,
            tolerance: 1e-4,
            init: None,
            socp: SocpSettings::default(),
            exact_socp: SocpSettings::exact_geometry(),
            min_kappa_scale: 1.0 / 16.0,
            coarse: true,
            over_relaxation: true,
            resolution: ResolutionMode::Paper,
            time_limit_s: None,
            replace_unrepairable_init: true,
        }
    }
}

/// When a planning run must stop: [`PlanOptions::time_limit_s`] after it started.
#[derive(Debug, Clone, Copy)]
struct Deadline {
    at: Option<Instant>,
    /// The limit, s (for messages; infinite without one).
    limit_s: f64,
}

impl Deadline {
    /// `limit_s` after `started` (a limit too large to represent is no limit).
    fn after(started: Instant, limit_s: Option<f64>) -> Self {
        let at = limit_s
            .and_then(|s| Duration::try_from_secs_f64(s).ok())
            .and_then(|d| started.checked_add(d));
        Self {
            at,
            limit_s: limit_s.unwrap_or(f64::INFINITY),
        }
    }

    /// Whether it has passed.
    fn passed(self) -> bool {
        self.at.is_some_and(|at| Instant::now() >= at)
    }
}

/// Why the iterations stopped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "reason", content = "detail")]
pub enum TerminationReason {
    /// The relative change of the objective fell below the tolerance.
    Converged,
    /// The iteration limit was reached.
    MaxIterations,
    /// A subproblem failed even after backing off; the last accepted iterate is returned.
    SubproblemFailed(String),
    /// Steps kept being rejected by the exact-geometry check; the last accepted iterate is returned.
    NoProgress,
    /// [`PlanOptions::time_limit_s`] passed; the last accepted iterate is returned.
    TimeLimit,
}

/// One iteration as seen by an [`Observer`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Iteration number (1-based).
    pub iteration: usize,
    /// The optimiser's own objective after this iteration (J, or m for distance schemes).
    pub objective: f64,
    /// True energy of the iterate on the exact geometry, J.
    pub true_energy_j: f64,
    /// Largest sensing violation of the iterate on the exact geometry, m.
    pub sensing_violation_m: f64,
    /// Largest azimuth (minimum speed) violation on the exact geometry, m/s.
    pub speed_violation_mps: f64,
    /// Interior-point iterations spent in this iteration's cone programs.
    pub ipm_iterations: u32,
    /// Wall time of this iteration, s.
    pub seconds: f64,
    /// Whether the step was accepted.
    pub accepted: bool,
}

/// Receives progress of a planning run.
pub trait Observer {
    /// Called after every iteration (accepted or rejected).
    fn on_iteration(&mut self, _record: &IterationRecord) {}
    /// Called when a phase starts ("repair", "solve").
    fn on_phase(&mut self, _phase: &str) {}
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoObserver;
impl Observer for NoObserver {}

/// The result of a planning run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanResult {
    /// The scheme that produced it.
    pub scheme: Scheme,
    /// The planned trajectory.
    pub trajectory: Trajectory,
    /// Its exact-geometry evaluation (true energy, violations, per-slot values).
    pub evaluation: Evaluation,
    /// The optimiser's own final objective (J for energy schemes, m for distance schemes).
    pub objective: f64,
    /// The optimiser's objective after each accepted iteration.
    pub objective_history: Vec<f64>,
    /// True energy after each accepted iteration, J.
    pub true_energy_history: Vec<f64>,
    /// All iterations (accepted and rejected).
    pub records: Vec<IterationRecord>,
    /// Number of iterations run.
    pub iterations: usize,
    /// True when stopped by the tolerance.
    pub converged: bool,
    /// Why it stopped.
    pub termination: TerminationReason,
    /// Wall time of the whole run (start, repair and iterations), s.
    pub solve_seconds: f64,
    /// True energy of the start trajectory, J.
    pub start_energy_j: f64,
    /// Phase-I iterations spent repairing the start.
    pub repair_iterations: usize,
    /// Cone programs solved.
    pub cone_programs: usize,
    /// The resolution requirement the plan was made for.
    pub resolution: ResolutionMode,
    /// Why a given start (`PlanOptions::init`) was not used: it could not be repaired (made
    /// feasible) and the plan starts from the built-in start instead. `None` when the given
    /// start was used or none was given.
    pub init_replaced: Option<String>,
}

/// Why planning failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// The mission cannot be flown (found before or during phase I).
    #[error(transparent)]
    Infeasible(#[from] Infeasibility),
    /// The given start trajectory does not fit the mission.
    #[error("start trajectory: {0}")]
    InvalidInit(String),
    /// The first subproblem could not be solved.
    ///
    /// The solver's error is part of the message (not a separate `source`), so that printing
    /// the error chain names it once.
    #[error("iteration {iteration}: {error}")]
    Solver {
        /// Iteration (0 = phase I).
        iteration: usize,
        /// The solver's error.
        error: SolveError,
    },
    /// [`PlanOptions::time_limit_s`] passed before a feasible start was found.
    #[error(
        "time limit of {limit_s} s reached after {iterations} phase I iterations without a \
         feasible start (largest sensing violation {sensing_violation_m:.2} m)"
    )]
    TimeLimit {
        /// The limit, s.
        limit_s: f64,
        /// Phase I iterations run on the mission's own grid.
        iterations: usize,
        /// Largest sensing violation of the last accepted repair iterate, m.
        sensing_violation_m: f64,
    },
    /// An option is out of range.
    #[error("option `{field}` = {value}: {reason}")]
    InvalidOption {
        /// The option's name (its field of [`PlanOptions`]).
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What it must satisfy.
        reason: &'static str,
    },
}

impl From<PlanError> for cellsar_error::exit::Failure {
    /// An infeasible mission exits 3, a start trajectory that does not fit or a bad option 2, a
    /// solver failure or a time limit 1.
    fn from(e: PlanError) -> Self {
        use cellsar_error::exit::FailureKind as K;
        let kind = match &e {
            PlanError::Infeasible(_) => K::Infeasible,
            PlanError::InvalidInit(_) | PlanError::InvalidOption { .. } => K::BadInput,
            PlanError::Solver { .. } | PlanError::TimeLimit { .. } => K::Runtime,
        };
        Self::new(kind, e)
    }
}

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
    let started = Instant::now();
    options.validate()?;
    let deadline = Deadline::after(started, options.time_limit_s);
    precheck(mission)?;
    let p = mission.params();
    let start = match &options.init {
        Some(tr) => {
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
            // A given start that is infeasible (a warm start after the mission changed, say)
            // is repaired and re-optimised on the coarse grid first, like the built-in start:
            // large steps fix large violations in few iterations.
            let objective = match options.scheme {
                Scheme::BaselineExact => Some(ExactObjective::Distance),
                Scheme::Exact => Some(ExactObjective::Energy),
                Scheme::Paper | Scheme::Baseline => None,
            };
            match objective {
                Some(obj)
                    if options.coarse
                        && !evaluate(mission, tr).is_feasible_for(options.resolution) =>
                {
                    coarse_start_from(mission, obj, true, options, deadline, Some(tr), 0)
                        .and_then(LevelStart::solved)
                        .unwrap_or_else(|| tr.clone())
                }
                _ => tr.clone(),
            }
        }
        None => built_in_start(mission, options, deadline),
    };
    let mut start_energy_j = evaluate(mission, &start).energy_j;
    let resolution = match options.scheme {
        Scheme::Exact | Scheme::BaselineExact => options.resolution,
        Scheme::Paper | Scheme::Baseline => ResolutionMode::Paper,
    };
    let mut solver = SocpSolver::new(options.scheme_socp());
    let mut repair_solver = SocpSolver::new(options.scheme_socp());
    // Every scheme needs a start that is feasible on the exact geometry, except the paper's
    // schemes started from a given path: that path is used as it is (its first (p5) is the
    // reproduction check).
    let phase1 = match options.scheme {
        Scheme::Exact => Some(ExactObjective::Energy),
        Scheme::BaselineExact => Some(ExactObjective::Distance),
        Scheme::Paper | Scheme::Baseline => {
            options.init.is_none().then_some(ExactObjective::Energy)
        }
    };
    let base = ExactTuning {
        resolution,
        ..ExactTuning::default()
    };
    let mut init_replaced = None;
    let (start, repair_iterations) = match phase1 {
        Some(objective) => {
            let exact_rules = options.scheme == Scheme::Exact;
            match make_feasible(
                mission,
                start,
                objective,
                &base,
                &mut repair_solver,
                observer,
                exact_rules,
                deadline,
            ) {
                Ok(repaired) => repaired,
                // A given path phase I cannot repair (far outside the speed limits, or so far
                // from the landmarks that the elastic program is numerically infeasible): plan
                // from the built-in start rather than fail, and say so (unless told not to, or
                // out of time).
                Err(failure)
                    if options.init.is_some()
                        && options.replace_unrepairable_init
                        && !matches!(failure.error, PlanError::TimeLimit { .. }) =>
                {
                    let reason = failure.error.to_string();
                    tracing::warn!(
                        error = %reason,
                        "the given start cannot be repaired; planning from the built-in start"
                    );
                    init_replaced = Some(reason);
                    let start = built_in_start(mission, options, deadline);
                    start_energy_j = evaluate(mission, &start).energy_j;
                    make_feasible(
                        mission,
                        start,
                        objective,
                        &base,
                        &mut repair_solver,
                        observer,
                        exact_rules,
                        deadline,
                    )?
                }
                Err(failure) => return Err(failure.into()),
            }
        }
        None => (start, 0),
    };
    observer.on_phase("solve");
    let mut out = match options.scheme {
        Scheme::Exact => run_exact(
            mission,
            start,
            ExactObjective::Energy,
            &base,
            options,
            deadline,
            &mut solver,
            observer,
        )?,
        Scheme::BaselineExact => run_exact(
            mission,
            start,
            ExactObjective::Distance,
            &base,
            options,
            deadline,
            &mut solver,
            observer,
        )?,
        Scheme::Paper => run_paper(
            mission,
            start,
            PaperObjective::Energy,
            options,
            deadline,
            &mut solver,
            observer,
        )?,
        Scheme::Baseline => run_paper(
            mission,
            start,
            PaperObjective::Distance,
            options,
            deadline,
            &mut solver,
            observer,
        )?,
    };
    out.scheme = options.scheme;
    out.resolution = resolution;
    out.start_energy_j = start_energy_j;
    out.repair_iterations = repair_iterations;
    out.init_replaced = init_replaced;
    out.cone_programs += repair_solver.builds.max(repair_iterations);
    out.solve_seconds = started.elapsed().as_secs_f64();
    Ok(out)
}

/// The built-in start: the guidance law on a coarse grid made feasible there (phase I); for the
/// exact-geometry schemes also optimised there. The paper's schemes get the plain feasible path,
/// as Algorithm 1's step 1 asks ("a feasible initial flight path").
fn built_in_start(mission: &Mission, options: &PlanOptions, deadline: Deadline) -> Trajectory {
    let (objective, optimise) = match options.scheme {
        Scheme::Exact => (ExactObjective::Energy, options.coarse),
        Scheme::BaselineExact => (ExactObjective::Distance, options.coarse),
        Scheme::Paper | Scheme::Baseline => (ExactObjective::Energy, false),
    };
    coarse_start(mission, objective, optimise, options, deadline)
        .unwrap_or_else(|| guidance_start(mission, options.resolution))
}

/// Slot lengths of the coarse levels, finest first, s: the mission is first solved on slots of
/// about 10 s (one per landmark window of the paper's missions), that solution starts a solve on
/// slots of about 5 s, that one a solve on slots of about 2.5 s, which starts the mission's own
/// grid. (All divide the paper's 10 s landmark windows.) The 10 s level finds the shape of the
/// track (the orbit of the 30 m mission) in a few cheap iterations: the default 30 m mission
/// plans 2.3x faster with it (BENCHMARKS.md, "Planner"). The `exact` scheme starts one level
/// earlier, on 20 s slots ([`EXACT_COARSE_LEVELS_S`]).
const COARSE_LEVELS_S: [f64; 3] = [2.5, 5.0, 10.0];

/// The coarse levels of the `exact` scheme's built-in start: [`COARSE_LEVELS_S`] and a first
/// solve on slots of about 20 s. A 20 s slot senses only the landmark of its end time (the 10 s
/// level then repairs the others), but it finds the orbit of compact missions that the 10 s level
/// can miss: random-9 and random-18 of Fig. 11 plan in 0.2 s instead of 6–16 s, at the floor
/// instead of 5–6 J above it, and the staircase in 0.65 s instead of 1.3 s (BENCHMARKS.md).
/// The comparison schemes keep [`COARSE_LEVELS_S`], so that their starts do not change.
const EXACT_COARSE_LEVELS_S: [f64; 4] = [2.5, 5.0, 10.0, 20.0];

/// The coarse levels for a scheme and purpose (optimising `exact`, or anything else).
fn coarse_levels(options: &PlanOptions, optimise: bool) -> &'static [f64] {
    if optimise && options.scheme == Scheme::Exact {
        &EXACT_COARSE_LEVELS_S
    } else {
        &COARSE_LEVELS_S
    }
}

/// The factor k (n divisible by k, at least 12 coarse slots) whose slot length k δ is closest to
/// `target_s`, within a factor 1.5 of it.
fn coarse_factor(n: usize, delta: f64, target_s: f64) -> Option<usize> {
    (2..=n / 12)
        .filter(|&k| n.is_multiple_of(k))
        .map(|k| (k, ((k as f64 * delta) / target_s).ln().abs()))
        .filter(|(_, d)| *d <= 1.5f64.ln())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k)
}

/// Solves the mission on coarser grids ([`coarse_levels`]) and interpolates the result to the
/// mission's slots. `None` when no suitable coarse grid exists or it fails (a stalled finest
/// level included: see [`LevelStart::solved`]).
fn coarse_start(
    mission: &Mission,
    objective: ExactObjective,
    optimise: bool,
    options: &PlanOptions,
    deadline: Deadline,
) -> Option<Trajectory> {
    coarse_start_from(mission, objective, optimise, options, deadline, None, 0)
        .and_then(LevelStart::solved)
}

/// What a coarse level hands to the next finer one, interpolated to that one's slots.
enum LevelStart {
    /// Feasible at its level (and optimised there when asked).
    Solved(Trajectory),
    /// The last accepted (least-merit) iterate of a phase I that stalled (only for `exact`):
    /// the level's windows cannot all be held over its whole slots, but the track has the right
    /// shape.
    Stalled(Trajectory),
}

impl LevelStart {
    /// The track when it is feasible at its level. The finest coarse level hands only such a
    /// track to the fine grid (a stalled one there would replace the guidance start or a given
    /// `--init` path, which the fine phase I repairs itself).
    fn solved(self) -> Option<Trajectory> {
        match self {
            LevelStart::Solved(t) => Some(t),
            LevelStart::Stalled(_) => None,
        }
    }
}

/// [`coarse_start`] at coarse level `level`, from a given fine-grid trajectory (sampled at the
/// coarse slot ends) or else from the next coarser level (or the guidance law).
///
/// For `exact`, when the next coarser level stalled, this level is solved from both its
/// stalled track and the guidance law and keeps the cheaper result (when both stall here too,
/// the track that came from the coarser level is handed on): the stalled track is the
/// better start on Fig. 11's random realisations (19: 149 fine iterations to 7 J above the
/// floor from the guidance law, 1 iteration to the floor from the stalled 20 s track), the
/// guidance law on the square of Fig. 9 (H = 1000 m: 35 440 J against 39 380 J).
fn coarse_start_from(
    mission: &Mission,
    objective: ExactObjective,
    optimise: bool,
    options: &PlanOptions,
    deadline: Deadline,
    warm: Option<&Trajectory>,
    level: usize,
) -> Option<LevelStart> {
    if deadline.passed() {
        return None;
    }
    let n = mission.slots();
    let delta = mission.params().slot_s;
    let target = coarse_levels(options, optimise).get(level)?;
    let factor = coarse_factor(n, delta, *target)?;
    let coarse = mission.coarsened(factor)?;
    let tuning = ExactTuning {
        whole_slot_sensing: true,
        resolution: options.resolution,
        ..ExactTuning::default()
    };
    let exact_rules = optimise && options.scheme == Scheme::Exact;
    let starts: Vec<Trajectory> = match warm {
        Some(w) => vec![Trajectory {
            slot_s: coarse.params().slot_s,
            start_m: w.start_m,
            pos_m: (1..=coarse.slots()).map(|k| w.q(k * factor)).collect(),
        }],
        None => match coarse_start_from(
            &coarse,
            objective,
            optimise,
            options,
            deadline,
            None,
            level + 1,
        ) {
            Some(LevelStart::Solved(t)) => vec![t],
            Some(LevelStart::Stalled(t)) => vec![t, guidance_start(&coarse, options.resolution)],
            None => vec![guidance_start(&coarse, options.resolution)],
        },
    };
    let mut best: Option<(f64, Trajectory)> = None;
    let mut stalled: Option<Trajectory> = None;
    for start in starts {
        let mut solver = SocpSolver::new(options.scheme_socp());
        let feasible = make_feasible(
            &coarse,
            start,
            objective,
            &tuning,
            &mut solver,
            &mut NoObserver,
            exact_rules,
            deadline,
        );
        let start = match feasible {
            Ok((start, _)) => start,
            Err(f) => {
                tracing::debug!(factor, error = %f.error, "coarse level: no feasible track");
                if exact_rules && stalled.is_none() {
                    stalled = f.stalled;
                }
                continue;
            }
        };
        let tr: (f64, Trajectory) = if optimise {
            let sub_options = PlanOptions {
                init: None,
                coarse: false,
                ..options.clone()
            };
            let mut solver = SocpSolver::new(options.scheme_socp());
            let solved = match run_exact(
                &coarse,
                start,
                objective,
                &tuning,
                &sub_options,
                deadline,
                &mut solver,
                &mut NoObserver,
            ) {
                Ok(solved) => solved,
                Err(e) => {
                    tracing::debug!(factor, error = %e, "coarse level: optimisation failed");
                    continue;
                }
            };
            tracing::debug!(
                factor,
                iterations = solved.iterations,
                energy_j = solved.evaluation.energy_j,
                "coarse solve"
            );
            (objective.true_value(&solved.evaluation), solved.trajectory)
        } else {
            // not optimised: the comparison schemes, which always have one start (two starts
            // come only after a stalled level, which needs the exact scheme's optimisation)
            (0.0, start)
        };
        if best.as_ref().is_none_or(|(b, _)| tr.0 < *b) {
            best = Some(tr);
        }
    }
    let to_fine = |tr: Trajectory| Trajectory {
        slot_s: delta,
        start_m: tr.start_m,
        pos_m: (1..=n).map(|t| tr.position_at(t as f64 * delta)).collect(),
    };
    match (best, stalled) {
        (Some((_, tr)), _) => Some(LevelStart::Solved(to_fine(tr))),
        (None, Some(tr)) => Some(LevelStart::Stalled(to_fine(tr))),
        (None, None) => None,
    }
}

/// Per-slot violation used by the elastic phase: the largest of the sensing excess (m), the
/// azimuth speed shortfall (m/s) and the range keep-out shortfall (m) of each landmark slot,
/// summed over slots (the same quantities that the subproblem's slack σ_t bounds). With
/// `whole_slot`, the sensing excess is the larger of the slot-end centre's and the slot-start
/// centre's (straight flight at the slot's heading), as [`ExactTuning::whole_slot_sensing`] imposes.
fn total_violation(
    mission: &Mission,
    ev: &Evaluation,
    mode: ResolutionMode,
    whole_slot: bool,
) -> f64 {
    let p = mission.params();
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
        .sum()
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
#[allow(clippy::too_many_arguments)] // private: the run's state, passed explicitly
fn make_feasible(
    mission: &Mission,
    start: Trajectory,
    objective: ExactObjective,
    base: &ExactTuning,
    solver: &mut SocpSolver,
    observer: &mut dyn Observer,
    exact_rules: bool,
    deadline: Deadline,
) -> Result<(Trajectory, usize), PhaseOneFailure> {
    let mode = base.resolution;
    let mut current = start;
    let mut ev = evaluate(mission, &current);
    if ev.is_feasible_for(mode) {
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
    let violation_of = |ev: &Evaluation| total_violation(mission, ev, mode, slot_start);
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
            if ev.is_feasible_for(mode) {
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
    let p = mission.params();
    let first = ev
        .slots
        .iter()
        .find(|s| {
            !s.in_view
                || (s.landmark_m.is_some()
                    && (s.speed_mps < p.min_speed_mps() - 1e-4
                        || (mode == ResolutionMode::General && s.worst_width_m > p.d_min_m + 1e-4)))
        })
        .map(|s| s.t)
        .unwrap_or(1);
    let error = PlanError::Infeasible(Infeasibility {
        slot: first,
        t_s: first as f64 * p.slot_s,
        reason: format!(
            "no trajectory found that keeps every landmark in view at the required resolution \
             ({} resolution; phase I stalled with a sensing violation of {:.2} m, a speed \
             shortfall of {:.3} m/s and a worst cell width of d_min + {:.2} m)",
            mode.name(),
            ev.violations.sensing_m,
            ev.violations.min_speed_mps,
            ev.violations.worst_width_m
        ),
    });
    Err(PhaseOneFailure {
        error,
        stalled: Some(current),
    })
}

/// Why phase I gave no feasible start.
struct PhaseOneFailure {
    error: PlanError,
    /// Its last accepted (least-merit) iterate when it stalled (not after a solver failure).
    stalled: Option<Trajectory>,
}

impl From<PhaseOneFailure> for PlanError {
    fn from(f: PhaseOneFailure) -> Self {
        f.error
    }
}

fn record(
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

#[allow(clippy::too_many_arguments)] // a private constructor of PlanResult
fn finish(
    mission: &Mission,
    trajectory: Trajectory,
    objective: f64,
    objective_history: Vec<f64>,
    true_energy_history: Vec<f64>,
    records: Vec<IterationRecord>,
    termination: TerminationReason,
    cone_programs: usize,
) -> PlanResult {
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
    }
}

/// The exact-geometry SCA loop (monotone: a step is accepted only if it is feasible on the exact
/// geometry and does not increase the true objective; otherwise a trust region is tightened).
#[allow(clippy::too_many_arguments)] // private: the run's state, passed explicitly
fn run_exact(
    mission: &Mission,
    start: Trajectory,
    objective: ExactObjective,
    base: &ExactTuning,
    options: &PlanOptions,
    deadline: Deadline,
    solver: &mut SocpSolver,
    observer: &mut dyn Observer,
) -> Result<PlanResult, PlanError> {
    let true_value = |ev: &Evaluation| objective.true_value(ev);
    let mut current = start;
    let mut ev = evaluate(mission, &current);
    let mut value = true_value(&ev);
    let mut tuning = *base;
    let mut records = Vec::new();
    let mut obj_hist = Vec::new();
    let mut energy_hist = Vec::new();
    let mut last_objective = value;
    let mut rejects = 0;
    let mut programs = 0;
    let mut termination = TerminationReason::MaxIterations;
    for it in 1..=options.max_iterations {
        if deadline.passed() {
            termination = TerminationReason::TimeLimit;
            break;
        }
        let t0 = Instant::now();
        let sub = ExactSubproblem::build(mission, &current, objective, &tuning);
        programs += 1;
        let sol = match solver.solve(&sub.builder) {
            Ok(s) => s,
            Err(e) => {
                if it == 1 && tuning.trust_radius_m.is_none() && records.is_empty() {
                    tracing::warn!(error = %e, "first subproblem failed; retrying with a trust region");
                }
                rejects += 1;
                tuning.trust_radius_m = Some(tuning.trust_radius_m.map_or(2.0, |r| r * 0.5));
                records.push(record(
                    it,
                    f64::NAN,
                    &ev,
                    0,
                    t0.elapsed().as_secs_f64(),
                    false,
                ));
                if rejects > 8 {
                    if obj_hist.is_empty() && it <= 9 {
                        return Err(PlanError::Solver {
                            iteration: it,
                            error: e,
                        });
                    }
                    termination = TerminationReason::SubproblemFailed(e.to_string());
                    break;
                }
                continue;
            }
        };
        let mut cand = sub.trajectory(&sol.x, &current);
        let mut cand_ev = evaluate(mission, &cand);
        let mut cand_value = true_value(&cand_ev);
        // over-relaxation: SCA steps limited by the conservative centre bound tend to repeat in
        // the same direction; try longer steps along it and keep the best that stays feasible.
        let mode = base.resolution;
        if options.over_relaxation && cand_ev.is_feasible_for(mode) && cand_value < value {
            for alpha in [2.0, 4.0] {
                let trial = extrapolate(&current, &cand, alpha);
                let ev = evaluate(mission, &trial);
                let v = true_value(&ev);
                if ev.is_feasible_for(mode) && v < cand_value {
                    cand = trial;
                    cand_ev = ev;
                    cand_value = v;
                } else {
                    break;
                }
            }
        }
        let own = sub.physical_objective(sol.objective);
        let ok = cand_ev.is_feasible_for(mode) && cand_value <= value * (1.0 + 1e-9) + 1e-9;
        let rec = record(
            it,
            own,
            &cand_ev,
            sol.iterations,
            t0.elapsed().as_secs_f64(),
            ok,
        );
        observer.on_iteration(&rec);
        records.push(rec);
        if !ok && tuning.kappa_scale < 1.0 {
            // the optimistic model overreached: fall back to the proven bound and re-solve
            tuning.kappa_scale = (tuning.kappa_scale * 2.0).min(1.0);
            continue;
        }
        if !ok {
            rejects += 1;
            tracing::debug!(
                iteration = it,
                feasible = cand_ev.is_feasible_for(mode),
                value = cand_value,
                previous = value,
                "step rejected"
            );
            tuning.trust_radius_m = Some(tuning.trust_radius_m.map_or(2.0, |r| r * 0.5));
            if rejects > 8 {
                termination = TerminationReason::NoProgress;
                break;
            }
            continue;
        }
        rejects = 0;
        let rel = (value - cand_value).abs() / value.abs().max(1e-12);
        current = cand;
        ev = cand_ev;
        value = cand_value;
        last_objective = own;
        obj_hist.push(own);
        energy_hist.push(ev.energy_j);
        tracing::debug!(
            iteration = it,
            objective = own,
            true_value = value,
            rel,
            "accepted"
        );
        if rel < options.tolerance {
            termination = TerminationReason::Converged;
            break;
        }
        // a successful step relaxes the trust region again and makes the centre model bolder
        tuning.trust_radius_m = tuning.trust_radius_m.map(|r| r * 4.0).filter(|r| *r < 50.0);
        tuning.kappa_scale = (tuning.kappa_scale * 0.8).max(options.min_kappa_scale);
    }
    Ok(finish(
        mission,
        current,
        last_objective,
        obj_hist,
        energy_hist,
        records,
        termination,
        programs,
    ))
}

/// `from + alpha (to − from)`, slot by slot.
fn extrapolate(from: &Trajectory, to: &Trajectory, alpha: f64) -> Trajectory {
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
fn run_paper(
    mission: &Mission,
    start: Trajectory,
    objective: PaperObjective,
    options: &PlanOptions,
    deadline: Deadline,
    solver: &mut SocpSolver,
    observer: &mut dyn Observer,
) -> Result<PlanResult, PlanError> {
    let mut state = PaperState::from_trajectory(mission, &start);
    let mut p6_solver = SocpSolver::new(options.socp);
    let mut records = Vec::new();
    let mut obj_hist: Vec<f64> = Vec::new();
    let mut energy_hist = Vec::new();
    let mut termination = TerminationReason::MaxIterations;
    let mut programs = 0;
    let mut traj = start;
    for it in 1..=options.max_iterations {
        if deadline.passed() {
            termination = TerminationReason::TimeLimit;
            break;
        }
        let t0 = Instant::now();
        let p5 = state.solve_p5(mission, objective, solver);
        programs += 1;
        let (own, ipm) = match p5 {
            Ok(v) => v,
            Err(e) => {
                if obj_hist.is_empty() {
                    return Err(PlanError::Solver {
                        iteration: it,
                        error: e,
                    });
                }
                termination = TerminationReason::SubproblemFailed(e.to_string());
                break;
            }
        };
        let ipm6 = state.solve_p6(mission, &mut p6_solver);
        programs += 1;
        traj = state.trajectory(&traj);
        let ev = evaluate(mission, &traj);
        let rec = record(it, own, &ev, ipm + ipm6, t0.elapsed().as_secs_f64(), true);
        observer.on_iteration(&rec);
        records.push(rec);
        let prev = obj_hist.last().copied();
        obj_hist.push(own);
        energy_hist.push(ev.energy_j);
        if let Some(prev) = prev {
            if (prev - own).abs() / prev.abs().max(1e-12) < options.tolerance {
                termination = TerminationReason::Converged;
                break;
            }
        }
    }
    let last = obj_hist.last().copied().unwrap_or(f64::NAN);
    Ok(finish(
        mission,
        traj,
        last,
        obj_hist,
        energy_hist,
        records,
        termination,
        programs,
    ))
}
