//! The model cores behind the C API: the planner model (`CellsarPlanner`) and a small partner
//! model for coupled co-simulation (`LandmarkMover`). A core knows nothing about FMI call
//! sequences, pointers or versions: [`crate::instance`] does that and calls the core with
//! validated arguments. Cores are plain data (`Clone`, serde), so an FMU state is a copy of one.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use planner::geometry::sensing_centre_m;
use planner::{evaluate, Evaluation, Mission, MissionFile, Params, Trajectory};
use serde::{Deserialize, Serialize};

use crate::planning::{self, ReplanError};
use crate::table::{mover_vr, planner_vr as pv, Category, Var, VarType, MOVER_VARS, PLANNER_VARS};

/// FMI status codes (the same numbers in FMI 2 and FMI 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    /// `OK`.
    Ok = 0,
    /// `Warning`.
    Warning = 1,
    /// `Discard`.
    Discard = 2,
    /// `Error`.
    Error = 3,
    /// `Fatal`.
    Fatal = 4,
}

/// An error (or warning) reported to the importer: a status and a message for the log.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct FmuError {
    /// The status the entry point returns.
    pub status: Status,
    /// The message logged.
    pub message: String,
}

impl FmuError {
    /// An `Error` with a message.
    pub fn error(message: impl Into<String>) -> Self {
        Self {
            status: Status::Error,
            message: message.into(),
        }
    }
}

/// Where a core sends log messages.
pub trait Log {
    /// Logs `message` under `category` with `status`.
    fn log(&self, category: Category, status: Status, message: &str);
}

/// Value of [`crate::table::planner_vr::DEBUG_INJECT_PANIC`] that makes the next doStep panic.
pub const PANIC_IN_DO_STEP: i32 = 1;
/// Value of [`crate::table::planner_vr::DEBUG_INJECT_PANIC`] that makes the next get panic.
pub const PANIC_IN_GET: i32 = 2;

/// The file name of the default mission inside the FMU's `resources/` directory.
pub const DEFAULT_MISSION_FILE: &str = "default_mission.toml";

/// The default mission shipped in the FMU's `resources/`.
pub const DEFAULT_MISSION_TOML: &str = include_str!("../resources/default_mission.toml");

/// Which model an instance runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ModelKind {
    /// The planner FMU.
    Planner,
    /// The landmark-mover partner FMU.
    Mover,
}

/// Static description of a model: what the model description and packaging need.
#[derive(Debug)]
pub struct ModelInfo {
    /// Which model.
    pub kind: ModelKind,
    /// `modelName` and `modelIdentifier` (the shared library's base name).
    pub identifier: &'static str,
    /// Description.
    pub description: &'static str,
    /// The variable table.
    pub vars: &'static [Var],
    /// Default experiment: start, stop, step (s).
    pub default_experiment: (f64, f64, f64),
    /// Files of `resources/`: name and content.
    pub resources: &'static [(&'static str, &'static str)],
}

/// The planner model.
pub const PLANNER_INFO: ModelInfo = ModelInfo {
    kind: ModelKind::Planner,
    identifier: "CellsarPlanner",
    description: "Least-energy UAV trajectory for cellular-assisted bistatic SAR (cellsar planner): plans the whole horizon at initialisation and re-plans the rest of it when a landmark input moves",
    vars: PLANNER_VARS,
    default_experiment: (0.0, 300.0, 0.5),
    resources: &[(DEFAULT_MISSION_FILE, DEFAULT_MISSION_TOML)],
};

/// The landmark-mover model.
pub const MOVER_INFO: ModelInfo = ModelInfo {
    kind: ModelKind::Mover,
    identifier: "LandmarkMover",
    description: "Partner FMU for coupled co-simulation with CellsarPlanner: moves the current landmark at a given time",
    vars: MOVER_VARS,
    default_experiment: (0.0, 300.0, 0.5),
    resources: &[],
};

/// All models this library implements.
pub const MODELS: [&ModelInfo; 2] = [&PLANNER_INFO, &MOVER_INFO];

/// The FMI version of an FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FmiVersion {
    /// FMI 2.0.
    Fmi2,
    /// FMI 3.0.
    Fmi3,
}

impl FmiVersion {
    /// "2.0" or "3.0".
    pub fn as_str(self) -> &'static str {
        match self {
            FmiVersion::Fmi2 => "2.0",
            FmiVersion::Fmi3 => "3.0",
        }
    }
}

