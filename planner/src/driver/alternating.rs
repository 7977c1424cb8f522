//! Free altitude with the scheme `paper`: the paper's alternating three-dimensional extension
//! as printed (Section III-C, the paragraph after (P6)), for reproduction. The `exact` scheme
//! plans the track and the altitudes jointly instead ([`super::altitude`]).
//!
//! 1. The fixed-altitude plan: Algorithm 1 at `altitude_m` from the usual start, the plan the
//!    scheme makes of the mission with `altitude = "fixed"`, and its BCD state
//!    {q_t, V_t, q_t, w_t, u_t}.
//! 2. Alternation ℓ = 1, 2, …: (b) the altitude step, the paper's "similar subproblem to (P6)"
//!    with the track and its auxiliaries fixed
//!    ([`PaperState::solve_altitudes`](crate::schemes::paper::PaperState::solve_altitudes):
//!    H_t for (w_t, u_t) in (29a) and for H in (29d), with (p2.2) and eq. (explicit) at H_t);
//!    then (a) the 2-D step, Algorithm 1's BCD between (p5) and (p6) continued from that state
//!    with slot t at H_t (centre offset H_t tan η, radius r_s H_t / H, V_min(H_t)).
//! 3. Each alternation's plan is evaluated by the exact evaluator at its altitudes
//!    ([`evaluate_with_altitudes`]) and accepted when its true energy (climb power included) is
//!    at most the last accepted plan's, and it is feasible. The alternation stops when the
//!    altitude step leaves every H_t where it was (the 2-D step at those altitudes is the one
//!    just solved), when the true energy changes by less than [`ALTERNATION_TOLERANCE`]
//!    (relative), at [`MAX_ALTERNATIONS`], or at the first rejected alternation, and returns the
//!    last accepted plan: never more energy than the fixed-altitude plan.
//!
//! Errata that apply (docs/paper-notes.md): 2 (the range rows only where the requirement is not
//! vacuous), 5 (the sensing radius of the antenna at H_t), 8 (eq. (explicit) expanded in its
//! correct form, here in H_t), 9 ((P6)-like problems degenerate: a failed altitude step keeps
//! the previous altitudes), 3 (the relaxations are kept, as in the 2-D scheme). Because of
//! erratum 3, Algorithm 1's plans are themselves infeasible on the exact geometry of the
//! default missions; "feasible" for an alternation then means no less feasible than the plan
//! it would replace: no more slots out of view and no larger violation of any constraint.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use crate::evaluate::{evaluate_with_altitudes, Evaluation, FEASIBILITY_TOL};
use crate::schemes::exact::ExactTuning;
use crate::schemes::paper::{PaperObjective, PaperState};
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

use super::altitude::fixed_at;
use super::executor::{execute, Candidate, Control, Failure, Review, Step, Stop};
use super::iterate::{paper_bcd, Means};
use super::options::Deadline;
use super::progress::LoopEnd;
use super::table;
use super::{NoObserver, Observer, PlanError, PlanOptions, PlanResult, Scheme};

/// Largest number of alternations (altitude step, then 2-D step).
pub const MAX_ALTERNATIONS: usize = 20;

/// The alternation has converged when an accepted alternation changes the true energy by less
/// than this, relative.
pub const ALTERNATION_TOLERANCE: f64 = 1e-4;

/// An altitude step that moves no H_t by more than this, m, leaves the plan where it was.
const STAYED_M: f64 = 1e-6;

/// The phase an [`Observer`] is told at the start of every alternation.
pub const ALTERNATION_PHASE: &str = "alternation";

/// Plans the free-altitude `mission` with the scheme `paper` (the module documentation);
/// `started` is the run's clock.
pub(super) fn plan_free_paper(
    started: Instant,
    mission: &Mission,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    stop: Option<&AtomicBool>,
) -> Result<PlanResult, PlanError> {
    let p = mission.params();
    let n = mission.slots();
    let fixed_mission = fixed_at(mission, p.altitude_m)?;
    let mut state = None;
    let run = super::FixedRun {
        paper_state: Some(&mut state),
        no_best_effort_start: false,
    };
    let fixed = super::plan_fixed(started, &fixed_mission, options, observer, stop, run)?;
    let profile = vec![p.altitude_m; n];
    let ev = evaluate_with_altitudes(mission, &fixed.trajectory, &profile)
        .map_err(|e| PlanError::InvalidInit(format!("the fixed plan's altitude profile: {e}")))?;
    let Some(state) = state else {
        // not reached: Algorithm 1 always leaves its state
        return Ok(PlanResult {
            evaluation: ev,
            altitudes_m: Some(profile),
            bound: None,
            ..fixed
        });
    };
    let deadline = Deadline::after(started, options.time_limit_s, stop);
    alternate(
        mission,
        fixed,
        state.with_altitudes(Some(profile)),
        options,
        observer,
        deadline,
    )
}

/// Whether `cand` may replace `incumbent` (true energies at their altitudes): no more energy,
/// and feasible, or, when `incumbent` is not, no less feasible than it.
pub(super) fn acceptable(cand: &Evaluation, incumbent: &Evaluation) -> bool {
    let energy = cand.energy_j <= incumbent.energy_j * (1.0 + 1e-9);
    let no_worse = |a: f64, b: f64| a <= b.max(FEASIBILITY_TOL) + 1e-9;
    let (c, i) = (&cand.violations, &incumbent.violations);
    let feasible = cand.is_feasible()
        || (!incumbent.is_feasible()
            && cand.slots_out_of_view <= incumbent.slots_out_of_view
            && no_worse(c.sensing_m, i.sensing_m)
            && no_worse(c.min_speed_mps, i.min_speed_mps)
            && no_worse(c.max_speed_mps, i.max_speed_mps)
            && no_worse(c.range_paper_m, i.range_paper_m)
            && c.altitude_ok(FEASIBILITY_TOL));
    energy && feasible
}

