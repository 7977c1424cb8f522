//! One FMU instance, independent of the FMI version: the call-sequence state machine (after the
//! FMI 2 and FMI 3 co-simulation state diagrams), variable access rules, time keeping, logging,
//! and FMU states. The `fmi2`/`fmi3` modules only convert C arguments and call these methods.

use std::ffi::{c_char, c_int, c_void, CString};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::core::{guid, Core, FmiVersion, FmuError, Log, ModelKind, Num, Status};
use crate::table::{self, Category, Causality, Var, VarType, LOG_CATEGORIES};

/// Marks a live [`Instance`] behind an importer's pointer.
const MAGIC: u64 = 0x43454c4c_53415246; // "CELLSARF"

/// The state of an instance (FMI 2 names in brackets).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mode {
    /// After instantiation or reset (instantiated).
    Instantiated,
    /// Between Enter- and ExitInitializationMode (initializationMode).
    Initialization,
    /// Stepping (stepComplete / Step Mode).
    Step,
    /// After Terminate (terminated).
    Terminated,
    /// After an internal error: only get, reset and free (error).
    Error,
}

/// What a doStep reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOutcome {
    /// The status to return (OK, Warning, or Discard when the horizon ended the step early).
    pub status: Status,
    /// The simulation must end (the horizon is over).
    pub terminate: bool,
    /// The time reached.
    pub last_successful_time: f64,
}

/// One FMU instance.
#[repr(C)]
#[derive(Debug)]
pub struct Instance {
    magic: u64,
    /// FMI version of the entry points that created it.
    pub version: FmiVersion,
    name: String,
    /// The logger.
    pub logger: Logger,
    mode: Mode,
    core: Core,
    resources: Option<PathBuf>,
    start_time: f64,
    stop_time: Option<f64>,
    time: f64,
    /// The horizon ended a step (FMI 2 `fmi2Terminated` status).
    pub terminated: bool,
    /// Strings returned by GetString stay valid until the next call.
    strings: Vec<CString>,
}

