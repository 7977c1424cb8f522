//! Calls into the planner: the initial plan of the whole horizon and receding-horizon re-plans
//! from the current state when a landmark moves.

use std::time::Instant;

use planner::evaluate::{Dynamics, ResolutionMode};
use planner::{LandmarkWindow, LandmarksSpec, Mission, Trajectory};
use serde::{Deserialize, Serialize};

use crate::core::Num;

mod splice;
use splice::{remainder, splice_altitudes_m};

/// A finished plan.
#[derive(Debug, Clone)]
pub struct Planned {
    /// The trajectory.
    pub trajectory: Trajectory,
    /// The altitude of every slot, m, for a mission with `altitude = "free"`
    /// ([`planner::PlanResult::altitudes_m`]); `None` at the mission's fixed altitude.
    pub altitudes_m: Option<Vec<f64>>,
    /// Wall time of the solve, s.
    pub solve_s: f64,
    /// One line for the log.
    pub summary: String,
}

/// The options of the initial plan that the FMU's parameters `resolution`, `strict_resolution`,
/// `max_extra_energy_pct` and `dynamics` set: the plan options a user gives `cellsar-planner plan`
/// (`--resolution`, `--strict-resolution`, `--max-extra-energy-pct`, `--dynamics`), with the same
/// defaults ([`planner::PlanOptions::default`]). Re-plans inside a step ignore the resolution
/// options (they plan for [`REPLAN_RESOLUTION`]) and keep the dynamics
/// ([`ReplanOptions::dynamics`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InitialPlan {
    /// [`planner::PlanOptions::resolution`].
    pub resolution: ResolutionMode,
    /// [`planner::PlanOptions::strict_resolution`].
    pub strict_resolution: bool,
    /// [`planner::PlanOptions::max_extra_energy_pct`] (`None`: no cap).
    pub max_extra_energy_pct: Option<f64>,
    /// [`planner::PlanOptions::dynamics`]: the vehicle model of the initial plan and of every
    /// re-plan.
    pub dynamics: Dynamics,
}

impl Default for InitialPlan {
    fn default() -> Self {
        let d = planner::PlanOptions::default();
        Self {
            resolution: d.resolution,
            strict_resolution: d.strict_resolution,
            max_extra_energy_pct: d.max_extra_energy_pct,
            dynamics: d.dynamics,
        }
    }
}

impl InitialPlan {
    /// The planner's options: these, and the library's defaults for everything else.
    pub fn plan_options(&self) -> planner::PlanOptions {
        planner::PlanOptions {
            resolution: self.resolution,
            strict_resolution: self.strict_resolution,
            max_extra_energy_pct: self.max_extra_energy_pct,
            dynamics: self.dynamics,
            // a free-altitude mission is planned with its altitude per slot (output `z_m`)
            altitude_profile: true,
            ..Default::default()
        }
    }

    /// Checks the options with the library's [`planner::PlanOptions::validate`] (which includes
    /// [`planner::PlanOptions::check_best_effort`]); the error is the library's message, which
    /// names the options by their fields, the names of the FMU's parameters.
    pub fn validate(&self) -> Result<(), String> {
        self.plan_options().validate().map_err(|e| e.to_string())
    }

    /// The plan for a log line: "resolution general (best effort, no energy cap), dynamics
    /// vehicle".
    pub fn describe(&self) -> String {
        let detail = match (
            self.resolution,
            self.strict_resolution,
            self.max_extra_energy_pct,
        ) {
            (ResolutionMode::Paper, _, _) => " (the least-energy plan)".to_string(),
            (ResolutionMode::General, true, _) => " (strict)".to_string(),
            (ResolutionMode::General, false, None) => " (best effort, no energy cap)".to_string(),
            (ResolutionMode::General, false, Some(pct)) => {
                format!(
                    " (best effort, at most {}% more energy than the least-energy plan)",
                    Num(pct)
                )
            }
        };
        format!(
            "resolution {}{detail}, dynamics {}",
            self.resolution, self.dynamics
        )
    }
}

/// Plans `mission` with the planner's defaults ([`planner::PlanOptions::default`]: the `exact`
/// scheme for the general resolution cell as a best effort, the same plan as `cellsar-planner
/// plan`, `cellsar run`, the Python package and a plan request on the wire), warm-started from
/// `init` if given. The error is the planner's message.
pub fn plan(mission: &Mission, init: Option<Trajectory>) -> Result<Planned, String> {
    plan_with(mission, init, &planner::PlanOptions::default())
}

