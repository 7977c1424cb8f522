//! [`PlannerCore`]: the planner model's state, its variables and its steps.

use super::*;

/// The planner model's state.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlannerCore {
    /// Parameter values as set through FMI (the default parameters at start); after initialisation the
    /// values in effect.
    pub(super) params: Params,
    /// Names of the parameters set through FMI to a value other than their start value: they
    /// override the mission file. Array elements count one by one, under their FMI 2 names
    /// (`start_m[1]`, `bs_m[2]`): setting one element keeps the file's other one.
    pub(super) params_set: BTreeSet<String>,
    /// `mission_file`.
    pub(super) mission_file: String,
    /// `resolution`, `strict_resolution`, `max_extra_energy_pct`, `dynamics`: the plan options.
    pub(super) initial: planning::InitialPlan,
    /// `start_velocity_mps` as set through FMI (NaN, NaN: the mission's own).
    pub(super) start_velocity_in_mps: [f64; 2],
    /// `landmark_x_in_m`, `landmark_y_in_m`.
    pub(super) landmark_in_m: [f64; 2],
    /// Test hook (hidden variable; only with the `test-hooks` feature).
    #[cfg(feature = "test-hooks")]
    pub(super) debug_panic: i32,
    /// The plan, after initialisation.
    pub(super) run: Option<Run>,
}

impl Default for PlannerCore {
    fn default() -> Self {
        Self {
            params: Params::default(),
            params_set: BTreeSet::new(),
            mission_file: DEFAULT_MISSION_FILE.to_string(),
            initial: planning::InitialPlan::default(),
            start_velocity_in_mps: [f64::NAN; 2],
            landmark_in_m: [f64::NAN, f64::NAN],
            #[cfg(feature = "test-hooks")]
            debug_panic: 0,
            run: None,
        }
    }
}

impl PlannerCore {
    pub(super) fn get_real(&self, var: &Var, elem: usize, tau_s: f64) -> Result<f64, FmuError> {
        match var.vr {
            pv::START_M => return Ok(self.params.start_m[elem.min(1)]),
            pv::BS_M => return Ok(self.params.bs_m[elem.min(1)]),
            pv::LANDMARK_X_IN => return Ok(self.landmark_in_m[0]),
            pv::LANDMARK_Y_IN => return Ok(self.landmark_in_m[1]),
            // NaN: no jerk limit
            pv::MAX_JERK => return Ok(self.params.max_jerk_mps3.unwrap_or(f64::NAN)),
            // NaN: no cap
            pv::MAX_EXTRA_ENERGY_PCT => {
                return Ok(self.initial.max_extra_energy_pct.unwrap_or(f64::NAN))
            }
            // the value in effect once planned, the value set (NaN: the mission's own) before
            pv::START_VELOCITY => {
                return Ok(match &self.run {
                    Some(run) => run.mission.start_velocity_mps()[elem.min(1)],
                    None => self.start_velocity_in_mps[elem.min(1)],
                })
            }
            _ => {}
        }
        if var.causality == crate::table::Causality::Parameter {
            return self
                .params
                .get_by_name(var.name)
                .ok_or_else(|| unknown(var));
        }
        let run = self.run.as_ref().ok_or_else(|| {
            FmuError::error(format!(
                "output `{}` is not available before the mission is planned",
                var.name
            ))
        })?;
        match var.vr {
            pv::SOLVE_TIME => return Ok(run.solve_s),
            pv::LOWER_BOUND => return Ok(run.bound.map_or(f64::NAN, |b| b.energy_j)),
            pv::BOUND_GAP => {
                return Ok(run.bound.map_or(f64::NAN, |b| b.gap_pct(run.eval.energy_j)))
            }
            _ => {}
        }
        let s = run.sample(tau_s);
        Ok(match var.vr {
            pv::X => s.pos_m[0],
            pv::Y => s.pos_m[1],
            pv::SPEED => s.speed_mps,
            pv::HEADING => s.heading_rad,
            pv::POWER => s.power_w,
            pv::ENERGY => s.energy_j,
            pv::XC => s.centre_m[0],
            pv::YC => s.centre_m[1],
            pv::LANDMARK_X => s.landmark_m[0],
            pv::LANDMARK_Y => s.landmark_m[1],
            pv::RANGE_RES => s.range_resolution_m,
            pv::AZIMUTH_RES => s.azimuth_resolution_m,
            pv::RANGE_RES_PAPER => s.range_resolution_paper_m,
            pv::AZIMUTH_RES_PAPER => s.azimuth_resolution_paper_m,
            pv::WORST_WIDTH => s.worst_cell_width_m,
            pv::COMMANDED_ACCEL => s.commanded_accel_abs_mps2,
            pv::COMMANDED_ACCEL_X => s.commanded_accel_mps2[0],
            pv::COMMANDED_ACCEL_Y => s.commanded_accel_mps2[1],
            pv::Z => s.z_m,
            pv::CLIMB => s.climb_mps,
            _ => return Err(unknown(var)),
        })
    }

