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

/// A number in a message: plain decimal when 1e-4 ≤ |x| < 1e15 (and 0), scientific notation
/// otherwise (`-1e308`, `1e-12` instead of 309 or 14 digits), `NaN`, `inf` and `-inf` as Rust
/// writes them. A precision (`{:.3}`) applies to both forms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        let plain = x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&x.abs());
        match (plain, f.precision()) {
            (true, None) => write!(f, "{x}"),
            (true, Some(p)) => write!(f, "{x:.p$}"),
            (false, None) => write!(f, "{x:e}"),
            (false, Some(p)) => write!(f, "{x:.p$e}"),
        }
    }
}

/// Largest number of slots (`horizon_s` / `slot_s`) the planner FMU accepts. Initialisation
/// plans the whole horizon within `ExitInitializationMode`, and the planner's time grows faster
/// than linearly with the slot count (fmu/BENCHMARKS.md, "Initialisation time against the
/// number of slots"), so the FMU refuses missions above this size with an error that names
/// both parameters, instead of not returning for minutes. The planner's own limit
/// (`planner::params::MAX_SLOTS`) is higher.
pub const MAX_FMU_SLOTS: usize = 20_000;

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
pub const DEFAULT_MISSION_TOML: &str = include_str!("../../missions/default-30m.toml");

/// Largest mission file the FMU reads (16 MiB): a larger file (or a device such as `/dev/zero`)
/// is refused with an error naming it instead of exhausting the importer's memory.
pub const MAX_MISSION_FILE_BYTES: u64 = 16 * 1024 * 1024;