/// The resolution requirement of the receding-horizon re-plans ([`replan`]): the paper's, the
/// least-energy plan, not the library's default (the general cell as a best effort) that the
/// initial plan uses. The best effort plans the least-energy plan first and then its own, about
/// 13 times as long on the default mission (4.35 s against 0.32 s for the whole horizon, debug
/// build: `cellsar-planner plan missions/default-30m.toml --resolution general|paper`), too
/// long for a re-plan inside a co-simulation step. The output `plan_resolution` says which plan
/// is flown.
pub const REPLAN_RESOLUTION: planner::evaluate::ResolutionMode =
    planner::evaluate::ResolutionMode::Paper;

/// The value of the output `plan_resolution` for a plan made for `mode`: 1 for the general cell
/// (the best effort of the initial plan), 0 for the paper's (every re-plan).
pub fn resolution_code(mode: planner::evaluate::ResolutionMode) -> i32 {
    match mode {
        planner::evaluate::ResolutionMode::Paper => 0,
        planner::evaluate::ResolutionMode::General => 1,
    }
}

/// Where a re-plan starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WarmStart {
    /// From the rest of the current plan.
    Always,
    /// From the rest of the current plan when it already keeps the moved landmark in view
    /// (exact-geometry feasible), else from the planner's own (coarse-to-fine) start: repairing
    /// an infeasible warm start takes many small phase-I steps.
    IfFeasible,
    /// From the planner's own start.
    Never,
}

/// How a receding-horizon re-plan calls the planner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplanOptions {
    /// Where the re-plan starts.
    pub warm_start: WarmStart,
    /// Largest number of SCA iterations of the re-plan.
    pub max_iterations: usize,
    /// Relative objective change that ends the re-plan.
    pub tolerance: f64,
    /// `planner::PlanOptions::coarse`: repair an infeasible warm start on a coarse grid (slots of
    /// about 2.5 s) first. Off, the warm start is repaired on the mission's own slots.
    pub coarse: bool,
    /// `planner::PlanOptions::dynamics`: the vehicle model of the re-plan, that of the initial
    /// plan (the FMU's parameter `dynamics`). Under [`Dynamics::Vehicle`] the re-plan starts
    /// with the velocity flown into q_{from_slot}.
    pub dynamics: Dynamics,
}

/// The defaults were chosen with `cargo run --release -p fmu --example replan-bench` (see
/// BENCHMARKS.md): the warm start is fastest in most cases, 5 iterations keep the energy
/// within a few J of the converged re-plan, and repairing the warm start on the mission's own
/// slots (`coarse: false`) is up to 4× faster than on the coarse grid: the coarse repair costs
/// 0.3–1.3 s on the moves measured, and where transition slots are needed it stalls anyway, as a
/// 2.5 s coarse slot must see the moved landmark over its whole length.
impl Default for ReplanOptions {
    fn default() -> Self {
        Self {
            warm_start: WarmStart::Always,
            max_iterations: 5,
            tolerance: 1e-3,
            coarse: false,
            dynamics: planner::DEFAULT_DYNAMICS,
        }
    }
}

/// [`plan`] with explicit planner options (`options.init` is replaced by `init`).
pub fn plan_with(
    mission: &Mission,
    init: Option<Trajectory>,
    options: &planner::PlanOptions,
) -> Result<Planned, String> {
    let started = Instant::now();
    let options = planner::PlanOptions {
        init,
        ..options.clone()
    };
    let result = planner::plan(mission, &options).map_err(|e| e.to_string())?;
    let solve_s = started.elapsed().as_secs_f64();
    let summary = format!(
        "true energy {:.3} J, {} iterations, {}, {:.3} s",
        result.evaluation.energy_j, result.iterations, result.termination, solve_s
    );
    Ok(Planned {
        trajectory: result.trajectory,
        altitudes_m: result.altitudes_m,
        solve_s,
        summary,
    })
}

/// How one planner call of a re-plan treated the moved landmark's window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WindowPlan {
    /// The window starts at the earliest `delay` slots after the re-plan's start (0: the
    /// mission's own window; slots of the window before that are not asked to see the landmark).
    Delayed(usize),
    /// The window was left out: the moved landmark is not asked to be in view in any of its slots.
    Dropped,
}

/// One planner call of a re-plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Attempt {
    /// How the moved landmark's window was treated.
    pub window: WindowPlan,
    /// Wall time of the call (building the sub-mission included), s.
    pub solve_s: f64,
    /// The planner's message when the call failed.
    pub error: Option<String>,
}