    pub(super) fn check_real(&self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        if matches!(var.vr, pv::LANDMARK_X_IN | pv::LANDMARK_Y_IN) {
            // NaN means "the plan's own landmark"; an infinite coordinate is no landmark at all
            return if value.is_infinite() {
                Err(FmuError::error(format!(
                    "input `{}` = {}: must be a finite number (a landmark position) or NaN (the plan's own landmark)",
                    var.name,
                    Num(value)
                )))
            } else {
                Ok(())
            };
        }
        if var.causality != crate::table::Causality::Parameter || var.ty != VarType::Real {
            return Err(unknown(var));
        }
        if var.vr == pv::MAX_EXTRA_ENERGY_PCT {
            return check_max_extra_energy_pct(value);
        }
        if var.vr == pv::MAX_JERK {
            // NaN: the mission file's limit, else none (the range is checked at initialisation)
            return if value.is_infinite() {
                Err(FmuError::error(format!(
                    "parameter `{}` = {}: must be a finite number (a jerk limit, m/s3) or NaN (the mission file's, else no jerk limit)",
                    var.name,
                    Num(value)
                )))
            } else {
                Ok(())
            };
        }
        if var.vr == pv::START_VELOCITY {
            // NaN: the mission's own start velocity (checked as a pair at initialisation)
            return if elem >= 2 {
                Err(unknown(var))
            } else if value.is_infinite() {
                Err(FmuError::error(format!(
                    "parameter `{}` = {}: must be a finite number (a velocity component, m/s) or NaN (the mission's own start velocity)",
                    crate::table::fmi2_name(var, elem),
                    Num(value)
                )))
            } else {
                Ok(())
            };
        }
        if !value.is_finite() {
            return Err(FmuError::error(format!(
                "parameter `{}` = {}: must be a finite number",
                crate::table::fmi2_name(var, elem),
                Num(value)
            )));
        }
        match var.vr {
            pv::START_M | pv::BS_M if elem < 2 => Ok(()),
            pv::START_M | pv::BS_M => Err(unknown(var)),
            _ if self.params.get_by_name(var.name).is_some() => Ok(()),
            _ => Err(unknown(var)),
        }
    }