/// The GUID (FMI 2) or instantiation token (FMI 3) of a model: a 128-bit FNV-1a hash of the crate
/// version, the FMI version and every row of the variable table, written as a UUID. It changes
/// whenever the interface changes; the shared library and the packaged model description compute
/// it with the same code.
pub fn guid(info: &ModelInfo, version: FmiVersion) -> String {
    let mut text = format!(
        "{}|{}|{}|",
        env!("CARGO_PKG_VERSION"),
        info.identifier,
        version.as_str()
    );
    for v in info.vars {
        text.push_str(&format!(
            "{}:{}:{:?}:{:?}:{:?}:{}:{:?};",
            v.name, v.vr, v.ty, v.causality, v.variability, v.len, v.unit
        ));
    }
    const OFFSET: u128 = 0x6c62272e07bb014262b821756295c58d;
    const PRIME: u128 = 0x0000000001000000000000000000013B;
    let mut h = OFFSET;
    for b in text.bytes() {
        h ^= u128::from(b);
        h = h.wrapping_mul(PRIME);
    }
    let x = format!("{h:032x}");
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &x[0..8],
        &x[8..12],
        &x[12..16],
        &x[16..20],
        &x[20..32]
    )
}

/// What a step did, for the FMI layer.
#[derive(Debug, Clone, Default)]
pub struct StepReport {
    /// A warning to return (the step itself succeeded).
    pub warning: Option<String>,
}

/// A model core.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum Core {
    /// The planner.
    Planner(Box<PlannerCore>),
    /// The landmark mover.
    Mover(MoverCore),
}

impl Core {
    /// A fresh core with every variable at its start value.
    pub fn new(kind: ModelKind) -> Self {
        match kind {
            ModelKind::Planner => Core::Planner(Box::default()),
            ModelKind::Mover => Core::Mover(MoverCore::default()),
        }
    }

    /// The model's static description.
    pub fn info(&self) -> &'static ModelInfo {
        match self {
            Core::Planner(_) => &PLANNER_INFO,
            Core::Mover(_) => &MOVER_INFO,
        }
    }

    /// Reads a Real element at mission time `tau_s`.
    pub fn get_real(&self, var: &Var, elem: usize, tau_s: f64) -> Result<f64, FmuError> {
        match self {
            Core::Planner(c) => c.get_real(var, elem, tau_s),
            Core::Mover(c) => c.get_real(var, tau_s),
        }
    }

    /// Sets a Real element.
    pub fn set_real(&mut self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.set_real(var, elem, value),
            Core::Mover(c) => c.set_real(var, value),
        }
    }

    /// Reads an Integer.
    pub fn get_int(&self, var: &Var) -> Result<i32, FmuError> {
        match (self, var.vr) {
            (Core::Planner(c), pv::REPLAN_COUNT) => Ok(c
                .run
                .as_ref()
                .map_or(0, |r| i32::try_from(r.replans).unwrap_or(i32::MAX))),
            _ => Err(unknown(var)),
        }
    }

    /// Sets an Integer by value reference (also the hidden debug variable).
    pub fn set_int(&mut self, vr: u32, value: i32) -> Result<(), FmuError> {
        match (self, vr) {
            (Core::Planner(c), pv::DEBUG_INJECT_PANIC) => {
                c.debug_panic = value;
                Ok(())
            }
            _ => Err(FmuError::error(format!(
                "value reference {vr} is not a settable Integer"
            ))),
        }
    }

    /// Reads a Boolean at mission time `tau_s`.
    pub fn get_bool(&self, var: &Var, tau_s: f64) -> Result<bool, FmuError> {
        match self {
            Core::Planner(c) => c.get_bool(var, tau_s),
            Core::Mover(c) => c.get_bool(var, tau_s),
        }
    }

    /// Reads a String.
    pub fn get_string(&self, var: &Var) -> Result<String, FmuError> {
        match (self, var.vr) {
            (Core::Planner(c), pv::MISSION_FILE) => Ok(c.mission_file.clone()),
            _ => Err(unknown(var)),
        }
    }

    /// Sets a String.
    pub fn set_string(&mut self, var: &Var, value: &str) -> Result<(), FmuError> {
        match (self, var.vr) {
            (Core::Planner(c), pv::MISSION_FILE) => {
                c.mission_file = value.to_string();
                c.run = None;
                Ok(())
            }
            _ => Err(unknown(var)),
        }
    }

    /// True when the outputs can be computed (the plan exists).
    pub fn is_ready(&self) -> bool {
        match self {
            Core::Planner(c) => c.run.is_some(),
            Core::Mover(_) => true,
        }
    }

    /// Computes what initialisation needs (loads and plans the mission).
    pub fn initialize(&mut self, resources: Option<&Path>, log: &dyn Log) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.initialize(resources, log),
            Core::Mover(_) => Ok(()),
        }
    }

    /// The mission horizon, s, once known (a step past it is refused).
    pub fn horizon_s(&self) -> Option<f64> {
        match self {
            Core::Planner(c) => c.run.as_ref().map(|r| r.mission.params().horizon_s),
            Core::Mover(_) => None,
        }
    }

    /// Runs the step from mission time `tau_s` to `tau_s + h_s`, with the inputs as set now.
    pub fn step(&mut self, tau_s: f64, h_s: f64, log: &dyn Log) -> Result<StepReport, FmuError> {
        match self {
            Core::Planner(c) => c.step(tau_s, log),
            Core::Mover(c) => {
                c.step(tau_s + h_s);
                Ok(StepReport::default())
            }
        }
    }

    /// Called before a get: panics when the test hook asks for it.
    pub fn before_get(&self) {
        if let Core::Planner(c) = self {
            if c.debug_panic == PANIC_IN_GET {
                panic!("injected panic in a get call (debug_inject_panic = {PANIC_IN_GET})");
            }
        }
    }
}