impl std::fmt::Display for Attempt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.window {
            WindowPlan::Delayed(d) => write!(f, "delay {d}")?,
            WindowPlan::Dropped => write!(f, "window left out")?,
        }
        match &self.error {
            None => write!(f, ": {:.3} s", self.solve_s),
            Some(e) => write!(f, ": failed after {:.3} s ({e})", self.solve_s),
        }
    }
}

/// The attempts of a re-plan for a log line: "delay 0: failed after 9.512 s (…); delay 1: 0.210 s".
pub fn describe_attempts(attempts: &[Attempt]) -> String {
    if attempts.is_empty() {
        return "no planner call".to_string();
    }
    attempts
        .iter()
        .map(Attempt::to_string)
        .collect::<Vec<_>>()
        .join("; ")
}

/// The outcome of a receding-horizon re-plan.
#[derive(Debug, Clone)]
pub struct Replanned {
    /// The mission with the moved landmark (full horizon, original slot grid).
    pub mission: Mission,
    /// The spliced trajectory: the old plan up to slot `from_slot`, the new plan after it.
    pub trajectory: Trajectory,
    /// Slots of the moved window after `from_slot` that the accepted plan was not asked to keep
    /// the moved landmark in view in (the UAV first has to get there; all of them when
    /// `window_dropped`); 0 when it is asked to be in view at once.
    pub transition_slots: usize,
    /// The moved landmark could not be kept in view in any slot of its window: the accepted plan
    /// leaves the window out (the other windows are planned as usual).
    pub window_dropped: bool,
    /// The altitude of every slot of `trajectory` for a free-altitude plan (the current plan's up
    /// to slot `from_slot`, the new plan's after it), m; `None` at the mission's fixed altitude.
    pub altitudes_m: Option<Vec<f64>>,
    /// Wall time of all planner calls, s.
    pub solve_s: f64,
    /// Every planner call, in order (the last one is the accepted plan).
    pub attempts: Vec<Attempt>,
    /// Sensing excess of the warm start on the sub-mission, summed over its slots, m.
    pub start_excess_m: f64,
    /// Whether the accepted plan started from the rest of the current plan.
    pub warm: bool,
    /// One line for the log.
    pub summary: String,
}

/// Sensing excess Σ (‖g − c‖ − r_s)⁺ of `traj` over the landmark slots of `mission`, m.
pub fn sensing_excess_m(mission: &Mission, traj: &Trajectory) -> f64 {
    let r = mission.params().sensing_radius_m;
    planner::evaluate(mission, traj)
        .slots
        .iter()
        .filter_map(|s| s.centre_error_m)
        .map(|e| (e - r).max(0.0))
        .sum()
}

/// Why a re-plan produced no new trajectory.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum ReplanError {
    /// The moved landmark makes the mission invalid (e.g. a non-finite coordinate).
    Mission(String),
    /// The planner could not plan the rest of the horizon; the mission (with the moved landmark)
    /// is returned so the outputs can report the landmark honestly.
    Planner {
        /// The mission with the moved landmark.
        mission: Box<Mission>,
        /// The planner's message (of the last call).
        message: String,
        /// Every planner call, in order.
        attempts: Vec<Attempt>,
        /// Wall time of all planner calls, s.
        solve_s: f64,
    },
}

/// `mission` with the landmark of window `window` (0-based, as `points[window]` of a mission
/// file) at `moved_m`. The error says why the moved mission is invalid.
pub fn moved_mission(
    mission: &Mission,
    window: usize,
    moved_m: [f64; 2],
) -> Result<Mission, String> {
    let mut windows = mission.schedule().landmarks.clone();
    let count = windows.len();
    let Some(w) = windows.get_mut(window) else {
        return Err(format!(
            "landmark window {window} does not exist (the mission has {count})"
        ));
    };
    w.x_m = moved_m[0];
    w.y_m = moved_m[1];
    let spec = LandmarksSpec {
        points: Some(windows),
        ..Default::default()
    };
    Mission::new(mission.name(), mission.params().clone(), &spec).map_err(|e| e.to_string())
}