/// Reads a mission file as UTF-8 text, at most [`MAX_MISSION_FILE_BYTES`]; errors name the file.
pub fn read_mission_text(path: &Path) -> Result<String, FmuError> {
    use std::io::Read as _;
    let shown = path.display();
    let too_large = || {
        FmuError::error(format!(
            "mission file {shown} is larger than the limit of {MAX_MISSION_FILE_BYTES} bytes"
        ))
    };
    let cannot =
        |e: std::io::Error| FmuError::error(format!("cannot read mission file {shown}: {e}"));
    let file = std::fs::File::open(path).map_err(cannot)?;
    if file.metadata().map_err(cannot)?.len() > MAX_MISSION_FILE_BYTES {
        return Err(too_large());
    }
    // devices and growing files report a wrong length: read one byte past the limit to tell
    let mut bytes = Vec::new();
    file.take(MAX_MISSION_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_MISSION_FILE_BYTES {
        return Err(too_large());
    }
    String::from_utf8(bytes).map_err(|e| {
        FmuError::error(format!(
            "cannot read mission file {shown}: not UTF-8 text ({e})"
        ))
    })
}

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

    /// Checks that a Real element may be set to `value`, without setting it (multi-value sets
    /// check every value first, so a refused set changes nothing).
    pub fn check_real(&self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.check_real(var, elem, value),
            Core::Mover(c) => c.check_real(var, value),
        }
    }

    /// Sets a Real element (after [`Core::check_real`]; it checks again).
    pub fn set_real(&mut self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.set_real(var, elem, value),
            Core::Mover(c) => c.set_real(var, value),
        }
    }

    /// Reads an Integer.
    pub fn get_int(&self, var: &Var) -> Result<i32, FmuError> {
        let count = |n: usize| i32::try_from(n).unwrap_or(i32::MAX);
        match (self, var.vr) {
            (Core::Planner(c), pv::REPLAN_COUNT) => Ok(c
                .run
                .as_ref()
                .map_or(0, |r| i32::try_from(r.replans).unwrap_or(i32::MAX))),
            (Core::Planner(c), pv::SLOTS_OUT_OF_VIEW) => Ok(c
                .run
                .as_ref()
                .map_or(0, |r| count(r.eval.slots_out_of_view))),
            _ => Err(unknown(var)),
        }
    }

    /// Checks that an Integer may be set by value reference, without setting it.
    pub fn check_int(&self, vr: u32) -> Result<(), FmuError> {
        match (self, vr) {
            (Core::Planner(_), pv::DEBUG_INJECT_PANIC) => Ok(()),
            _ => Err(FmuError::error(format!(
                "value reference {vr} is not a settable Integer"
            ))),
        }
    }

    /// Sets an Integer by value reference (also the hidden debug variable).
    pub fn set_int(&mut self, vr: u32, value: i32) -> Result<(), FmuError> {
        self.check_int(vr)?;
        if let Core::Planner(c) = self {
            c.debug_panic = value;
        }
        Ok(())
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

    /// Checks that a String may be set, without setting it.
    pub fn check_string(&self, var: &Var) -> Result<(), FmuError> {
        match (self, var.vr) {
            (Core::Planner(_), pv::MISSION_FILE) => Ok(()),
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
                c.step(tau_s + h_s)?;
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
    /// Parameter values as set through FMI (the default parameters at start); after initialisation the
    /// values in effect.
    params: Params,
    /// Names of the parameters set through FMI to a value other than their start value: they
    /// override the mission file. Array elements count one by one, under their FMI 2 names
    /// (`start_m[1]`, `bs_m[2]`): setting one element keeps the file's other one.
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

    fn check_real(&self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
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

    fn set_real(&mut self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
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
        let text = read_mission_text(&path)?;
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
                let d = Params::default();
                for name in &self.params_set {
                    // array elements (`start_m[1]`) replace only that element of the file's
                    // array (or of the default when the file has none)
                    let array = [
                        ("start_m", self.params.start_m, d.start_m),
                        ("bs_m", self.params.bs_m, d.bs_m),
                    ]
                    .into_iter()
                    .find_map(|(array, fmi, spec)| {
                        let i = match name.strip_prefix(array)? {
                            "[1]" => 0,
                            "[2]" => 1,
                            _ => return None,
                        };
                        Some((array, i, fmi[i], spec))
                    });
                    match array {
                        Some((array, i, value, spec)) => {
                            let mut v: [f64; 2] = obj
                                .get(array)
                                .and_then(|a| serde_json::from_value(a.clone()).ok())
                                .unwrap_or(spec);
                            v[i] = value;
                            obj.insert(array.to_string(), serde_json::json!(v));
                        }
                        None => {
                            obj.insert(
                                name.clone(),
                                serde_json::json!(self.params.get_by_name(name)),
                            );
                        }
                    }
                }
            }
            file.params = serde_json::from_value(map)
                .map_err(|e| FmuError::error(format!("parameters set through FMI: {e}")))?;
        }
        let mission = Mission::from_file_struct(&file).map_err(|e| {
            let text = match &e {
                // the planner writes the value in full decimal (309 digits for -1e308)
                planner::MissionError::Param(planner::ParamError::Invalid {
                    field,
                    value,
                    reason,
                }) => format!("parameter `{field}` = {}: {reason}", Num(*value)),
                other => other.to_string(),
            };
            FmuError::error(format!("mission {shown}: {text}"))
        })?;
        let slots = mission.slots();
        if slots > MAX_FMU_SLOTS {
            let p = mission.params();
            return Err(FmuError::error(format!(
                "mission {shown}: parameters `horizon_s` = {} s and `slot_s` = {} s give {slots} slots, more than the {MAX_FMU_SLOTS} this FMU plans at initialisation (raise `slot_s` or shorten `horizon_s`)",
                Num(p.horizon_s),
                Num(p.slot_s)
            )));
        }
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
                Num(mission.params().slot_s),
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
        let reject = |message: String| {
            FmuError::error(format!(
                "t = {} s: landmark input ({}, {}) m rejected: {message}",
                Num(tau_s),
                Num(input[0]),
                Num(input[1])
            ))
        };
        if !has_later_slots {
            // the window ended with the current slot: nothing is left to re-plan, but the
            // outputs report the moved landmark (and whether the current slot still sees it)
            let mission = planning::moved_mission(&run.mission, window, input).map_err(reject)?;
            log.log(
                Category::Events,
                Status::Ok,
                &format!(
                    "{what}; its window has no slot left (slot {current}, which ended at t = {} s, was its last): nothing re-planned",
                    Num(current as f64 * slot_s)
                ),
            );
            run.moved.insert(window);
            run.eval = evaluate(&mission, &run.traj);
            run.mission = mission;
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
            Err(ReplanError::Mission(message)) => Err(reject(message)),
            Err(ReplanError::Planner {
                mission,
                attempts,
                solve_s,
                ..
            }) => {
                run.moved.insert(window);
                run.eval = evaluate(&mission, &run.traj);
                run.mission = *mission;
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
    fn out_of_view_from(&self, first: usize) -> (usize, String) {
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
    fn warn(&self, warning: String, log: &dyn Log) -> StepReport {
        log.log(Category::Warning, Status::Warning, &warning);
        StepReport {
            warning: Some(warning),
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

/// The landmark mover's state. Its input is meant to be the planner's `landmark_x_m`/`landmark_y_m`
/// (the landmark of [`current_window`]); at the end of the step that reaches `move_at_s` it
/// latches that landmark plus the offset, and the planner applies its output, from the next
/// doStep on, to [`current_window`] at that time: the same window (Gauss-Seidel coupling,
/// planner first).
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
            // mid-window on the default mission (windows of 10 s): a move at a window boundary
            // would shift the landmark of the window that ends there, which has no slot left
            move_at_s: 65.0,
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

    fn check_real(&self, var: &Var, value: f64) -> Result<(), FmuError> {
        let bad = |why: &str| {
            Err(FmuError::error(format!(
                "{} `{}` = {}: {why}",
                var.causality.name(),
                var.name,
                Num(value)
            )))
        };
        match var.vr {
            mover_vr::MOVE_AT | mover_vr::OFFSET_X | mover_vr::OFFSET_Y if !value.is_finite() => {
                bad("must be a finite number")
            }
            mover_vr::HOLD if !(value.is_finite() && value >= 0.0) => {
                bad("must be a finite number >= 0 (0: until the end)")
            }
            mover_vr::IN_X | mover_vr::IN_Y if value.is_infinite() => {
                bad("must be a finite number (the planner's landmark) or NaN (none)")
            }
            mover_vr::MOVE_AT
            | mover_vr::OFFSET_X
            | mover_vr::OFFSET_Y
            | mover_vr::HOLD
            | mover_vr::IN_X
            | mover_vr::IN_Y => Ok(()),
            _ => Err(unknown(var)),
        }
    }

    fn set_real(&mut self, var: &Var, value: f64) -> Result<(), FmuError> {
        self.check_real(var, value)?;
        match var.vr {
            mover_vr::MOVE_AT => self.move_at_s = value,
            mover_vr::OFFSET_X => self.offset_m[0] = value,
            mover_vr::OFFSET_Y => self.offset_m[1] = value,
            mover_vr::HOLD => self.hold_s = value,
            mover_vr::IN_X => self.input_m[0] = value,
            _ => self.input_m[1] = value,
        }
        Ok(())
    }

    fn get_bool(&self, var: &Var, tau_s: f64) -> Result<bool, FmuError> {
        match var.vr {
            mover_vr::MOVED => Ok(self.output(tau_s).is_some()),
            _ => Err(unknown(var)),
        }
    }

    /// At the end of a step: latch the moved landmark once the move time is reached. An input
    /// with one NaN and one finite coordinate is refused (the step is not taken).
    fn step(&mut self, end_s: f64) -> Result<(), FmuError> {
        if self.input_m[0].is_nan() != self.input_m[1].is_nan() {
            return Err(FmuError::error(format!(
                "inputs (`landmark_x_m`, `landmark_y_m`) = ({}, {}) m refused: set both to finite numbers or both to NaN; the step was not taken",
                Num(self.input_m[0]),
                Num(self.input_m[1])
            )));
        }
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
        Ok(())
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
                let off = planner::geometry::distance(&mid.centre_m.into(), &mid.pos_m.into());
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

    /// Collects log messages.
    #[derive(Default)]
    struct Collect(std::cell::RefCell<Vec<(Status, String)>>);

    impl Log for Collect {
        fn log(&self, _category: Category, status: Status, message: &str) {
            self.0.borrow_mut().push((status, message.to_string()));
        }
    }

    use crate::planning::tests::{short_mission, SHORT};

    fn var(table: &'static [Var], name: &str) -> &'static Var {
        table.iter().find(|v| v.name == name).unwrap()
    }

    /// A planner core for `mission` (TOML text), with `setup` applied before initialisation.
    fn planned(
        mission: &str,
        setup: impl FnOnce(&mut Core),
    ) -> (Core, tempfile::TempDir, Result<(), FmuError>) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        std::fs::write(&path, mission).unwrap();
        let mut core = Core::new(ModelKind::Planner);
        core.set_string(var(PLANNER_VARS, "mission_file"), path.to_str().unwrap())
            .unwrap();
        setup(&mut core);
        let r = core.initialize(None, &Collect::default());
        (core, dir, r)
    }

    fn set_input(core: &mut Core, x: f64, y: f64) {
        core.set_real(var(PLANNER_VARS, "landmark_x_in_m"), 0, x)
            .unwrap();
        core.set_real(var(PLANNER_VARS, "landmark_y_in_m"), 0, y)
            .unwrap();
    }

    fn landmarks(core: &Core) -> Vec<[f64; 2]> {
        let Core::Planner(c) = core else {
            panic!("not a planner")
        };
        let run = c.run.as_ref().unwrap();
        run.mission
            .schedule()
            .landmarks
            .iter()
            .map(|w| w.pos_m())
            .collect()
    }

    #[test]
    fn numbers_in_messages_are_short() {
        assert_eq!(Num(-1e308).to_string(), "-1e308");
        assert_eq!(Num(1e-12).to_string(), "1e-12");
        assert_eq!(Num(0.0001).to_string(), "0.0001");
        assert_eq!(Num(0.5).to_string(), "0.5");
        assert_eq!(Num(300.0).to_string(), "300");
        assert_eq!(Num(1e15).to_string(), "1e15");
        assert_eq!(Num(f64::NAN).to_string(), "NaN");
        assert_eq!(Num(f64::NEG_INFINITY).to_string(), "-inf");
        assert_eq!(format!("{:.3}", Num(1.23456)), "1.235");
        assert_eq!(format!("{:.2}", Num(123456789e10)), "1.23e18");
    }

    #[test]
    fn one_array_element_keeps_the_files_other_element() {
        let mission = SHORT.replace(
            "horizon_s = 20",
            "horizon_s = 20\nstart_m = [-1100.0, -450.0]\nbs_m = [10.0, 20.0]",
        );
        // FMI 2 sets start_m[2] and bs_m[1] alone; bs_m[2] is written back at its start value
        let (core, _dir, r) = planned(&mission, |c| {
            c.set_real(var(PLANNER_VARS, "start_m"), 1, -460.0).unwrap();
            c.set_real(var(PLANNER_VARS, "bs_m"), 0, 11.0).unwrap();
            c.set_real(var(PLANNER_VARS, "bs_m"), 1, Params::default().bs_m[1])
                .unwrap();
        });
        r.unwrap();
        let get = |name, i| core.get_real(var(PLANNER_VARS, name), i, 0.0).unwrap();
        assert_eq!([get("start_m", 0), get("start_m", 1)], [-1100.0, -460.0]);
        assert_eq!([get("bs_m", 0), get("bs_m", 1)], [11.0, 20.0]);
        assert_eq!([get("x_m", 0), get("y_m", 0)], [-1100.0, -460.0]);
    }

    #[test]
    fn move_out_of_reach_warns_and_counts_slots_out_of_view() {
        let (mut core, _dir, r) = planned(SHORT, |_| {});
        r.unwrap();
        let out_of_view = |c: &Core| c.get_int(var(PLANNER_VARS, "slots_out_of_view")).unwrap();
        assert_eq!(out_of_view(&core), 0);
        set_input(&mut core, 1e7, 0.0);
        let log = Collect::default();
        let report = core.step(2.5, 0.5, &log).unwrap();
        let warning = report
            .warning
            .expect("a re-plan that drops a window must warn");
        assert!(
            warning.contains("landmark 0") && warning.contains("slots 6..20"),
            "{warning}"
        );
        assert!(log
            .0
            .borrow()
            .iter()
            .any(|(s, m)| *s == Status::Warning && *m == warning));
        // every slot of window 0 misses the moved landmark, window 1 is planned as usual
        assert_eq!(out_of_view(&core), 20);
        assert!(!core.get_bool(var(PLANNER_VARS, "in_view"), 5.0).unwrap());
        assert!(core.get_bool(var(PLANNER_VARS, "in_view"), 15.0).unwrap());
    }

    #[test]
    fn input_at_a_window_boundary_moves_the_window_that_ends_there() {
        let (mut core, _dir, r) = planned(SHORT, |_| {});
        r.unwrap();
        // at t = 10 s the outputs show slot 20, window 0 (0, 10] s: the input moves that one
        let lx = var(PLANNER_VARS, "landmark_x_m");
        assert_eq!(core.get_real(lx, 0, 10.0).unwrap(), 0.0);
        assert_eq!(
            core.get_real(var(PLANNER_VARS, "landmark_y_m"), 0, 10.0)
                .unwrap(),
            0.0
        );
        set_input(&mut core, 40.0, 0.0);
        let report = core.step(10.0, 0.5, &Collect::default()).unwrap();
        assert_eq!(landmarks(&core), vec![[40.0, 0.0], [0.0, 30.0]]);
        // window 0 has no slot left: nothing re-planned, and the step says so
        assert!(report.warning.unwrap().contains("no slot left"));
        assert_eq!(core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(), 0);
        // in the middle of window 1 the same input moves window 1 and re-plans
        core.step(10.5, 0.5, &Collect::default()).unwrap();
        assert_eq!(landmarks(&core), vec![[40.0, 0.0], [40.0, 0.0]]);
        assert_eq!(core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(), 1);
        assert_eq!(current_window(&short_mission(), 10.0), Some(0));
    }

    #[test]
    fn bad_landmark_inputs_are_refused() {
        let (mut core, _dir, r) = planned(SHORT, |_| {});
        r.unwrap();
        let x = var(PLANNER_VARS, "landmark_x_in_m");
        let e = core.set_real(x, 0, f64::INFINITY).unwrap_err();
        assert!(
            e.message.contains("`landmark_x_in_m` = inf"),
            "{}",
            e.message
        );
        assert!(core.get_real(x, 0, 0.0).unwrap().is_nan());
        // one coordinate NaN, the other finite: refused at the step, nothing changes
        core.set_real(x, 0, 40.0).unwrap();
        let e = core.step(2.5, 0.5, &Collect::default()).unwrap_err();
        assert!(
            e.message.contains("landmark_x_in_m") && e.message.contains("landmark_y_in_m"),
            "{}",
            e.message
        );
        assert_eq!(landmarks(&core), vec![[0.0, 0.0], [0.0, 30.0]]);
    }

    #[test]
    fn bad_mover_values_are_refused() {
        let mut core = Core::new(ModelKind::Mover);
        let hold = var(MOVER_VARS, "hold_s");
        let e = core.set_real(hold, 0, -1.0).unwrap_err();
        assert!(e.message.contains("`hold_s` = -1"), "{}", e.message);
        assert_eq!(core.get_real(hold, 0, 0.0).unwrap(), 0.0);
        let e = core
            .set_real(var(MOVER_VARS, "landmark_y_m"), 0, f64::INFINITY)
            .unwrap_err();
        assert!(e.message.contains("landmark_y_m"), "{}", e.message);
        core.set_real(var(MOVER_VARS, "landmark_x_m"), 0, f64::NAN)
            .unwrap();
        assert!(core.step(0.0, 0.5, &Collect::default()).is_err());
    }

    #[test]
    fn too_many_slots_are_refused_before_planning() {
        let started = std::time::Instant::now();
        let (_core, _dir, r) = planned(SHORT, |c| {
            c.set_real(var(PLANNER_VARS, "slot_s"), 0, 1e-4).unwrap();
        });
        let e = r.unwrap_err();
        assert!(
            e.message
                .contains("`horizon_s` = 20 s and `slot_s` = 0.0001 s give 200000 slots"),
            "{}",
            e.message
        );
        assert!(started.elapsed().as_secs_f64() < 5.0);
    }

    #[test]
    fn mission_file_size_is_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let big = dir.path().join("big.toml");
        let f = std::fs::File::create(&big).unwrap();
        f.set_len(MAX_MISSION_FILE_BYTES + 1).unwrap();
        let e = read_mission_text(&big).unwrap_err();
        assert!(
            e.message.contains("big.toml") && e.message.contains("limit"),
            "{e}"
        );
        // a device reports length 0: the bounded read still stops
        let e = read_mission_text(Path::new("/dev/zero")).unwrap_err();
        assert!(
            e.message.contains("/dev/zero") && e.message.contains("limit"),
            "{e}"
        );
        let ok = dir.path().join("ok.toml");
        std::fs::write(&ok, "a = 1").unwrap();
        assert_eq!(read_mission_text(&ok).unwrap(), "a = 1");
        let e = read_mission_text(&dir.path().join("none.toml")).unwrap_err();
        assert!(e.message.contains("none.toml"), "{e}");
    }
}
