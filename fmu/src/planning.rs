//! Calls into the planner: the initial plan of the whole horizon and receding-horizon re-plans
//! from the current state when a landmark moves.

use std::time::Instant;

use planner::{LandmarkWindow, LandmarksSpec, Mission, Trajectory};

/// A finished plan.
#[derive(Debug, Clone)]
pub struct Planned {
    /// The trajectory.
    pub trajectory: Trajectory,
    /// Wall time of the solve, s.
    pub solve_s: f64,
    /// One line for the log.
    pub summary: String,
}

/// Plans `mission` with the planner's default (exact) scheme, warm-started from `init` if given.
/// The error is the planner's message.
pub fn plan(mission: &Mission, init: Option<Trajectory>) -> Result<Planned, String> {
    plan_with(mission, init, &planner::PlanOptions::default())
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
}

/// The defaults were chosen with `cargo run --release -p fmu --example replan-bench` (see
/// BENCHMARKS.md): the warm start is fastest in most cases, and 5 iterations keep the energy
/// within a few J of the converged re-plan.
impl Default for ReplanOptions {
    fn default() -> Self {
        Self {
            warm_start: WarmStart::Always,
            max_iterations: 5,
            tolerance: 1e-3,
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
        "true energy {:.3} J, {} iterations, {:?}, {:.3} s",
        result.evaluation.energy_j, result.iterations, result.termination, solve_s
    );
    Ok(Planned {
        trajectory: result.trajectory,
        solve_s,
        summary,
    })
}

/// The outcome of a receding-horizon re-plan.
#[derive(Debug, Clone)]
pub struct Replanned {
    /// The mission with the moved landmark (full horizon, original slot grid).
    pub mission: Mission,
    /// The spliced trajectory: the old plan up to slot `from_slot`, the new plan after it.
    pub trajectory: Trajectory,
    /// Slots of the moved window at the start of the new plan that could not keep the moved
    /// landmark in view (the UAV first has to get there); 0 when it is in view at once.
    pub transition_slots: usize,
    /// Wall time of all planner calls, s.
    pub solve_s: f64,
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
pub enum ReplanError {
    /// The moved landmark makes the mission invalid (e.g. a non-finite coordinate).
    Mission(String),
    /// The planner could not plan the rest of the horizon; the mission (with the moved landmark)
    /// is returned so the outputs can report the landmark honestly.
    Planner {
        /// The mission with the moved landmark.
        mission: Box<Mission>,
        /// The planner's message.
        message: String,
    },
}

/// Moves landmark window `window` of `mission` to `moved_m` and re-plans the slots after
/// `from_slot` (the slots up to `from_slot` are already flown or committed: the UAV is on its way
/// to q_{from_slot}). The sub-mission starts at q_{from_slot} with the remaining windows shifted
/// by `from_slot` slots. When the moved landmark cannot be reached in the very next slot, the
/// start of its window is delayed (1, 2, 4, ... slots) until the planner finds a plan.
pub fn replan(
    mission: &Mission,
    current: &Trajectory,
    from_slot: usize,
    window: usize,
    moved_m: [f64; 2],
    options: &ReplanOptions,
) -> Result<Replanned, ReplanError> {
    let plan_options = planner::PlanOptions {
        max_iterations: options.max_iterations,
        tolerance: options.tolerance,
        ..Default::default()
    };
    let started = Instant::now();
    let p = mission.params().clone();
    let slot_s = p.slot_s;
    let n = mission.slots();
    let mut windows = mission.schedule().landmarks.clone();
    let Some(w) = windows.get_mut(window) else {
        return Err(ReplanError::Mission(format!(
            "landmark window {window} does not exist (the mission has {})",
            mission.schedule().landmarks.len()
        )));
    };
    w.x_m = moved_m[0];
    w.y_m = moved_m[1];
    let spec = LandmarksSpec {
        points: Some(windows.clone()),
        ..Default::default()
    };
    let moved_mission = Mission::new(mission.name(), p.clone(), &spec)
        .map_err(|e| ReplanError::Mission(e.to_string()))?;
    if from_slot >= n {
        return Ok(Replanned {
            mission: moved_mission,
            trajectory: current.clone(),
            transition_slots: 0,
            solve_s: 0.0,
            start_excess_m: 0.0,
            warm: false,
            summary: "the horizon is over: nothing to re-plan".into(),
        });
    }
    let shift_s = from_slot as f64 * slot_s;
    let remaining = n - from_slot;
    let sched = moved_mission.schedule();
    let future: Vec<(usize, LandmarkWindow)> = windows
        .iter()
        .enumerate()
        .filter(|(i, _)| sched.slot_landmark[from_slot..].contains(&Some(*i)))
        .map(|(i, w)| {
            (
                i,
                LandmarkWindow {
                    x_m: w.x_m,
                    y_m: w.y_m,
                    from_s: (w.from_s - shift_s).max(0.0),
                    to_s: (w.to_s - shift_s).min(remaining as f64 * slot_s),
                },
            )
        })
        .collect();
    let mut sub_params = p.clone();
    sub_params.start_m = current.q(from_slot);
    sub_params.horizon_s = remaining as f64 * slot_s;
    let init = Trajectory {
        slot_s,
        start_m: current.q(from_slot),
        pos_m: current.pos_m.get(from_slot..).unwrap_or(&[]).to_vec(),
    };
    let moved_is_future = future.iter().any(|(i, _)| *i == window);
    let mut delays = vec![0usize];
    if moved_is_future {
        let mut d = 1;
        while d < remaining {
            delays.push(d);
            d *= 2;
        }
    }
    let mut last_error = String::new();
    let mut attempts = 0;
    for delay in delays {
        attempts += 1;
        let points: Vec<LandmarkWindow> = future
            .iter()
            .filter_map(|(i, w)| {
                if *i != window || delay == 0 {
                    return Some(*w);
                }
                let from_s = w.from_s.max(delay as f64 * slot_s);
                // keep the window only while a slot end remains in it
                (from_s + slot_s <= w.to_s + 1e-9 * slot_s)
                    .then_some(LandmarkWindow { from_s, ..*w })
            })
            .collect();
        let sub = match Mission::new(
            format!("{} (re-plan from t = {shift_s} s)", mission.name()),
            sub_params.clone(),
            &LandmarksSpec {
                points: Some(points),
                ..Default::default()
            },
        ) {
            Ok(m) => m,
            Err(e) => {
                last_error = e.to_string();
                continue;
            }
        };
        let excess = sensing_excess_m(&sub, &init);
        let warm = match options.warm_start {
            WarmStart::Always => true,
            WarmStart::Never => false,
            WarmStart::IfFeasible => planner::evaluate(&sub, &init).is_feasible(),
        };
        match plan_with(&sub, warm.then(|| init.clone()), &plan_options) {
            Ok(planned) => {
                let mut pos_m = current.pos_m[..from_slot].to_vec();
                pos_m.extend_from_slice(&planned.trajectory.pos_m);
                let solve_s = started.elapsed().as_secs_f64();
                return Ok(Replanned {
                    mission: moved_mission,
                    trajectory: Trajectory {
                        slot_s,
                        start_m: current.start_m,
                        pos_m,
                    },
                    transition_slots: delay,
                    solve_s,
                    start_excess_m: excess,
                    warm,
                    summary: format!(
                        "{} slots from t = {shift_s} s, {} start (sensing excess {excess:.1} m), {attempts} planner call(s), {} transition slot(s), {}",
                        remaining,
                        if warm { "warm" } else { "cold" },
                        delay,
                        planned.summary
                    ),
                });
            }
            Err(e) => last_error = e,
        }
    }
    Err(ReplanError::Planner {
        mission: Box::new(moved_mission),
        message: last_error,
    })
}