/// Moves landmark window `window` of `mission` to `moved_m` and re-plans, for the paper's
/// resolution ([`REPLAN_RESOLUTION`]), the slots after `from_slot` (the slots up to `from_slot` are already flown or committed: the UAV is on its way
/// to q_{from_slot}). The sub-mission starts at q_{from_slot} with the remaining windows shifted
/// by `from_slot` slots.
///
/// When the moved landmark cannot be in view in the first slots of its window, the start of the
/// window is delayed: first to the earliest slot that [`planner::init::earliest_in_view_slot`] allows, then by
/// 1, 2, 4, … more slots until the planner finds a plan. When no delay works (or the landmark is
/// out of reach in every slot of its window), the rest of the horizon is planned without that
/// window ([`Replanned::window_dropped`]); the caller reports the slots out of view.
///
/// `current` is flown at the mission's fixed altitude; [`replan_with_altitudes`] re-plans a
/// free-altitude plan.
pub fn replan(
    mission: &Mission,
    current: &Trajectory,
    from_slot: usize,
    window: usize,
    moved_m: [f64; 2],
    options: &ReplanOptions,
) -> Result<Replanned, ReplanError> {
    replan_with_altitudes(mission, current, None, from_slot, window, moved_m, options)
}

/// [`replan`] of a plan `current` flown at the altitudes `current_altitudes_m` (one per slot,
/// a free-altitude plan's; `None`: the mission's fixed altitude). A mission with
/// `altitude = "free"` is re-planned as the initial plan is, with an altitude per slot
/// ([`planner::PlanOptions::altitude_profile`]): the sub-mission starts at q_{from_slot} at the
/// altitude flown there, H_{from_slot} (its `altitude_m`, with the sensing radius of the same
/// antenna there, [`planner::altitude::params_at`]), so the spliced profile keeps the climb and
/// descent rates across the splice ([`Replanned::altitudes_m`]).
pub fn replan_with_altitudes(
    mission: &Mission,
    current: &Trajectory,
    current_altitudes_m: Option<&[f64]>,
    from_slot: usize,
    window: usize,
    moved_m: [f64; 2],
    options: &ReplanOptions,
) -> Result<Replanned, ReplanError> {
    let plan_options = planner::PlanOptions {
        max_iterations: options.max_iterations,
        tolerance: options.tolerance,
        coarse: options.coarse,
        resolution: REPLAN_RESOLUTION,
        dynamics: options.dynamics,
        // a free-altitude mission's re-plan has an altitude per slot, as its initial plan
        altitude_profile: true,
        ..Default::default()
    };
    let started = Instant::now();
    let moved = moved_mission(mission, window, moved_m).map_err(ReplanError::Mission)?;
    let slot_s = mission.params().slot_s;
    if from_slot >= mission.slots() {
        return Ok(Replanned {
            mission: moved,
            trajectory: current.clone(),
            transition_slots: 0,
            window_dropped: false,
            altitudes_m: current_altitudes_m.map(<[f64]>::to_vec),
            solve_s: 0.0,
            attempts: Vec::new(),
            start_excess_m: 0.0,
            warm: false,
            summary: "the horizon is over: nothing to re-plan".into(),
        });
    }
    let rest = remainder(&moved, current, current_altitudes_m, from_slot, window);
    let (plans, reach_note) = window_plans(&rest.sub_params, moved_m, rest.moved_slots);
    let mut attempts: Vec<Attempt> = Vec::new();
    let mut last_error = String::new();
    for plan in plans {
        let call_started = Instant::now();
        let points = sub_windows(&rest.future, window, plan, slot_s);
        let sub = match Mission::new(
            format!(
                "{} (re-plan from t = {} s)",
                mission.name(),
                Num(rest.shift_s)
            ),
            rest.sub_params.clone(),
            &LandmarksSpec {
                points: Some(points),
                ..Default::default()
            },
        ) {
            Ok(m) => m,
            Err(e) => {
                last_error = e.to_string();
                attempts.push(Attempt {
                    window: plan,
                    solve_s: call_started.elapsed().as_secs_f64(),
                    error: Some(last_error.clone()),
                });
                continue;
            }
        };
        let excess = sensing_excess_m(&sub, &rest.init);
        let warm = match options.warm_start {
            WarmStart::Always => true,
            WarmStart::Never => false,
            WarmStart::IfFeasible => planner::evaluate(&sub, &rest.init).is_feasible(),
        };
        match plan_with(&sub, warm.then(|| rest.init.clone()), &plan_options) {
            Ok(planned) => {
                attempts.push(Attempt {
                    window: plan,
                    solve_s: call_started.elapsed().as_secs_f64(),
                    error: None,
                });
                let mut pos_m = current.pos_m.get(..from_slot).unwrap_or(&[]).to_vec();
                pos_m.extend_from_slice(&planned.trajectory.pos_m);
                let solve_s = started.elapsed().as_secs_f64();
                let (transition_slots, window_dropped) = transition(plan, rest.moved_slots);
                let altitudes_m = splice_altitudes_m(
                    mission,
                    current_altitudes_m,
                    planned.altitudes_m.as_deref(),
                    from_slot,
                    rest.sub_params.altitude_m,
                );
                let outcome = if window_dropped {
                    format!("landmark {window}'s window left out")
                } else {
                    format!("{transition_slots} transition slot(s)")
                };
                return Ok(Replanned {
                    mission: moved,
                    trajectory: Trajectory {
                        slot_s,
                        start_m: current.start_m,
                        pos_m,
                    },
                    transition_slots,
                    window_dropped,
                    altitudes_m,
                    solve_s,
                    summary: format!(
                        "{} slots from t = {} s in {solve_s:.3} s, {} start (sensing excess {excess:.1} m){reach_note}, {} planner call(s) ({}), {outcome}, {}",
                        rest.remaining,
                        Num(rest.shift_s),
                        if warm { "warm" } else { "cold" },
                        attempts.len(),
                        describe_attempts(&attempts),
                        planned.summary
                    ),
                    attempts,
                    start_excess_m: excess,
                    warm,
                });
            }
            Err(e) => {
                attempts.push(Attempt {
                    window: plan,
                    solve_s: call_started.elapsed().as_secs_f64(),
                    error: Some(e.clone()),
                });
                last_error = e;
            }
        }
    }
    Err(ReplanError::Planner {
        mission: Box::new(moved),
        message: last_error,
        attempts,
        solve_s: started.elapsed().as_secs_f64(),
    })
}