    pub(super) fn set_real(&mut self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        self.check_real(var, elem, value)?;
        let d = Params::default();
        // A parameter overrides the mission file only while it differs from its start value, so
        // importers that write every start value back do not undo the file.
        let at_start = match var.vr {
            pv::LANDMARK_X_IN => {
                self.landmark_in_m[0] = value;
                return Ok(());
            }
            pv::LANDMARK_Y_IN => {
                self.landmark_in_m[1] = value;
                return Ok(());
            }
            pv::MAX_EXTRA_ENERGY_PCT => {
                self.initial.max_extra_energy_pct = (!value.is_nan()).then_some(value);
                self.run = None;
                return Ok(());
            }
            pv::START_VELOCITY => {
                self.start_velocity_in_mps[elem] = value;
                self.run = None;
                return Ok(());
            }
            pv::MAX_JERK => {
                self.params.max_jerk_mps3 = (!value.is_nan()).then_some(value);
                value.is_nan()
            }
            pv::START_M => {
                self.params.start_m[elem] = value;
                value == d.start_m[elem]
            }
            pv::BS_M => {
                self.params.bs_m[elem] = value;
                value == d.bs_m[elem]
            }
            _ => {
                self.params
                    .set_by_name(var.name, value)
                    .map_err(|e| FmuError::error(e.to_string()))?;
                Some(value) == d.get_by_name(var.name)
            }
        };
        let key = crate::table::fmi2_name(var, elem);
        if at_start {
            self.params_set.remove(&key);
        } else {
            self.params_set.insert(key);
        }
        self.run = None;
        Ok(())
    }

    pub(super) fn get_bool(&self, var: &Var, tau_s: f64) -> Result<bool, FmuError> {
        if var.vr == pv::STRICT_RESOLUTION {
            return Ok(self.initial.strict_resolution);
        }
        if var.vr != pv::IN_VIEW {
            return Err(unknown(var));
        }
        let run = self.run.as_ref().ok_or_else(|| {
            FmuError::error("output `in_view` is not available before the mission is planned")
        })?;
        Ok(run.sample(tau_s).in_view)
    }
}

/// Checks a value of `max_extra_energy_pct` on its own: NaN (no cap) or what the library's
/// [`planner::PlanOptions::validate`] accepts as a cap (its message otherwise). Whether a cap
/// applies to the plan (resolution general) is checked at initialisation, when every option is
/// known.
fn check_max_extra_energy_pct(value: f64) -> Result<(), FmuError> {
    if value.is_nan() {
        return Ok(());
    }
    planning::InitialPlan {
        max_extra_energy_pct: Some(value),
        ..Default::default()
    }
    .validate()
    .map_err(|e| {
        FmuError::error(format!(
            "parameter `max_extra_energy_pct` refused: {e} (NaN: no cap)"
        ))
    })
}

impl PlannerCore {
    pub(super) fn check_bool(&self, var: &Var) -> Result<(), FmuError> {
        if var.vr == pv::STRICT_RESOLUTION {
            Ok(())
        } else {
            Err(unknown(var))
        }
    }

    pub(super) fn set_bool(&mut self, var: &Var, value: bool) -> Result<(), FmuError> {
        self.check_bool(var)?;
        self.initial.strict_resolution = value;
        self.run = None;
        Ok(())
    }

    pub(super) fn get_string(&self, var: &Var) -> Result<String, FmuError> {
        match var.vr {
            pv::MISSION_FILE => Ok(self.mission_file.clone()),
            pv::RESOLUTION => Ok(self.initial.resolution.to_string()),
            pv::DYNAMICS => Ok(self.initial.dynamics.to_string()),
            _ => Err(unknown(var)),
        }
    }

    pub(super) fn check_string(&self, var: &Var, value: &str) -> Result<(), FmuError> {
        match var.vr {
            pv::MISSION_FILE => Ok(()),
            pv::RESOLUTION => parse_resolution(value).map(|_| ()),
            pv::DYNAMICS => parse_dynamics(value).map(|_| ()),
            _ => Err(unknown(var)),
        }
    }

    pub(super) fn set_string(&mut self, var: &Var, value: &str) -> Result<(), FmuError> {
        match var.vr {
            pv::MISSION_FILE => self.mission_file = value.to_string(),
            pv::RESOLUTION => self.initial.resolution = parse_resolution(value)?,
            pv::DYNAMICS => self.initial.dynamics = parse_dynamics(value)?,
            _ => return Err(unknown(var)),
        }
        self.run = None;
        Ok(())
    }
}

