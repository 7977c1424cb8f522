//! The steps of the fixed-altitude schemes (exact-geometry SCA, Algorithm 1), the judge of the
//! exact geometry, and the records the executor keeps.

use crate::evaluate::{evaluate, evaluate_with_altitudes, Dynamics, Evaluation, ResolutionMode};
use crate::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use crate::schemes::paper::{PaperObjective, PaperState};
use crate::shortfall::total_deficit_m;
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

use super::executor::{execute, Candidate, Control, Failure, Step};
use super::options::Deadline;
pub(super) use super::progress::LoopEnd;
use super::table;
use super::{
    BestEffort, IterationRecord, Observer, PlanError, PlanOptions, PlanResult, Scheme,
    TerminationReason,
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

/// What a plan was made for and from, beyond its loop: the parts of a [`PlanResult`] that
/// [`finish`] takes from its maker.
pub(super) struct Made {
    pub scheme: Scheme,
    pub resolution: ResolutionMode,
    pub dynamics: Dynamics,
    /// The true energy of the start the loop began from, J.
    pub start_energy_j: f64,
    /// Phase I's iterations.
    pub repair_iterations: usize,
    pub init_replaced: Option<String>,
    pub best_effort: Option<BestEffort>,
    /// Cone programs solved before the loop (phase I, an earlier loop).
    pub programs_before: usize,
}

/// The plan a loop that ended with `trajectory` (at the mission's fixed altitude) makes, built
/// once from its end and what `made` says. Its bound and wall time are the run's, set where the
/// run ends ([`super::run_plan`]).
pub(super) fn finish(
    mission: &Mission,
    trajectory: Trajectory,
    end: LoopEnd,
    made: Made,
) -> PlanResult {
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
        scheme: made.scheme,
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
        start_energy_j: made.start_energy_j,
        repair_iterations: made.repair_iterations,
        cone_programs: made.programs_before + cone_programs,
        resolution: made.resolution,
        init_replaced: made.init_replaced,
        best_effort: made.best_effort,
        dynamics: made.dynamics,
        altitudes_m: None,
        bound: None,
    }
}

/// The exact-geometry SCA (monotone: a step is accepted only if it is feasible on the exact
/// geometry and does not increase the true objective; otherwise a trust region is tightened),
/// run by the executor with the row [`table::exact`]. Returns the last accepted track and the
/// loop's end.
pub(super) fn run_exact(
    mission: &Mission,
    start: Trajectory,
    objective: ExactObjective,
    base: &ExactTuning,
    options: &PlanOptions,
    means: Means<'_>,
) -> Result<(Trajectory, LoopEnd), PlanError> {
    let Means {
        solver,
        observer,
        deadline,
    } = means;
    let mut step = ExactStep {
        judge: Judge {
            mission,
            objective,
            tuning: base,
        },
        solver,
        over_relaxation: options.over_relaxation,
        programs: 0,
    };
    let out = execute(
        &mut step,
        start,
        &table::exact(options, base),
        Control::of(base),
        LoopEnd::starting(f64::NAN),
        observer,
        deadline,
    )?;
    let mut end = out.end;
    if end.objective_history.is_empty() {
        end.objective = step.judge.value(&out.evaluation);
    }
    Ok((out.iterate, end))
}

impl Control {
    /// The trust radius and centre scale `tuning` starts with.
    pub(super) fn of(tuning: &ExactTuning) -> Self {
        Self {
            trust_radius_m: tuning.trust_radius_m,
            kappa_scale: tuning.kappa_scale,
        }
    }

    /// `tuning` with this trust radius and centre scale.
    pub(super) fn applied_to(self, tuning: &ExactTuning) -> ExactTuning {
        ExactTuning {
            trust_radius_m: self.trust_radius_m,
            kappa_scale: self.kappa_scale,
            ..*tuning
        }
    }
}

/// One step of the exact-geometry SCA at a fixed altitude: the cone program
/// ([`ExactSubproblem`]) at the current track, judged by [`Judge`].
struct ExactStep<'a> {
    judge: Judge<'a>,
    solver: &'a mut SocpSolver,
    over_relaxation: bool,
    programs: usize,
}

impl Step for ExactStep<'_> {
    type Iterate = Trajectory;

    fn evaluate(&self, iterate: &Trajectory) -> Result<Evaluation, PlanError> {
        Ok(evaluate(self.judge.mission, iterate))
    }

    fn propose(
        &mut self,
        current: &Trajectory,
        control: Control,
    ) -> Result<Candidate<Trajectory>, Failure> {
        let tuning = control.applied_to(self.judge.tuning);
        let sub =
            ExactSubproblem::build(self.judge.mission, current, self.judge.objective, &tuning);
        self.programs += 1;
        let sol = self.solver.solve(&sub.builder).map_err(Failure::Solver)?;
        let iterate = sub.trajectory(&sol.x, current);
        Ok(Candidate {
            evaluation: evaluate(self.judge.mission, &iterate),
            iterate,
            objective: sub.physical_objective(sol.objective),
            ipm_iterations: sol.iterations,
        })
    }

    fn merit(&self, evaluation: &Evaluation) -> f64 {
        self.judge.value(evaluation)
    }

    fn admissible(&self, evaluation: &Evaluation, _current: &Evaluation) -> bool {
        self.judge.feasible(evaluation)
    }

    fn lengthen(
        &self,
        current: &Trajectory,
        value: f64,
        candidate: Candidate<Trajectory>,
    ) -> Candidate<Trajectory> {
        if !self.over_relaxation {
            return candidate;
        }
        let judge = &self.judge;
        over_relax(judge.mission, current, value, candidate, |ev| {
            judge.feasible(ev).then(|| judge.value(ev))
        })
    }

    fn cone_programs(&self) -> usize {
        self.programs
    }
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