/// The alternation from the fixed plan `fixed` and its BCD state `state`, run by the executor with the row [`table::alternation`]: each alternation
/// is one step ([`AlternationStep`]), the BCD inside it a run of the executor itself.
fn alternate(
    mission: &Mission,
    fixed: PlanResult,
    state: PaperState,
    options: &PlanOptions,
    observer: &mut dyn Observer,
    deadline: Deadline<'_>,
) -> Result<PlanResult, PlanError> {
    let start = (
        fixed.trajectory.clone(),
        state.altitudes_m().map(<[f64]>::to_vec).unwrap_or_default(),
    );
    let mut step = AlternationStep {
        mission,
        options,
        state,
        solver: SocpSolver::new(options.scheme_socp()),
        altitude_solver: SocpSolver::new(options.socp),
        observer,
        deadline,
        end: LoopEnd::continuing(&fixed),
        pending: None,
        programs: 0,
    };
    let out = execute(
        &mut step,
        start,
        &table::alternation(),
        Control::of(&ExactTuning::default()),
        LoopEnd::starting(f64::NAN),
        &mut NoObserver,
        deadline,
    )?;
    let mut end = step.end;
    end.termination = out.stop.termination();
    end.cone_programs += step.programs;
    let ((trajectory, altitudes), evaluation) = (out.iterate, out.evaluation);
    Ok(end.into_free_plan(fixed, Scheme::Paper, trajectory, altitudes, evaluation))
}

/// One alternation: (b) the altitude step with the track and its auxiliaries fixed, then (a)
/// Algorithm 1 continued from the state at those altitudes. Its BCD records go straight into
/// `end` (the plan's); its histories join them when the alternation is accepted.
struct AlternationStep<'a, 'o> {
    mission: &'a Mission,
    options: &'a PlanOptions,
    state: PaperState,
    solver: SocpSolver,
    altitude_solver: SocpSolver,
    observer: &'o mut dyn Observer,
    deadline: Deadline<'a>,
    end: LoopEnd,
    /// The last alternation's BCD run, until it is judged.
    pending: Option<LoopEnd>,
    programs: usize,
}

impl Step for AlternationStep<'_, '_> {
    /// The track and the altitude of every slot, m.
    type Iterate = (Trajectory, Vec<f64>);

    fn evaluate(&self, (track, z): &Self::Iterate) -> Result<Evaluation, PlanError> {
        evaluate_with_altitudes(self.mission, track, z)
            .map_err(|e| PlanError::InvalidInit(format!("the altitude profile: {e}")))
    }

    fn propose(
        &mut self,
        (track, _): &Self::Iterate,
        _control: Control,
    ) -> Result<Candidate<Self::Iterate>, Failure> {
        self.observer.on_phase(ALTERNATION_PHASE);
        // (b) the altitudes with the track and its auxiliaries fixed
        let step = self
            .state
            .solve_altitudes(self.mission, &mut self.altitude_solver);
        self.programs += 1;
        if step.max_change_m <= STAYED_M {
            tracing::debug!("the altitude step stayed put");
            return Err(Failure::Settled);
        }
        let z = self
            .state
            .altitudes_m()
            .map(<[f64]>::to_vec)
            .unwrap_or_default();
        // (a) the 2-D problem at those altitudes, Algorithm 1 continued from the state
        let start = self.state.trajectory(track);
        let (traj, run) = paper_bcd(
            self.mission,
            &mut self.state,
            start,
            PaperObjective::Energy,
            self.options,
            Means {
                solver: &mut self.solver,
                observer: &mut *self.observer,
                deadline: self.deadline,
            },
            self.end.records.len(),
        )
        .map_err(|error| Failure::Ended(error.to_string()))?;
        self.programs += run.cone_programs;
        self.end.records.extend(run.records.iter().cloned());
        let evaluation = evaluate_with_altitudes(self.mission, &traj, &z).map_err(|e| {
            Failure::Fatal(PlanError::InvalidInit(format!("the altitude profile: {e}")))
        })?;
        let objective = run.objective;
        self.pending = Some(run);
        Ok(Candidate {
            iterate: (traj, z),
            evaluation,
            objective,
            ipm_iterations: 0,
        })
    }

    fn merit(&self, ev: &Evaluation) -> f64 {
        ev.energy_j
    }

    fn admissible(&self, candidate: &Evaluation, current: &Evaluation) -> bool {
        acceptable(candidate, current)
    }

    /// An accepted alternation adds its BCD histories; the first rejected one ends the
    /// alternation, its last BCD record marked rejected.
    fn review(&mut self, accepted: bool, candidate: &Evaluation, current: &Evaluation) -> Review {
        let run = self.pending.take();
        if !accepted {
            tracing::debug!(
                energy_j = candidate.energy_j,
                incumbent_j = current.energy_j,
                out_of_view = candidate.slots_out_of_view,
                "alternation rejected"
            );
            if let Some(last) = self.end.records.last_mut() {
                last.accepted = false;
            }
            return Review::Stop(Stop::NoProgress);
        }
        if let Some(run) = run {
            self.end.objective = run.objective;
            self.end.objective_history.extend(run.objective_history);
            self.end.true_energy_history.extend(run.true_energy_history);
        }
        Review::Continue
    }

    fn cone_programs(&self) -> usize {
        self.programs
    }
}