/// The value of the parameter `resolution`: a name of [`planner::evaluate::ResolutionMode`]
/// (`general`, `paper`), as `cellsar-planner plan --resolution` takes it.
fn parse_resolution(value: &str) -> Result<planner::evaluate::ResolutionMode, FmuError> {
    use planner::evaluate::ResolutionMode;
    ResolutionMode::ALL
        .into_iter()
        .find(|m| m.name() == value)
        .ok_or_else(|| {
            let names: Vec<&str> = ResolutionMode::ALL.iter().map(|m| m.name()).collect();
            FmuError::error(format!(
                "parameter `resolution` = \"{value}\" refused: must be one of {}",
                names.join(", ")
            ))
        })
}

/// The value of the parameter `dynamics`: a name of [`planner::evaluate::Dynamics`] (`paper`,
/// `vehicle`), as `cellsar-planner plan --dynamics` takes it.
fn parse_dynamics(value: &str) -> Result<planner::evaluate::Dynamics, FmuError> {
    use planner::evaluate::Dynamics;
    Dynamics::ALL
        .into_iter()
        .find(|m| m.name() == value)
        .ok_or_else(|| {
            let names: Vec<&str> = Dynamics::ALL.iter().map(|m| m.name()).collect();
            FmuError::error(format!(
                "parameter `dynamics` = \"{value}\" refused: must be one of {}",
                names.join(", ")
            ))
        })
}

impl PlannerCore {
    /// The start velocity set through FMI: `None` when both components are NaN (the mission's
    /// own); an error when only one is.
    pub(super) fn start_velocity_set(&self) -> Result<Option<[f64; 2]>, FmuError> {
        let v = self.start_velocity_in_mps;
        match (v[0].is_nan(), v[1].is_nan()) {
            (true, true) => Ok(None),
            (false, false) => Ok(Some(v)),
            _ => Err(FmuError::error(format!(
                "parameter `start_velocity_mps` = ({}, {}) m/s refused: set both components to finite numbers (the start velocity) or both to NaN (the mission's own: its start_velocity_mps, else the mission's rule)",
                Num(v[0]),
                Num(v[1])
            ))),
        }
    }

    pub(super) fn initialize(
        &mut self,
        resources: Option<&Path>,
        log: &dyn Log,
    ) -> Result<(), FmuError> {
        if self.run.is_some() {
            return Ok(());
        }
        // the options first: a refused combination needs no mission
        self.initial.validate().map_err(|e| {
            FmuError::error(format!(
                "the plan options (parameters `resolution`, `strict_resolution`, `max_extra_energy_pct`, `dynamics`) are refused: {e}"
            ))
        })?;
        let (mission, source) = self.resolve_mission(resources)?;
        log.log(
            Category::Events,
            Status::Ok,
            &format!(
                "mission '{}' from {}: {} slots of {} s, {} landmark windows; planning the whole horizon for {}",
                mission.name(),
                source.display(),
                mission.slots(),
                Num(mission.params().slot_s),
                mission.schedule().landmarks.len(),
                self.initial.describe()
            ),
        );
        let options = self.initial.plan_options();
        let planned = planning::plan_with(&mission, None, &options).map_err(|e| {
            FmuError::error(format!(
                "mission '{}' ({}) cannot be flown: {e}",
                mission.name(),
                source.display()
            ))
        })?;
        let eval = evaluate_at(
            &mission,
            &planned.trajectory,
            planned.altitudes_m.as_deref(),
        )
        .map_err(|e| {
            FmuError::error(format!(
                "mission '{}' ({}): its plan does not evaluate at its altitudes: {e}",
                mission.name(),
                source.display()
            ))
        })?;
        log.log(
            Category::Events,
            Status::Ok,
            &format!(
                "planned mission '{}': {}; true energy {:.3} J, {} slot(s) out of view",
                mission.name(),
                planned.summary,
                eval.energy_j,
                eval.slots_out_of_view
            ),
        );
        self.params = mission.params().clone();
        let bound = planner::energy_bound(&mission, self.initial.dynamics).ok();
        self.run = Some(Run {
            bound,
            mission,
            source,
            traj: planned.trajectory,
            eval,
            replans: 0,
            solve_s: planned.solve_s,
            moved: BTreeSet::new(),
            dynamics: self.initial.dynamics,
            altitudes_m: planned.altitudes_m,
        });
        Ok(())
    }

