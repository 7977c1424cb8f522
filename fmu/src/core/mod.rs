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

/// Value of [`crate::table::planner_vr::DEBUG_INJECT_PANIC`] that makes the next doStep panic
/// (`test-hooks` feature).
pub const PANIC_IN_DO_STEP: i32 = 1;
/// Value of [`crate::table::planner_vr::DEBUG_INJECT_PANIC`] that makes the next get panic
/// (`test-hooks` feature).
pub const PANIC_IN_GET: i32 = 2;

/// The file name of the default mission inside the FMU's `resources/` directory.
pub const DEFAULT_MISSION_FILE: &str = "default_mission.toml";

/// The default mission shipped in the FMU's `resources/`.
pub const DEFAULT_MISSION_TOML: &str = include_str!("../../../missions/default-30m.toml");

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

#[cfg(test)]
mod altitude_tests;
mod dispatch;
mod mission_file;
mod mover;
mod planner_core;
mod run;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod vehicle_tests;

use dispatch::unknown;
pub use dispatch::{Core, StepReport};
pub use mission_file::{read_mission_text, MAX_MISSION_FILE_BYTES};
pub use mover::MoverCore;
pub use planner_core::PlannerCore;
use run::slot_at_committed;
pub use run::{current_window, evaluate_at, slot_at, Run, Sample};