/// The window plans to try after a move, in order (the moved window delayed by d0, d0 + 1, d0 + 2,
/// d0 + 4, … slots while it keeps slots, where d0 skips the slots that cannot see it; then dropped),
/// and a note on when the moved landmark is reachable.
/// `moved_slots` are the moved window's first and last slot in the sub-mission (1-based).
fn window_plans(
    sub_params: &planner::Params,
    moved_m: [f64; 2],
    moved_slots: Option<(usize, usize)>,
) -> (Vec<WindowPlan>, String) {
    let mut plans = Vec::new();
    let mut reach_note = String::new();
    if let Some((first, last)) = moved_slots {
        match planner::init::earliest_in_view_slot(sub_params, moved_m, first, last) {
            Some(t) => {
                let d0 = if t > first { t - 1 } else { 0 };
                if d0 > 0 {
                    reach_note = format!(
                        ", the moved landmark is out of reach before sub-mission slot {t} (delays below {d0} skipped)"
                    );
                }
                let mut extra = 0usize;
                while d0 + extra < last {
                    plans.push(WindowPlan::Delayed(d0 + extra));
                    extra = if extra == 0 { 1 } else { extra * 2 };
                }
            }
            None => {
                reach_note =
                    ", the moved landmark is out of reach in every slot of its window".to_string()
            }
        }
        plans.push(WindowPlan::Dropped);
    } else {
        plans.push(WindowPlan::Delayed(0));
    }
    (plans, reach_note)
}

/// The sub-mission's landmark windows under a window plan for the moved `window`.
fn sub_windows(
    future: &[(usize, LandmarkWindow)],
    window: usize,
    plan: WindowPlan,
    slot_s: f64,
) -> Vec<LandmarkWindow> {
    future
        .iter()
        .filter_map(|(i, w)| match plan {
            _ if *i != window => Some(*w),
            WindowPlan::Dropped => None,
            WindowPlan::Delayed(0) => Some(*w),
            WindowPlan::Delayed(d) => Some(LandmarkWindow {
                from_s: w.from_s.max(d as f64 * slot_s),
                ..*w
            }),
        })
        .collect()
}

/// Transition slots and whether the moved window was dropped, for a plan that succeeded.
fn transition(plan: WindowPlan, moved_slots: Option<(usize, usize)>) -> (usize, bool) {
    match (plan, moved_slots) {
        (_, None) => (0, false),
        (WindowPlan::Dropped, Some((first, last))) => (last - first + 1, true),
        (WindowPlan::Delayed(d), Some((first, last))) => {
            ((d.min(last) + 1).saturating_sub(first), false)
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