    pub(super) fn step(&mut self, tau_s: f64, log: &dyn Log) -> Result<StepReport, FmuError> {
        #[cfg(feature = "test-hooks")]
        if self.debug_panic == PANIC_IN_DO_STEP {
            panic!("injected panic in doStep (debug_inject_panic = {PANIC_IN_DO_STEP})");
        }
        let input = self.landmark_in_m;
        let Some(run) = self.run.as_mut() else {
            return Err(FmuError::error("doStep: the mission is not planned"));
        };
        match (input[0].is_nan(), input[1].is_nan()) {
            (true, true) => return Ok(StepReport::default()),
            (false, false) if input.iter().all(|v| v.is_finite()) => {}
            _ => {
                return Err(FmuError::error(format!(
                    "t = {} s: landmark input (`landmark_x_in_m`, `landmark_y_in_m`) = ({}, {}) m refused: set both to finite numbers (a move) or both to NaN (no move); the step was not taken",
                    Num(tau_s),
                    Num(input[0]),
                    Num(input[1])
                )))
            }
        }
        let slot_s = run.mission.params().slot_s;
        let n = run.mission.slots();
        // The input refers to the landmark the outputs report at τ (one rule for both, and for
        // LandmarkMover, which reads those outputs): see `current_window`.
        let current = slot_at(tau_s, slot_s, n);
        let Some(window) = current_window(&run.mission, tau_s) else {
            return Ok(StepReport::default());
        };
        let Some(w) = run.mission.schedule().landmarks.get(window).copied() else {
            return Ok(StepReport::default());
        };
        let planned = w.pos_m();
        if planner::geometry::distance(&input.into(), &planned.into()) <= 1e-6 {
            return Ok(StepReport::default());
        }
        // slots up to `from` are flown or committed (the UAV is on its way to q_from)
        let from = slot_at_committed(tau_s, slot_s, n);
        let has_later_slots = run
            .mission
            .schedule()
            .slot_landmark
            .get(from..)
            .is_some_and(|l| l.contains(&Some(window)));
        let what = format!(
            "t = {} s: landmark {window} (window ({}, {}] s) moved from ({}, {}) m to ({}, {}) m",
            Num(tau_s),
            Num(w.from_s),
            Num(w.to_s),
            Num(planned[0]),
            Num(planned[1]),
            Num(input[0]),
            Num(input[1])
        );
        let mv = LandmarkMove {
            tau_s,
            window,
            from,
            input,
            what,
        };
        let what = &mv.what;
        if !has_later_slots {
            // the window ended with the current slot: nothing is left to re-plan, but the
            // outputs report the moved landmark (and whether the current slot still sees it)
            let mission =
                planning::moved_mission(&run.mission, window, input).map_err(|m| mv.reject(m))?;
            run.take_moved(mission, window).map_err(|m| mv.reject(m))?;
            log.log(
                Category::Events,
                Status::Ok,
                &format!(
                    "{what}; its window has no slot left (slot {current}, which ended at t = {} s, was its last): nothing re-planned",
                    Num(current as f64 * slot_s)
                ),
            );
            let (count, _) = run.out_of_view_from(current);
            let seen = if count > 0 {
                format!("; slot {current} does not see it")
            } else {
                String::new()
            };
            return Ok(run.warn(
                format!(
                    "{what}: the move came when its window had no slot left (slot {current}, which ended at t = {} s, was its last), so nothing was re-planned{seen}",
                    Num(current as f64 * slot_s)
                ),
                log,
            ));
        }
        log.log(
            Category::Events,
            Status::Ok,
            &format!("{what}; re-planning slots {}..{n}", from + 1),
        );
        replan_after_move(run, &mv, log)
    }
}