fn unknown(var: &Var) -> FmuError {
    FmuError::error(format!(
        "variable `{}` (value reference {}) cannot be accessed this way",
        var.name, var.vr
    ))
}

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
}

/// The planner model's state.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlannerCore {
    /// Parameter values as set through FMI (SPEC defaults at start); after initialisation the
    /// values in effect.
    params: Params,
    /// Names of the parameters set through FMI to a value other than their start value: they
    /// override the mission file.
    params_set: BTreeSet<String>,
    /// `mission_file`.
    mission_file: String,
    /// `landmark_x_in_m`, `landmark_y_in_m`.
    landmark_in_m: [f64; 2],
    /// Test hook (hidden variable).
    debug_panic: i32,
    /// The plan, after initialisation.
    run: Option<Run>,
}

impl Default for PlannerCore {
    fn default() -> Self {
        Self {
            params: Params::default(),
            params_set: BTreeSet::new(),
            mission_file: DEFAULT_MISSION_FILE.to_string(),
            landmark_in_m: [f64::NAN, f64::NAN],
            debug_panic: 0,
            run: None,
        }
    }
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
}

/// The slot (1-based) whose values hold at mission time `tau_s`: slot t covers ((t−1)δ, tδ]; at
/// τ ≤ 0 it is slot 1, past the horizon the last slot.
pub fn slot_at(tau_s: f64, slot_s: f64, slots: usize) -> usize {
    let x = (tau_s / slot_s - 1e-9).ceil();
    if x.is_nan() || x < 1.0 {
        1
    } else {
        (x as usize).clamp(1, slots.max(1))
    }
}

impl Run {
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
            };
        };
        let pos_m = self.traj.position_at(tau_s);
        let before_j = if k >= 2 {
            self.eval.slots[k - 2].energy_j
        } else {
            0.0
        };
        let into_slot_s = (tau_s - (k - 1) as f64 * p.slot_s).clamp(0.0, p.slot_s);
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
        }
    }
}

impl PlannerCore {
    fn get_real(&self, var: &Var, elem: usize, tau_s: f64) -> Result<f64, FmuError> {
        match var.vr {
            pv::START_M => return Ok(self.params.start_m[elem.min(1)]),
            pv::BS_M => return Ok(self.params.bs_m[elem.min(1)]),
            pv::LANDMARK_X_IN => return Ok(self.landmark_in_m[0]),
            pv::LANDMARK_Y_IN => return Ok(self.landmark_in_m[1]),
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
        if var.vr == pv::SOLVE_TIME {
            return Ok(run.solve_s);
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
            _ => return Err(unknown(var)),
        })
    }

