//! [`Run`]: the plan being flown, its outputs at an instant ([`Sample`]) and the slot rule.

use super::*;

/// The plan being flown.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Run {
    /// The mission (with any moved landmarks).
    pub mission: Mission,
    /// Where the mission came from.
    pub source: PathBuf,
    /// The plan over the whole horizon.
    pub traj: Trajectory,
    /// `traj` evaluated on the exact geometry against `mission`.
    pub eval: Evaluation,
    /// Receding-horizon re-plans so far.
    pub replans: u32,
    /// Wall time of the last plan or re-plan, s.
    pub solve_s: f64,
    /// Landmark windows moved by the inputs.
    pub moved: BTreeSet<usize>,
    /// The vehicle model of the plan and of every re-plan (parameter `dynamics`).
    pub dynamics: planner::evaluate::Dynamics,
    /// The plan's altitude per slot, m, for a mission with `altitude = "free"` (`eval` is at
    /// these altitudes); `None` at the mission's fixed altitude.
    #[serde(default)]
    pub altitudes_m: Option<Vec<f64>>,
    /// A lower bound on the energy of every trajectory that meets the mission (as moved) under
    /// `dynamics` ([`planner::bound`]); `None` when the bound proves the mission infeasible.
    #[serde(default)]
    pub bound: Option<planner::EnergyBound>,
}

/// The values of every output at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Position, m.
    pub pos_m: [f64; 2],
    /// Speed of the slot, m/s.
    pub speed_mps: f64,
    /// Heading of the slot, rad.
    pub heading_rad: f64,
    /// Power of the slot, W.
    pub power_w: f64,
    /// Energy since the start, J.
    pub energy_j: f64,
    /// Sensing centre, m.
    pub centre_m: [f64; 2],
    /// Landmark of the slot (NaN: none), m.
    pub landmark_m: [f64; 2],
    /// In view at the slot end.
    pub in_view: bool,
    /// General range resolution, m.
    pub range_resolution_m: f64,
    /// General azimuth resolution, m.
    pub azimuth_resolution_m: f64,
    /// The paper's range resolution, m.
    pub range_resolution_paper_m: f64,
    /// The paper's azimuth resolution, m.
    pub azimuth_resolution_paper_m: f64,
    /// Worst cell width, m.
    pub worst_cell_width_m: f64,
    /// Commanded acceleration of the slot, (v_t − v_{t−1})/δ, and (v_1 − v_0)/(δ/2) for the first
    /// with v_0 the mission's start velocity, m/s².
    pub commanded_accel_mps2: [f64; 2],
    /// Its magnitude, the evaluator's `accel_mps2` of the slot, m/s².
    pub commanded_accel_abs_mps2: f64,
    /// Altitude, linear within the slot, m.
    pub z_m: f64,
    /// Climb rate of the slot (negative: descent), m/s.
    pub climb_mps: f64,
}

/// The slot (1-based) whose values hold at mission time `tau_s`: slot t covers ((t−1)δ, tδ]
/// (the slot rule), so this is ⌈τ/δ⌉; at τ ≤ 0 it is slot 1, past the horizon the last slot. The outputs
/// and the landmark inputs both use it ([`current_window`]).
pub fn slot_at(tau_s: f64, slot_s: f64, slots: usize) -> usize {
    let x = (tau_s / slot_s - 1e-9).ceil();
    if x.is_nan() || x < 1.0 {
        1
    } else {
        (x as usize).clamp(1, slots.max(1))
    }
}

/// `traj` evaluated on the exact geometry against `mission`, at the altitudes `altitudes_m` of
/// a free-altitude plan (one per slot) or at the mission's fixed altitude. The error is the
/// evaluator's message (a profile that breaks the mission's altitude bounds or rates).
pub fn evaluate_at(
    mission: &Mission,
    traj: &Trajectory,
    altitudes_m: Option<&[f64]>,
) -> Result<Evaluation, String> {
    match altitudes_m {
        Some(z) => {
            planner::evaluate::evaluate_with_altitudes(mission, traj, z).map_err(|e| e.to_string())
        }
        None => Ok(evaluate(mission, traj)),
    }
}

impl Run {
    /// `traj` evaluated against `mission` at this plan's altitudes ([`evaluate_at`]).
    pub fn evaluate(&self, mission: &Mission, traj: &Trajectory) -> Result<Evaluation, String> {
        evaluate_at(mission, traj, self.altitudes_m.as_deref())
    }

    /// Takes `mission` (the run's mission with the landmark of window `window` moved) with the
    /// plan kept: the plan is evaluated against it at its altitudes ([`Run::evaluate`]) and the
    /// window counted as moved. The error is the evaluator's message; the run is then unchanged.
    pub(super) fn take_moved(&mut self, mission: Mission, window: usize) -> Result<(), String> {
        self.eval = self.evaluate(&mission, &self.traj)?;
        self.mission = mission;
        self.moved.insert(window);
        Ok(())
    }

