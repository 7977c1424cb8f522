//! # cellsar planner
//!
//! Least-energy trajectory planning for a cellular-connected rotary-wing UAV that forms a
//! bistatic SAR with its serving base station (Hu, Yuan, Ni, Wang, IEEE Trans. Commun.),
//! with the corrections of `the errata (docs/paper-notes.md).
//!
//! Layers, bottom up:
//! - models: [`params`], [`landmarks`], [`mission`], [`power`], [`geometry`], [`dmin`];
//! - exact-geometry evaluation of any trajectory: [`evaluate()`];
//! - trajectories and their files: [`trajectory`];
//! - the convex machinery: [`socp`] (Clarabel), [`schemes`] (the subproblems), [`init`]
//!   (pre-check and start), [`driver`] (the iteration loop: [`plan`]);
//! - a plan as data: [`summary`] (`summary.json`, `trajectory.csv`).
//!
//! A pure library: no networking, no command line, no plotting (those live in the `pipeline`
//! crate, which also holds the `cellsar-planner` binary).

pub mod altitude;
pub mod bound;
pub mod dmin;
pub mod driver;
pub mod evaluate;
pub mod files;
pub mod geometry;
pub mod init;
pub mod landmarks;
pub mod margins;
pub mod mission;
pub mod params;
pub mod power;
pub mod schemes;
pub mod shortfall;
pub mod socp;
pub mod summary;
pub mod tradeoff;
pub mod trajectory;

pub use altitude::AltitudeMode;
pub use bound::{energy_bound, EnergyBound};
pub use driver::{
    plan, plan_with_observer, plan_with_stop, IterationRecord, NoObserver, NotFound, Observer,
    OptionConflict, OptionName, PlanError, PlanOptions, PlanResult, Scheme, TerminationReason,
    DEFAULT_DYNAMICS, DEFAULT_RESOLUTION,
};
pub use evaluate::{evaluate, Dynamics, Evaluation, SlotEval, Violations};
pub use landmarks::{LandmarkWindow, LandmarksSpec, Preset, Schedule};
pub use mission::{Mission, MissionError, MissionFile};
pub use params::{ParamError, Params, ParamsOverride, StartVelocityKind};
pub use power::PowerModel;
pub use summary::Summary;
pub use trajectory::{Trajectory, TrajectoryError};