    fn set_real(&mut self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        match var.vr {
            pv::LANDMARK_X_IN => {
                self.landmark_in_m[0] = value;
                return Ok(());
            }
            pv::LANDMARK_Y_IN => {
                self.landmark_in_m[1] = value;
                return Ok(());
            }
            _ => {}
        }
        if var.causality != crate::table::Causality::Parameter || var.ty != VarType::Real {
            return Err(unknown(var));
        }
        if !value.is_finite() {
            return Err(FmuError::error(format!(
                "parameter `{}` = {value}: must be a finite number",
                crate::table::fmi2_name(var, elem)
            )));
        }
        match var.vr {
            pv::START_M => self.params.start_m[elem.min(1)] = value,
            pv::BS_M => self.params.bs_m[elem.min(1)] = value,
            _ => self
                .params
                .set_by_name(var.name, value)
                .map_err(|e| FmuError::error(e.to_string()))?,
        }
        // A parameter overrides the mission file only while it differs from its start value, so
        // importers that write every start value back do not undo the file.
        let d = Params::default();
        let at_start = match var.vr {
            pv::START_M => self.params.start_m == d.start_m,
            pv::BS_M => self.params.bs_m == d.bs_m,
            _ => self.params.get_by_name(var.name) == d.get_by_name(var.name),
        };
        if at_start {
            self.params_set.remove(var.name);
        } else {
            self.params_set.insert(var.name.to_string());
        }
        self.run = None;
        Ok(())
    }

    fn get_bool(&self, var: &Var, tau_s: f64) -> Result<bool, FmuError> {
        if var.vr != pv::IN_VIEW {
            return Err(unknown(var));
        }
        let run = self.run.as_ref().ok_or_else(|| {
            FmuError::error("output `in_view` is not available before the mission is planned")
        })?;
        Ok(run.sample(tau_s).in_view)
    }

    /// Finds the mission file: absolute as given; relative in `resources`, then in the working
    /// directory.
    fn mission_path(&self, resources: Option<&Path>) -> Result<PathBuf, FmuError> {
        let name = self.mission_file.trim();
        if name.is_empty() {
            return Err(FmuError::error(
                "parameter `mission_file` is empty: name a mission file (TOML or JSON)",
            ));
        }
        let given = Path::new(name);
        if given.is_absolute() {
            return Ok(given.to_path_buf());
        }
        let mut tried = Vec::new();
        match resources {
            Some(dir) => {
                let p = dir.join(given);
                if p.is_file() {
                    return Ok(p);
                }
                tried.push(p.display().to_string());
            }
            None => tried.push(
                "<resources>/ (the FMU was instantiated without a usable resource location)"
                    .to_string(),
            ),
        }
        if given.is_file() {
            return Ok(given.to_path_buf());
        }
        tried.push(format!("{} (working directory)", given.display()));
        Err(FmuError::error(format!(
            "mission_file `{name}` not found; looked in: {}",
            tried.join(", ")
        )))
    }

    /// Reads the mission file and applies the parameters set through FMI on top of its `[params]`.
    fn resolve_mission(&self, resources: Option<&Path>) -> Result<(Mission, PathBuf), FmuError> {
        let path = self.mission_path(resources)?;
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(&path)
            .map_err(|e| FmuError::error(format!("cannot read mission file {shown}: {e}")))?;
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let mut file = if is_json {
            MissionFile::from_json_str(&text)
        } else {
            MissionFile::from_toml_str(&text)
        }
        .map_err(|e| FmuError::error(format!("mission file {shown}: {e}")))?;
        if !self.params_set.is_empty() {
            let mut map = serde_json::to_value(&file.params)
                .map_err(|e| FmuError::error(format!("mission file {shown}: {e}")))?;
            if let Some(obj) = map.as_object_mut() {
                for name in &self.params_set {
                    let value = match name.as_str() {
                        "start_m" => serde_json::json!(self.params.start_m),
                        "bs_m" => serde_json::json!(self.params.bs_m),
                        other => serde_json::json!(self.params.get_by_name(other)),
                    };
                    obj.insert(name.clone(), value);
                }
            }
            file.params = serde_json::from_value(map)
                .map_err(|e| FmuError::error(format!("parameters set through FMI: {e}")))?;
        }
        let mission = Mission::from_file_struct(&file)
            .map_err(|e| FmuError::error(format!("mission {shown}: {e}")))?;
        Ok((mission, path))
    }