    /// All outputs at mission time `tau_s`.
    pub fn sample(&self, tau_s: f64) -> Sample {
        let p = self.mission.params();
        let n = self.eval.slots.len();
        let k = slot_at(tau_s, p.slot_s, n);
        let Some(s) = self.eval.slots.get(k - 1) else {
            // no slot at all (cannot happen for a validated mission): report the start
            return Sample {
                pos_m: self.traj.start_m,
                speed_mps: 0.0,
                heading_rad: 0.0,
                power_w: 0.0,
                energy_j: 0.0,
                centre_m: self.traj.start_m,
                landmark_m: [f64::NAN; 2],
                in_view: true,
                range_resolution_m: f64::NAN,
                azimuth_resolution_m: f64::NAN,
                range_resolution_paper_m: f64::NAN,
                azimuth_resolution_paper_m: f64::NAN,
                worst_cell_width_m: f64::NAN,
                commanded_accel_mps2: [0.0; 2],
                commanded_accel_abs_mps2: 0.0,
                z_m: self.eval.start_altitude_m,
                climb_mps: 0.0,
            };
        };
        let pos_m = self.traj.position_at(tau_s);
        let before_j = if k >= 2 {
            self.eval.slots[k - 2].energy_j
        } else {
            0.0
        };
        let into_slot_s = (tau_s - (k - 1) as f64 * p.slot_s).clamp(0.0, p.slot_s);
        let before_mps = if k >= 2 {
            self.eval.slots[k - 2].velocity_mps
        } else {
            self.mission.start_velocity_mps()
        };
        // into the first slot from the instantaneous start velocity over δ/2
        let window_s = planner::evaluate::accel_window_s(p, k);
        let accel = |i: usize| (s.velocity_mps[i] - before_mps[i]) / window_s;
        let before_z_m = if k >= 2 {
            self.eval.slots[k - 2].z_m
        } else {
            self.eval.start_altitude_m
        };
        Sample {
            pos_m,
            speed_mps: s.speed_mps,
            heading_rad: s.heading_rad,
            power_w: s.power_w,
            energy_j: before_j + s.power_w * into_slot_s,
            centre_m: sensing_centre_m(pos_m, s.heading_rad, p.centre_offset_m()),
            landmark_m: s.landmark_m.unwrap_or([f64::NAN; 2]),
            in_view: s.in_view,
            range_resolution_m: s.range_resolution_general_m,
            azimuth_resolution_m: s.along_track_width_m,
            range_resolution_paper_m: s.range_resolution_paper_m,
            azimuth_resolution_paper_m: s.azimuth_resolution_paper_m,
            worst_cell_width_m: s.worst_width_m,
            commanded_accel_mps2: [accel(0), accel(1)],
            commanded_accel_abs_mps2: s.accel_mps2,
            z_m: before_z_m + s.climb_mps * into_slot_s,
            climb_mps: s.climb_mps,
        }
    }
}

/// The landmark window (0-based, as `points[i]` of the mission file) current at mission time
/// `tau_s`: the one sensed in slot ⌈τ/δ⌉ ([`slot_at`]). the slot rule: slot t covers ((t−1)δ, tδ]
/// and senses the landmark whose window holds tδ (from_s < tδ ≤ to_s). The outputs
/// `landmark_x_m`/`landmark_y_m` report this landmark at τ, the inputs
/// `landmark_x_in_m`/`landmark_y_in_m` of a doStep from τ move it, and `LandmarkMover`, which
/// reads the outputs, shifts it; so at a window boundary τ = kδ all three mean the window that
/// ends there. `None` when that slot senses no landmark.
pub fn current_window(mission: &Mission, tau_s: f64) -> Option<usize> {
    let k = slot_at(tau_s, mission.params().slot_s, mission.slots());
    mission
        .schedule()
        .slot_landmark
        .get(k.checked_sub(1)?)
        .copied()
        .flatten()
}

impl Run {
    /// Slots from `first` (1-based) on whose landmark is not in view at the slot end: their
    /// count and a description naming the landmarks and slots (at most four runs of consecutive
    /// slots).
    pub(super) fn out_of_view_from(&self, first: usize) -> (usize, String) {
        let slot_s = self.mission.params().slot_s;
        let sched = self.mission.schedule();
        // (landmark, first slot, last slot) of each run of consecutive out-of-view slots
        let mut runs: Vec<(Option<usize>, usize, usize)> = Vec::new();
        let mut count = 0;
        for s in self.eval.slots.iter().skip(first.saturating_sub(1)) {
            if s.in_view {
                continue;
            }
            count += 1;
            let landmark = sched.slot_landmark.get(s.t - 1).copied().flatten();
            match runs.last_mut() {
                Some((l, _, last)) if *l == landmark && *last + 1 == s.t => *last = s.t,
                _ => runs.push((landmark, s.t, s.t)),
            }
        }
        let mut text: Vec<String> = runs
            .iter()
            .take(4)
            .map(|(l, a, b)| {
                let name = l.map_or("no landmark".to_string(), |l| format!("landmark {l}"));
                if a == b {
                    format!("{name} in slot {a} (t = {} s)", Num(*a as f64 * slot_s))
                } else {
                    format!(
                        "{name} in slots {a}..{b} (t = {}..{} s)",
                        Num(*a as f64 * slot_s),
                        Num(*b as f64 * slot_s)
                    )
                }
            })
            .collect();
        if runs.len() > 4 {
            text.push(format!("and {} more run(s) of slots", runs.len() - 4));
        }
        (count, text.join(", "))
    }

    /// Logs `warning` and returns it as the step's warning.
    pub(super) fn warn(&self, warning: String, log: &dyn Log) -> StepReport {
        log.log(Category::Warning, Status::Warning, &warning);
        StepReport {
            warning: Some(warning),
        }
    }
}

/// Number of slots flown or committed at mission time `tau_s`: ⌈τ/δ⌉ (0 at the start).
pub(super) fn slot_at_committed(tau_s: f64, slot_s: f64, slots: usize) -> usize {
    let x = (tau_s / slot_s - 1e-9).ceil();
    if x.is_nan() || x < 0.0 {
        0
    } else {
        (x as usize).min(slots)
    }
}