fn mode_list(modes: &[Mode]) -> String {
    modes
        .iter()
        .map(|m| format!("{m:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Instance {
    /// Creates an instance after the FMI layer checked the name, token and interface type.
    pub fn new(
        version: FmiVersion,
        kind: ModelKind,
        name: &str,
        resources: Option<PathBuf>,
        logger: Logger,
    ) -> Self {
        Self {
            magic: MAGIC,
            version,
            name: name.to_string(),
            logger,
            mode: Mode::Instantiated,
            core: Core::new(kind),
            resources,
            start_time: 0.0,
            stop_time: None,
            time: 0.0,
            terminated: false,
            strings: Vec::new(),
        }
    }

    /// The instance behind a pointer handed out by instantiate.
    ///
    /// # Safety
    /// `ptr` must be null or a pointer returned by this library's instantiate and not yet freed.
    pub unsafe fn from_ptr<'a>(ptr: *mut c_void) -> Option<&'a mut Instance> {
        // SAFETY: the caller guarantees `ptr` is null or a live Instance.
        let inst = unsafe { ptr.cast::<Instance>().as_mut() }?;
        (inst.magic == MAGIC).then_some(inst)
    }

    /// Boxes an instance for the importer.
    pub fn into_raw(self) -> *mut c_void {
        Box::into_raw(Box::new(self)).cast()
    }

    /// Frees an instance from [`Instance::into_raw`].
    ///
    /// # Safety
    /// As for [`Instance::from_ptr`]; the pointer must not be used afterwards.
    pub unsafe fn free(ptr: *mut c_void) {
        // SAFETY: forwarded.
        if let Some(inst) = unsafe { Self::from_ptr(ptr) } {
            inst.magic = 0;
            // SAFETY: from Box::into_raw, freed once (magic cleared above).
            drop(unsafe { Box::from_raw(ptr.cast::<Instance>()) });
        }
    }

    /// The instance name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Puts the instance into the error mode (after an internal failure).
    pub fn set_error_mode(&mut self) {
        self.mode = Mode::Error;
    }

    /// The current simulation time.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The GUID / instantiation token of this instance's model and FMI version.
    pub fn guid(&self) -> String {
        guid(self.core.info(), self.version)
    }

    /// Logs a message.
    pub fn log(&self, category: Category, status: Status, message: &str) {
        self.logger.log(category, status, message);
    }

    /// Fails unless the instance is in one of `allowed`.
    pub fn require(&self, func: &str, allowed: &[Mode]) -> Result<(), FmuError> {
        if allowed.contains(&self.mode) {
            Ok(())
        } else {
            Err(FmuError::error(format!(
                "{func} is not allowed in mode {:?} (allowed in: {})",
                self.mode,
                mode_list(allowed)
            )))
        }
    }

    /// FMI 2 `SetupExperiment`.
    pub fn setup_experiment(&mut self, start: f64, stop: Option<f64>) -> Result<(), FmuError> {
        self.require("fmi2SetupExperiment", &[Mode::Instantiated])?;
        self.set_experiment(start, stop)
    }

    fn set_experiment(&mut self, start: f64, stop: Option<f64>) -> Result<(), FmuError> {
        if !start.is_finite() {
            return Err(FmuError::error(format!(
                "start time {} is not finite",
                Num(start)
            )));
        }
        if let Some(s) = stop {
            if !(s.is_finite() && s >= start) {
                return Err(FmuError::error(format!(
                    "stop time {} must be finite and not before the start time {}",
                    Num(s),
                    Num(start)
                )));
            }
        }
        self.start_time = start;
        self.stop_time = stop;
        self.time = start;
        Ok(())
    }

    /// `EnterInitializationMode`. FMI 3 passes the experiment here (`experiment`), FMI 2 in
    /// `SetupExperiment` before.
    pub fn enter_initialization(
        &mut self,
        func: &str,
        experiment: Option<(f64, Option<f64>)>,
    ) -> Result<(), FmuError> {
        self.require(func, &[Mode::Instantiated])?;
        if let Some((start, stop)) = experiment {
            self.set_experiment(start, stop)?;
        }
        self.mode = Mode::Initialization;
        Ok(())
    }

    /// `ExitInitializationMode`: plans the mission. A mission that cannot be flown puts the
    /// instance into the error mode.
    pub fn exit_initialization(&mut self, func: &str) -> Result<(), FmuError> {
        self.require(func, &[Mode::Initialization])?;
        if let Err(e) = self
            .core
            .initialize(self.resources.as_deref(), &self.logger)
        {
            self.mode = Mode::Error;
            return Err(e);
        }
        if let (Some(h), Some(stop)) = (self.core.horizon_s(), self.stop_time) {
            let end = self.start_time + h;
            if stop > end + 1e-9 * end.abs().max(1.0) {
                self.mode = Mode::Error;
                return Err(FmuError::error(format!(
                    "stop time {} s lies after the end of the mission horizon ({} s from the start time {} s, i.e. {} s)",
                    Num(stop),
                    Num(h),
                    Num(self.start_time),
                    Num(end)
                )));
            }
        }
        self.mode = Mode::Step;
        Ok(())
    }

    /// `Terminate`.
    pub fn terminate(&mut self, func: &str) -> Result<(), FmuError> {
        self.require(func, &[Mode::Step])?;
        self.mode = Mode::Terminated;
        Ok(())
    }

    /// `Reset`: back to the state after instantiation, every variable at its start value.
    pub fn reset(&mut self) {
        self.core = Core::new(self.core.info().kind);
        self.mode = Mode::Instantiated;
        self.start_time = 0.0;
        self.stop_time = None;
        self.time = 0.0;
        self.terminated = false;
        self.strings.clear();
    }
}

impl Instance {
    /// `DoStep` from `t` by `h`. The step must start at the current time; past the mission
    /// horizon it stops at the horizon and reports Discard with `terminate`.
    pub fn do_step(&mut self, func: &str, t: f64, h: f64) -> Result<StepOutcome, FmuError> {
        self.require(func, &[Mode::Step])?;
        if !(t.is_finite() && h.is_finite()) {
            return Err(FmuError::error(format!(
                "{func}: communication point {} and step size {} must be finite",
                Num(t),
                Num(h)
            )));
        }
        if h <= 0.0 {
            return Err(FmuError::error(format!(
                "{func}: communication step size must be > 0, got {}",
                Num(h)
            )));
        }
        let eps = 1e-9 * (1.0 + self.time.abs());
        if (t - self.time).abs() > eps {
            return Err(FmuError::error(format!(
                "{func}: communication point {} s is not the current time {} s",
                Num(t),
                Num(self.time)
            )));
        }
        let mut end = t + h;
        if let Some(stop) = self.stop_time {
            if end > stop + 1e-9 * (1.0 + stop.abs()) {
                return Err(FmuError::error(format!(
                    "{func}: the step to {} s passes the stop time {} s",
                    Num(end),
                    Num(stop)
                )));
            }
        }
        let mut status = Status::Ok;
        let mut terminate = false;
        if let Some(horizon) = self.core.horizon_s() {
            let last = self.start_time + horizon;
            if end > last + 1e-9 * (1.0 + last.abs()) {
                end = last;
                status = Status::Discard;
                terminate = true;
            }
        }
        let report = self.core.step(t - self.start_time, end - t, &self.logger)?;
        if report.warning.is_some() && status == Status::Ok {
            status = Status::Warning;
        }
        self.time = end;
        if terminate {
            self.terminated = true;
            self.log(
                Category::Warning,
                Status::Discard,
                &format!(
                    "{func}: the mission horizon ends at {} s: the step stopped there",
                    Num(end)
                ),
            );
        }
        Ok(StepOutcome {
            status,
            terminate,
            last_successful_time: self.time,
        })
    }

    /// The resources directory, if usable.
    pub fn resources(&self) -> Option<&Path> {
        self.resources.as_deref()
    }
}

mod access;
mod logger;
mod resource;
mod state;
#[cfg(test)]
mod tests;

pub use logger::{c_string, Callback, Fmi2Logger, Fmi3Logger, Logger};
pub use resource::parse_resource_location;
pub use state::{Snapshot, StateBox};