    fn initialize(&mut self, resources: Option<&Path>, log: &dyn Log) -> Result<(), FmuError> {
        if self.run.is_some() {
            return Ok(());
        }
        let (mission, source) = self.resolve_mission(resources)?;
        log.log(
            Category::Events,
            Status::Ok,
            &format!(
                "mission '{}' from {}: {} slots of {} s, {} landmark windows; planning the whole horizon",
                mission.name(),
                source.display(),
                mission.slots(),
                mission.params().slot_s,
                mission.schedule().landmarks.len()
            ),
        );
        let planned = planning::plan(&mission, None).map_err(|e| {
            FmuError::error(format!(
                "mission '{}' ({}) cannot be flown: {e}",
                mission.name(),
                source.display()
            ))
        })?;
        let eval = evaluate(&mission, &planned.trajectory);
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
        self.run = Some(Run {
            mission,
            source,
            traj: planned.trajectory,
            eval,
            replans: 0,
            solve_s: planned.solve_s,
            moved: BTreeSet::new(),
        });
        Ok(())
    }

    fn step(&mut self, tau_s: f64, log: &dyn Log) -> Result<StepReport, FmuError> {
        if self.debug_panic == PANIC_IN_DO_STEP {
            panic!("injected panic in doStep (debug_inject_panic = {PANIC_IN_DO_STEP})");
        }
        let input = self.landmark_in_m;
        let Some(run) = self.run.as_mut() else {
            return Err(FmuError::error("doStep: the mission is not planned"));
        };
        if !(input[0].is_finite() && input[1].is_finite()) {
            return Ok(StepReport::default());
        }
        let p = run.mission.params();
        let slot_s = p.slot_s;
        let n = run.mission.slots();
        // slots up to `from` are flown or committed (the UAV is on its way to q_from); the
        // input refers to the window of the next slot to fly, from + 1
        let from = slot_at_committed(tau_s, slot_s, n);
        if from >= n {
            return Ok(StepReport::default());
        }
        let sched = run.mission.schedule();
        let Some(window) = sched.slot_landmark[from] else {
            return Ok(StepReport::default());
        };
        let landmark = |w: usize| sched.landmarks.get(w).map(|l| l.pos_m());
        let Some(planned) = landmark(window) else {
            return Ok(StepReport::default());
        };
        let same = |a: [f64; 2], b: [f64; 2]| planner::geometry::v2::dist(a, b) <= 1e-6;
        if same(input, planned) {
            return Ok(StepReport::default());
        }
        // At a window boundary the outputs still show the previous slot's landmark: an input
        // equal to it (and not moved by an input) is that output fed back, not a move.
        let shown = slot_at(tau_s, slot_s, n);
        if let Some(Some(w)) = sched.slot_landmark.get(shown - 1).copied() {
            if w != window && landmark(w).is_some_and(|l| same(input, l)) && !run.moved.contains(&w)
            {
                return Ok(StepReport::default());
            }
        }
        log.log(
            Category::Events,
            Status::Ok,
            &format!(
                "t = {tau_s} s: landmark {window} moved from ({}, {}) m to ({}, {}) m; re-planning slots {}..{n}",
                planned[0],
                planned[1],
                input[0],
                input[1],
                from + 1
            ),
        );
        match planning::replan(
            &run.mission,
            &run.traj,
            from,
            window,
            input,
            &planning::ReplanOptions::default(),
        ) {
            Ok(re) => {
                run.moved.insert(window);
                run.eval = evaluate(&re.mission, &re.trajectory);
                run.mission = re.mission;
                run.traj = re.trajectory;
                run.replans += 1;
                run.solve_s = re.solve_s;
                log.log(
                    Category::Events,
                    Status::Ok,
                    &format!("re-planned: {}", re.summary),
                );
                Ok(StepReport::default())
            }
            Err(ReplanError::Mission(message)) => Err(FmuError::error(format!(
                "t = {tau_s} s: landmark input ({}, {}) m rejected: {message}",
                input[0], input[1]
            ))),
            Err(ReplanError::Planner { mission, message }) => {
                run.moved.insert(window);
                run.eval = evaluate(&mission, &run.traj);
                run.mission = *mission;
                let warning = format!(
                    "t = {tau_s} s: re-plan for landmark {window} at ({}, {}) m failed, keeping the previous plan: {message}",
                    input[0], input[1]
                );
                log.log(Category::Warning, Status::Warning, &warning);
                Ok(StepReport {
                    warning: Some(warning),
                })
            }
        }
    }
}