/// Over-relaxation: SCA steps limited by the conservative centre bound tend to repeat in the
/// same direction; from `current` (of merit `value`), try the step to `candidate` 2× and 4× as
/// long and keep the longest whose merit still falls. `merit` is `None` for an iterate the loop
/// would not accept (the exact scheme's feasibility; phase I accepts any).
pub(super) fn over_relax(
    mission: &Mission,
    current: &Trajectory,
    value: f64,
    candidate: Candidate<Trajectory>,
    merit: impl Fn(&Evaluation) -> Option<f64>,
) -> Candidate<Trajectory> {
    let Candidate {
        mut iterate,
        mut evaluation,
        objective,
        ipm_iterations,
    } = candidate;
    if let Some(mut best) = merit(&evaluation).filter(|m| *m < value) {
        for alpha in [2.0, 4.0] {
            let trial = extrapolate(current, &iterate, alpha);
            let ev = evaluate(mission, &trial);
            match merit(&ev) {
                Some(m) if m < best => {
                    iterate = trial;
                    evaluation = ev;
                    best = m;
                }
                _ => break,
            }
        }
    }
    Candidate {
        iterate,
        evaluation,
        objective,
        ipm_iterations,
    }
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
/// `state_out` receives the BCD state {q, V, q_aux, w, u} of the last iterate. Returns the last
/// iterate's path and the loop's end.
pub(super) fn run_paper(
    mission: &Mission,
    start: Trajectory,
    objective: PaperObjective,
    options: &PlanOptions,
    means: Means<'_>,
    state_out: Option<&mut Option<PaperState>>,
) -> Result<(Trajectory, LoopEnd), PlanError> {
    let mut state = PaperState::from_trajectory(mission, &start);
    let (traj, end) = paper_bcd(mission, &mut state, start, objective, options, means, 0)?;
    if let Some(out) = state_out {
        *out = Some(state);
    }
    Ok((traj, end))
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
    let mut step = PaperStep {
        mission,
        state,
        objective,
        p5_solver: solver,
        p6_solver: SocpSolver::new(options.socp),
        programs: 0,
    };
    let out = execute(
        &mut step,
        start,
        &table::paper(options, done),
        Control::of(&ExactTuning::default()),
        LoopEnd::starting(f64::NAN),
        observer,
        deadline,
    )?;
    Ok((out.iterate, out.end))
}

/// One iteration of Algorithm 1: (p5) for the track, then (p6) for its auxiliaries; every
/// iterate is accepted, as printed.
struct PaperStep<'a> {
    mission: &'a Mission,
    state: &'a mut PaperState,
    objective: PaperObjective,
    p5_solver: &'a mut SocpSolver,
    p6_solver: SocpSolver,
    programs: usize,
}

impl Step for PaperStep<'_> {
    type Iterate = Trajectory;

    fn evaluate(&self, iterate: &Trajectory) -> Result<Evaluation, PlanError> {
        match self.state.altitudes_m() {
            Some(z) => evaluate_with_altitudes(self.mission, iterate, z)
                .map_err(|e| PlanError::InvalidInit(format!("the altitude profile: {e}"))),
            None => Ok(evaluate(self.mission, iterate)),
        }
    }

    fn propose(
        &mut self,
        current: &Trajectory,
        _control: Control,
    ) -> Result<Candidate<Trajectory>, Failure> {
        let p5 = self
            .state
            .solve_p5(self.mission, self.objective, self.p5_solver);
        self.programs += 1;
        let (objective, ipm) = p5.map_err(Failure::Solver)?;
        let ipm6 = self.state.solve_p6(self.mission, &mut self.p6_solver);
        self.programs += 1;
        let iterate = self.state.trajectory(current);
        Ok(Candidate {
            evaluation: self.evaluate(&iterate).map_err(Failure::Fatal)?,
            iterate,
            objective,
            ipm_iterations: ipm + ipm6,
        })
    }

    fn merit(&self, evaluation: &Evaluation) -> f64 {
        evaluation.energy_j
    }

    fn admissible(&self, _evaluation: &Evaluation, _current: &Evaluation) -> bool {
        true
    }

    fn cone_programs(&self) -> usize {
        self.programs
    }
}