/// A landmark move taken from the inputs of a doStep: which window, from which slot on it may
/// be re-planned, and the log text describing it.
struct LandmarkMove {
    /// Mission time of the doStep.
    tau_s: f64,
    /// The moved landmark's window (0-based).
    window: usize,
    /// Slots up to this one are flown or committed.
    from: usize,
    /// The new landmark position.
    input: [f64; 2],
    /// What moved, for messages.
    what: String,
}

impl LandmarkMove {
    /// The error refusing this move.
    fn reject(&self, message: String) -> FmuError {
        FmuError::error(format!(
            "t = {} s: landmark input ({}, {}) m rejected: {message}",
            Num(self.tau_s),
            Num(self.input[0]),
            Num(self.input[1])
        ))
    }
}

/// Re-plans the rest of the horizon after a landmark move and reports the outcome: the new
/// plan (with a warning when slots are out of view), or the previous plan kept on a planner
/// failure (a warning); a refused move is an error. A free-altitude plan is re-planned with an
/// altitude per slot from the altitude flown at the splice
/// ([`planning::replan_with_altitudes`]).
fn replan_after_move(
    run: &mut Run,
    mv: &LandmarkMove,
    log: &dyn Log,
) -> Result<StepReport, FmuError> {
    let (what, window, from) = (&mv.what, mv.window, mv.from);
    match planning::replan_with_altitudes(
        &run.mission,
        &run.traj,
        run.altitudes_m.as_deref(),
        from,
        window,
        mv.input,
        &planning::ReplanOptions {
            dynamics: run.dynamics,
            ..Default::default()
        },
    ) {
        Ok(re) => {
            run.eval = evaluate_at(&re.mission, &re.trajectory, re.altitudes_m.as_deref())
                .map_err(|m| mv.reject(m))?;
            run.moved.insert(window);
            run.bound = planner::energy_bound(&re.mission, run.dynamics).ok();
            run.mission = re.mission;
            run.traj = re.trajectory;
            run.altitudes_m = re.altitudes_m;
            run.replans += 1;
            run.solve_s = re.solve_s;
            log.log(
                Category::Events,
                Status::Ok,
                &format!("re-planned: {}", re.summary),
            );
            let (count, slots) = run.out_of_view_from(from + 1);
            if count == 0 {
                return Ok(StepReport::default());
            }
            let why = if re.window_dropped {
                format!(
                    "landmark {window} cannot be brought into view in any slot of its window that is left, so the rest of the horizon was re-planned without it"
                )
            } else if re.transition_slots > 0 {
                format!(
                    "the UAV needs {} transition slot(s) to bring landmark {window} into view",
                    re.transition_slots
                )
            } else {
                "the new plan does not keep every landmark in view".to_string()
            };
            Ok(run.warn(
                format!(
                    "{what}: {why}; {count} re-planned slot(s) are out of view: {slots} (output `slots_out_of_view` = {})",
                    run.eval.slots_out_of_view
                ),
                log,
            ))
        }
        Err(ReplanError::Mission(message)) => Err(mv.reject(message)),
        Err(ReplanError::Planner {
            mission,
            attempts,
            solve_s,
            ..
        }) => {
            run.take_moved(*mission, window).map_err(|m| mv.reject(m))?;
            run.solve_s = solve_s;
            let (count, slots) = run.out_of_view_from(from + 1);
            let seen = if count > 0 {
                format!(
                    "; {count} slot(s) after the current one are out of view: {slots} (output `slots_out_of_view` = {})",
                    run.eval.slots_out_of_view
                )
            } else {
                String::new()
            };
            Ok(run.warn(
                format!(
                    "{what}: the re-plan failed, so the previous plan is kept ({} planner call(s) in {solve_s:.3} s: {}){seen}",
                    attempts.len(),
                    planning::describe_attempts(&attempts)
                ),
                log,
            ))
        }
    }
}