/// Number of slots flown or committed at mission time `tau_s`: ⌈τ/δ⌉ (0 at the start).
fn slot_at_committed(tau_s: f64, slot_s: f64, slots: usize) -> usize {
    let x = (tau_s / slot_s - 1e-9).ceil();
    if x.is_nan() || x < 0.0 {
        0
    } else {
        (x as usize).min(slots)
    }
}

/// The landmark mover's state.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MoverCore {
    move_at_s: f64,
    offset_m: [f64; 2],
    hold_s: f64,
    input_m: [f64; 2],
    /// The moved landmark and when it was latched.
    latched: Option<([f64; 2], f64)>,
}

impl Default for MoverCore {
    fn default() -> Self {
        Self {
            move_at_s: 60.0,
            offset_m: [100.0, 0.0],
            hold_s: 0.0,
            input_m: [0.0, 0.0],
            latched: None,
        }
    }
}

impl MoverCore {
    fn output(&self, tau_s: f64) -> Option<[f64; 2]> {
        let (pos, at) = self.latched?;
        (self.hold_s <= 0.0 || tau_s < at + self.hold_s - 1e-9).then_some(pos)
    }

    fn get_real(&self, var: &Var, tau_s: f64) -> Result<f64, FmuError> {
        Ok(match var.vr {
            mover_vr::MOVE_AT => self.move_at_s,
            mover_vr::OFFSET_X => self.offset_m[0],
            mover_vr::OFFSET_Y => self.offset_m[1],
            mover_vr::HOLD => self.hold_s,
            mover_vr::IN_X => self.input_m[0],
            mover_vr::IN_Y => self.input_m[1],
            mover_vr::OUT_X => self.output(tau_s).map_or(f64::NAN, |p| p[0]),
            mover_vr::OUT_Y => self.output(tau_s).map_or(f64::NAN, |p| p[1]),
            _ => return Err(unknown(var)),
        })
    }

