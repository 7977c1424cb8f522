//! # cellsar FMU
//!
//! The cellsar planner as FMI 2.0 and FMI 3.0 co-simulation FMUs (`CellsarPlanner`), plus a small
//! partner FMU for coupled co-simulation (`LandmarkMover`), both from this one library. The
//! structure follows modelica's Reference-FMUs:
//!
//! - [`table`]: one variable table per model drives the C API (get/set by value reference) and
//!   the generated model description ([`xml`]);
//! - [`core`]: the model cores (plain data: `Clone` + serde, so FMU states are copies);
//! - [`planning`]: the initial plan and receding-horizon re-plans through the planner crate;
//! - [`instance`]: the call-sequence state machine, time keeping, logging and FMU states;
//! - [`fmi2`], [`fmi3`]: the C entry points, written directly, each behind `catch_unwind`;
//! - [`package`]: the `.fmu` archives (`package-fmu` binary).
//!
//! The library keeps no mutable global state: every instance owns its state, so several
//! instances in one process and on different threads do not interfere, and it starts no threads.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod core;
pub mod ffi;
pub mod fmi2;
pub mod fmi3;
pub mod instance;
pub mod package;
pub mod planning;
pub mod table;
pub mod xml;