    fn set_real(&mut self, var: &Var, value: f64) -> Result<(), FmuError> {
        let param = |v: f64| {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(FmuError::error(format!(
                    "parameter `{}` = {v}: must be a finite number",
                    var.name
                )))
            }
        };
        match var.vr {
            mover_vr::MOVE_AT => self.move_at_s = param(value)?,
            mover_vr::OFFSET_X => self.offset_m[0] = param(value)?,
            mover_vr::OFFSET_Y => self.offset_m[1] = param(value)?,
            mover_vr::HOLD => self.hold_s = param(value)?,
            mover_vr::IN_X => self.input_m[0] = value,
            mover_vr::IN_Y => self.input_m[1] = value,
            _ => return Err(unknown(var)),
        }
        Ok(())
    }

    fn get_bool(&self, var: &Var, tau_s: f64) -> Result<bool, FmuError> {
        match var.vr {
            mover_vr::MOVED => Ok(self.output(tau_s).is_some()),
            _ => Err(unknown(var)),
        }
    }

    /// At the end of a step: latch the moved landmark once the move time is reached.
    fn step(&mut self, end_s: f64) {
        if self.latched.is_none()
            && end_s >= self.move_at_s - 1e-9
            && self.input_m.iter().all(|v| v.is_finite())
        {
            self.latched = Some((
                [
                    self.input_m[0] + self.offset_m[0],
                    self.input_m[1] + self.offset_m[1],
                ],
                end_s,
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slot_convention() {
        assert_eq!(slot_at(0.0, 0.5, 600), 1);
        assert_eq!(slot_at(0.25, 0.5, 600), 1);
        assert_eq!(slot_at(0.5, 0.5, 600), 1);
        assert_eq!(slot_at(0.5000001, 0.5, 600), 2);
        assert_eq!(slot_at(10.0, 0.5, 600), 20);
        assert_eq!(slot_at(1e9, 0.5, 600), 600);
        assert_eq!(slot_at_committed(0.0, 0.5, 600), 0);
        assert_eq!(slot_at_committed(0.1, 0.5, 600), 1);
        assert_eq!(slot_at_committed(10.0, 0.5, 600), 20);
        assert_eq!(slot_at_committed(1e9, 0.5, 600), 600);
    }

    #[test]
    fn guid_is_stable_and_distinct() {
        let a = guid(&PLANNER_INFO, FmiVersion::Fmi2);
        assert_eq!(a, guid(&PLANNER_INFO, FmiVersion::Fmi2));
        assert_ne!(a, guid(&PLANNER_INFO, FmiVersion::Fmi3));
        assert_ne!(a, guid(&MOVER_INFO, FmiVersion::Fmi2));
        assert_eq!(a.len(), 38);
    }

    #[test]
    fn start_values_are_spec_defaults() {
        let core = Core::new(ModelKind::Planner);
        let d = Params::default();
        for v in PLANNER_VARS
            .iter()
            .filter(|v| v.causality == crate::table::Causality::Parameter && v.ty == VarType::Real)
        {
            for i in 0..v.len {
                let got = core.get_real(v, i, 0.0).unwrap();
                let want = match v.name {
                    "start_m" => d.start_m[i],
                    "bs_m" => d.bs_m[i],
                    n => d.get_by_name(n).unwrap(),
                };
                assert_eq!(got, want, "{}", v.name);
            }
        }
    }

    fn run_of(pos_m: Vec<[f64; 2]>) -> Run {
        let mut p = Params::default();
        p.horizon_s = pos_m.len() as f64 * p.slot_s;
        let mission = Mission::new(
            "prop",
            p.clone(),
            &planner::LandmarksSpec {
                points: Some(vec![planner::LandmarkWindow {
                    x_m: 0.0,
                    y_m: 0.0,
                    from_s: 0.0,
                    to_s: p.horizon_s,
                }]),
                ..Default::default()
            },
        )
        .unwrap();
        let traj = Trajectory {
            slot_s: p.slot_s,
            start_m: p.start_m,
            pos_m,
        };
        Run {
            eval: evaluate(&mission, &traj),
            mission,
            source: PathBuf::new(),
            traj,
            replans: 0,
            solve_s: 0.0,
            moved: BTreeSet::new(),
        }
    }

    proptest::proptest! {
        /// Outputs between slot ends: position linear, energy = previous slots + power × time in
        /// the slot (non-decreasing, continuous), slot values at slot ends equal `evaluate`.
        #[test]
        fn samples_interpolate_and_integrate(
            steps in proptest::collection::vec((-12.0f64..12.0, -12.0f64..12.0), 1..12),
            frac in 0.0f64..1.0,
        ) {
            let mut q = Params::default().start_m;
            let pos: Vec<[f64; 2]> = steps.iter().map(|(dx, dy)| { q = [q[0] + dx, q[1] + dy]; q }).collect();
            let run = run_of(pos);
            let d = run.mission.params().slot_s;
            let n = run.eval.slots.len();
            let mut last_energy = 0.0;
            for t in 1..=n {
                let at_end = run.sample(t as f64 * d);
                let s = &run.eval.slots[t - 1];
                proptest::prop_assert_eq!(at_end.pos_m, s.pos_m);
                proptest::prop_assert!((at_end.energy_j - s.energy_j).abs() <= 1e-9 * s.energy_j.max(1.0));
                proptest::prop_assert_eq!(at_end.in_view, s.in_view);
                let tau = (t as f64 - 1.0 + frac) * d;
                let mid = run.sample(tau);
                let a = run.traj.q(t - 1);
                let b = run.traj.q(t);
                for i in 0..2 {
                    proptest::prop_assert!((mid.pos_m[i] - (a[i] + frac * (b[i] - a[i]))).abs() < 1e-9);
                }
                proptest::prop_assert!(mid.energy_j + 1e-9 >= last_energy);
                proptest::prop_assert!(mid.energy_j <= at_end.energy_j + 1e-9);
                proptest::prop_assert_eq!(mid.power_w, s.power_w);
                let off = planner::geometry::v2::dist(mid.centre_m, mid.pos_m);
                proptest::prop_assert!((off - run.mission.params().centre_offset_m()).abs() < 1e-9);
                last_energy = at_end.energy_j;
            }
        }
    }

    #[test]
    fn default_mission_resource_parses() {
        let f = MissionFile::from_toml_str(DEFAULT_MISSION_TOML).unwrap();
        let m = Mission::from_file_struct(&f).unwrap();
        assert_eq!(m.slots(), 600);
        assert_eq!(m.target_m(21), Some([0.0, 30.0]));
    }
}
