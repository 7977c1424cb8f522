//! One FMU instance, independent of the FMI version: the call-sequence state machine (after the
//! FMI 2 and FMI 3 co-simulation state diagrams), variable access rules, time keeping, logging,
//! and FMU states. The `fmi2`/`fmi3` modules only convert C arguments and call these methods.

use std::ffi::{c_char, c_int, c_void, CString};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::core::{guid, Core, FmiVersion, FmuError, Log, ModelKind, Num, Status};
use crate::table::{self, Category, Causality, Var, VarType, LOG_CATEGORIES};

/// The FMI 2 logger: `void logger(env, instanceName, status, category, message, ...)`; the
/// message is a printf format string.
pub type Fmi2Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...);

/// The FMI 3 logger: `void logMessage(env, status, category, message)`.
pub type Fmi3Logger = unsafe extern "C" fn(*mut c_void, c_int, *const c_char, *const c_char);

/// The importer's logging callback.
#[derive(Debug, Clone, Copy)]
pub enum Callback {
    /// No callback: messages are dropped.
    None,
    /// FMI 2 logger and its component environment.
    Fmi2(Fmi2Logger, *mut c_void),
    /// FMI 3 logger and its instance environment.
    Fmi3(Fmi3Logger, *mut c_void),
}

/// Sends messages to the importer. Errors and warnings are always sent; other categories only
/// with debug logging on and the category enabled.
#[derive(Debug, Clone)]
pub struct Logger {
    callback: Callback,
    instance_name: CString,
    debug: bool,
    enabled: [bool; 4],
}

/// A C string from arbitrary text: NUL bytes become U+FFFD.
pub fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', "\u{FFFD}")).unwrap_or_default()
}

impl Logger {
    /// A logger for `instance_name`.
    pub fn new(callback: Callback, instance_name: &str, debug: bool) -> Self {
        Self {
            callback,
            instance_name: c_string(instance_name),
            debug,
            enabled: [true; 4],
        }
    }

    /// FMI `SetDebugLogging`: `categories` empty means all.
    pub fn set_debug(&mut self, on: bool, categories: &[String]) -> Result<(), FmuError> {
        let mut idx = Vec::with_capacity(categories.len());
        for name in categories {
            let i = LOG_CATEGORIES
                .iter()
                .position(|c| c.name == name)
                .ok_or_else(|| {
                    FmuError::error(format!(
                        "unknown log category `{name}` (known: {})",
                        LOG_CATEGORIES
                            .iter()
                            .map(|c| c.name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })?;
            idx.push(i);
        }
        self.debug = on;
        if idx.is_empty() {
            self.enabled = [on; 4];
        } else {
            for i in idx {
                self.enabled[i] = on;
            }
        }
        Ok(())
    }

    /// Logs an error (always sent).
    pub fn log_now(&self, message: &str) {
        self.log(Category::Error, Status::Error, message);
    }

    /// Logs a warning (always sent).
    pub fn log_warning(&self, message: &str) {
        self.log(Category::Warning, Status::Warning, message);
    }

    /// True when a message of this category and status would be sent.
    pub fn wants(&self, category: Category, status: Status) -> bool {
        status >= Status::Warning || (self.debug && self.enabled[category as usize])
    }
}

impl Log for Logger {
    fn log(&self, category: Category, status: Status, message: &str) {
        if !self.wants(category, status) {
            return;
        }
        let cat = c_string(category.name());
        match self.callback {
            Callback::None => {}
            Callback::Fmi2(f, env) => {
                // the FMI 2 message is a printf format: escape `%`
                let msg = c_string(&message.replace('%', "%%"));
                // SAFETY: the importer gave this callback for this instance; every string is a
                // valid NUL-terminated C string that outlives the call.
                unsafe {
                    f(
                        env,
                        self.instance_name.as_ptr(),
                        status as c_int,
                        cat.as_ptr(),
                        msg.as_ptr(),
                    )
                };
            }
            Callback::Fmi3(f, env) => {
                let msg = c_string(message);
                // SAFETY: as above.
                unsafe { f(env, status as c_int, cat.as_ptr(), msg.as_ptr()) };
            }
        }
    }
}

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

const MAGIC: u64 = 0x43454c4c_53415246; // "CELLSARF"
const STATE_MAGIC: u64 = 0x43454c4c_53544154; // "CELLSTAT"
const STATE_HEADER: &[u8; 8] = b"CSFMUST1";

/// A saved FMU state (what `GetFMUState` hands out).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Snapshot {
    kind: ModelKind,
    version: FmiVersion,
    mode: Mode,
    core: Core,
    start_time: f64,
    stop_time: Option<f64>,
    time: f64,
    terminated: bool,
}

/// The object behind an `fmi2FMUstate` / `fmi3FMUState` pointer.
#[repr(C)]
#[derive(Debug)]
pub struct StateBox {
    magic: u64,
    snapshot: Snapshot,
}

impl StateBox {
    /// The saved state.
    pub fn snapshot_ref(&self) -> &Snapshot {
        &self.snapshot
    }

    /// Overwrites the saved state.
    pub fn replace(&mut self, snapshot: Snapshot) {
        self.snapshot = snapshot;
    }

    /// A boxed state, as a raw pointer for the importer.
    pub fn into_raw(snapshot: Snapshot) -> *mut c_void {
        Box::into_raw(Box::new(StateBox {
            magic: STATE_MAGIC,
            snapshot,
        }))
        .cast()
    }

    /// The state behind a pointer from [`StateBox::into_raw`].
    ///
    /// # Safety
    /// `ptr` must be null or a pointer this library handed out and not yet freed.
    pub unsafe fn from_ptr<'a>(ptr: *mut c_void) -> Result<&'a mut StateBox, FmuError> {
        let p = ptr.cast::<StateBox>();
        // SAFETY: the caller guarantees `ptr` is null or a live StateBox.
        match unsafe { p.as_mut() } {
            Some(s) if s.magic == STATE_MAGIC => Ok(s),
            Some(_) => Err(FmuError::error(
                "the FMU state pointer does not point to a state of this FMU",
            )),
            None => Err(FmuError::error("the FMU state pointer is NULL")),
        }
    }

    /// Frees a state from [`StateBox::into_raw`].
    ///
    /// # Safety
    /// As for [`StateBox::from_ptr`]; the pointer must not be used afterwards.
    pub unsafe fn free(ptr: *mut c_void) -> Result<(), FmuError> {
        // SAFETY: forwarded.
        let s = unsafe { Self::from_ptr(ptr) }?;
        s.magic = 0;
        // SAFETY: the pointer came from Box::into_raw and is freed once (magic cleared above).
        drop(unsafe { Box::from_raw(ptr.cast::<StateBox>()) });
        Ok(())
    }
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

/// Parses an FMI 2 resource location (a `file:` URI, or a plain path) or an FMI 3 resource path
/// into a directory. `Err` says why it is unusable.
pub fn parse_resource_location(text: &str) -> Result<PathBuf, String> {
    let raw = if let Some(rest) = text.strip_prefix("file://") {
        if let Some(r) = rest.strip_prefix("localhost/") {
            format!("/{r}")
        } else if rest.starts_with('/') {
            rest.to_string()
        } else {
            return Err(format!(
                "`{text}`: file URIs with a remote host are not supported"
            ));
        }
    } else if let Some(rest) = text.strip_prefix("file:") {
        rest.to_string()
    } else if text.contains("://") {
        return Err(format!("`{text}`: only file: URIs are supported"));
    } else {
        text.to_string()
    };
    let decoded = percent_decode(&raw).ok_or_else(|| format!("`{text}`: bad %-escape"))?;
    let path = PathBuf::from(decoded);
    if path.is_dir() {
        Ok(path)
    } else {
        Err(format!("{} is not a directory", path.display()))
    }
}

fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = s.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
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

    fn lookup(&self, func: &str, vr: u32) -> Result<(&'static Var, usize), FmuError> {
        table::lookup(self.core.info().vars, vr, self.version == FmiVersion::Fmi2).ok_or_else(
            || {
                FmuError::error(format!(
                    "{func}: unknown value reference {vr} (model {})",
                    self.core.info().identifier
                ))
            },
        )
    }

    fn check_get(&mut self, func: &str, var: &Var, ty: VarType) -> Result<(), FmuError> {
        self.require(
            func,
            &[
                Mode::Initialization,
                Mode::Step,
                Mode::Terminated,
                Mode::Error,
            ],
        )?;
        if var.ty != ty {
            return Err(FmuError::error(format!(
                "{func}: variable `{}` (value reference {}) is a {}",
                var.name,
                var.vr,
                var.ty.fmi2_name()
            )));
        }
        self.core.before_get();
        if var.is_calculated() && !self.core.is_ready() {
            if self.mode == Mode::Initialization {
                // initial unknowns are computed on demand
                self.core
                    .initialize(self.resources.as_deref(), &self.logger)?;
            } else {
                return Err(FmuError::error(format!(
                    "{func}: `{}` is not available: the mission was not planned",
                    var.name
                )));
            }
        }
        Ok(())
    }

    fn check_set(&self, func: &str, var: &Var, ty: VarType) -> Result<(), FmuError> {
        self.require(
            func,
            &[Mode::Instantiated, Mode::Initialization, Mode::Step],
        )?;
        if var.ty != ty {
            return Err(FmuError::error(format!(
                "{func}: variable `{}` (value reference {}) is a {}",
                var.name,
                var.vr,
                var.ty.fmi2_name()
            )));
        }
        match var.causality {
            Causality::Input => Ok(()),
            Causality::Parameter if self.mode != Mode::Step => Ok(()),
            Causality::Parameter => Err(FmuError::error(format!(
                "{func}: parameter `{}` is fixed: set it before ExitInitializationMode",
                var.name
            ))),
            _ => Err(FmuError::error(format!(
                "{func}: `{}` is an {} and cannot be set",
                var.name,
                var.causality.name()
            ))),
        }
    }

    fn tau(&self) -> f64 {
        self.time - self.start_time
    }

    /// Reads Real values (FMI 2: one per value reference; FMI 3: arrays take several).
    pub fn get_real(&mut self, func: &str, vrs: &[u32], out: &mut [f64]) -> Result<(), FmuError> {
        let mut k = 0;
        let len = out.len();
        for &vr in vrs {
            if vr == 0 && self.version == FmiVersion::Fmi3 {
                self.require(
                    func,
                    &[
                        Mode::Initialization,
                        Mode::Step,
                        Mode::Terminated,
                        Mode::Error,
                    ],
                )?;
                *out.get_mut(k).ok_or_else(|| too_few(func, len))? = self.time;
                k += 1;
                continue;
            }
            let (var, elem) = self.lookup(func, vr)?;
            self.check_get(func, var, VarType::Real)?;
            let n = if self.version == FmiVersion::Fmi3 {
                var.len
            } else {
                1
            };
            for i in 0..n {
                let v = self.core.get_real(var, elem + i, self.tau())?;
                *out.get_mut(k).ok_or_else(|| too_few(func, len))? = v;
                k += 1;
            }
        }
        if k != out.len() {
            return Err(FmuError::error(format!(
                "{func}: {} values requested for {} value references (expected {k})",
                out.len(),
                vrs.len()
            )));
        }
        Ok(())
    }

    /// Sets Real values, all or nothing: every value reference and value is checked before the
    /// first one is set, so a refused call leaves the instance as it was.
    pub fn set_real(&mut self, func: &str, vrs: &[u32], values: &[f64]) -> Result<(), FmuError> {
        let mut todo = Vec::with_capacity(values.len());
        for &vr in vrs {
            let (var, elem) = self.lookup(func, vr)?;
            self.check_set(func, var, VarType::Real)?;
            let n = if self.version == FmiVersion::Fmi3 {
                var.len
            } else {
                1
            };
            for i in 0..n {
                let v = *values
                    .get(todo.len())
                    .ok_or_else(|| too_few(func, values.len()))?;
                self.core.check_real(var, elem + i, v)?;
                todo.push((var, elem + i, v));
            }
        }
        if todo.len() != values.len() {
            return Err(FmuError::error(format!(
                "{func}: {} values given for {} value references (expected {})",
                values.len(),
                vrs.len(),
                todo.len()
            )));
        }
        for (var, elem, v) in todo {
            self.core.set_real(var, elem, v)?;
        }
        Ok(())
    }

    /// Reads Integer values.
    pub fn get_int(&mut self, func: &str, vrs: &[u32], out: &mut [i32]) -> Result<(), FmuError> {
        same_len(func, vrs.len(), out.len())?;
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            let (var, _) = self.lookup(func, vr)?;
            self.check_get(func, var, VarType::Integer)?;
            *o = self.core.get_int(var)?;
        }
        Ok(())
    }

    /// Sets Integer values (also the hidden test variable), all or nothing.
    pub fn set_int(&mut self, func: &str, vrs: &[u32], values: &[i32]) -> Result<(), FmuError> {
        same_len(func, vrs.len(), values.len())?;
        self.require(
            func,
            &[Mode::Instantiated, Mode::Initialization, Mode::Step],
        )?;
        for &vr in vrs {
            if vr != table::planner_vr::DEBUG_INJECT_PANIC {
                let (var, _) = self.lookup(func, vr)?;
                self.check_set(func, var, VarType::Integer)?;
            }
            self.core.check_int(vr)?;
        }
        for (&vr, &v) in vrs.iter().zip(values) {
            self.core.set_int(vr, v)?;
        }
        Ok(())
    }

    /// Reads Boolean values.
    pub fn get_bool(&mut self, func: &str, vrs: &[u32], out: &mut [bool]) -> Result<(), FmuError> {
        same_len(func, vrs.len(), out.len())?;
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            let (var, _) = self.lookup(func, vr)?;
            self.check_get(func, var, VarType::Boolean)?;
            *o = self.core.get_bool(var, self.tau())?;
        }
        Ok(())
    }

    /// Sets Boolean values (no Boolean variable is settable).
    pub fn set_bool(&mut self, func: &str, vrs: &[u32], values: &[bool]) -> Result<(), FmuError> {
        same_len(func, vrs.len(), values.len())?;
        for &vr in vrs {
            let (var, _) = self.lookup(func, vr)?;
            self.check_set(func, var, VarType::Boolean)?;
        }
        Ok(())
    }

    /// Reads String values; the pointers stay valid until the next GetString call.
    pub fn get_string(
        &mut self,
        func: &str,
        vrs: &[u32],
        out: &mut [*const c_char],
    ) -> Result<(), FmuError> {
        same_len(func, vrs.len(), out.len())?;
        self.strings.clear();
        for &vr in vrs {
            let (var, _) = self.lookup(func, vr)?;
            self.check_get(func, var, VarType::String)?;
            let s = self.core.get_string(var)?;
            self.strings.push(c_string(&s));
        }
        for (o, s) in out.iter_mut().zip(&self.strings) {
            *o = s.as_ptr();
        }
        Ok(())
    }

    /// Sets String values, all or nothing.
    pub fn set_string(
        &mut self,
        func: &str,
        vrs: &[u32],
        values: &[String],
    ) -> Result<(), FmuError> {
        same_len(func, vrs.len(), values.len())?;
        let mut todo = Vec::with_capacity(vrs.len());
        for &vr in vrs {
            let (var, _) = self.lookup(func, vr)?;
            self.check_set(func, var, VarType::String)?;
            self.core.check_string(var)?;
            todo.push(var);
        }
        for (var, v) in todo.into_iter().zip(values) {
            self.core.set_string(var, v)?;
        }
        Ok(())
    }

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

    /// A copy of the current state.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            kind: self.core.info().kind,
            version: self.version,
            mode: self.mode,
            core: self.core.clone(),
            start_time: self.start_time,
            stop_time: self.stop_time,
            time: self.time,
            terminated: self.terminated,
        }
    }

    /// Restores a state taken from an instance of the same model and FMI version.
    pub fn restore(&mut self, s: &Snapshot) -> Result<(), FmuError> {
        if s.kind != self.core.info().kind || s.version != self.version {
            return Err(FmuError::error(
                "the FMU state belongs to a different model or FMI version",
            ));
        }
        self.mode = s.mode;
        self.core = s.core.clone();
        self.start_time = s.start_time;
        self.stop_time = s.stop_time;
        self.time = s.time;
        self.terminated = s.terminated;
        Ok(())
    }

    /// Serialises a state: header, this model's GUID, bincode body.
    pub fn serialize_state(&self, s: &Snapshot) -> Result<Vec<u8>, FmuError> {
        let mut out = STATE_HEADER.to_vec();
        let g = self.guid();
        out.extend_from_slice(&(g.len() as u32).to_le_bytes());
        out.extend_from_slice(g.as_bytes());
        let body = bincode::serde::encode_to_vec(s, bincode::config::standard())
            .map_err(|e| FmuError::error(format!("cannot serialise the FMU state: {e}")))?;
        out.extend_from_slice(&body);
        Ok(out)
    }

    /// Reads a state written by [`Instance::serialize_state`] of the same model.
    pub fn deserialize_state(&self, bytes: &[u8]) -> Result<Snapshot, FmuError> {
        let bad = |why: &str| FmuError::error(format!("serialized FMU state rejected: {why}"));
        let rest = bytes
            .strip_prefix(STATE_HEADER.as_slice())
            .ok_or_else(|| bad("wrong header"))?;
        let len_bytes: [u8; 4] = rest
            .get(..4)
            .and_then(|b| b.try_into().ok())
            .ok_or_else(|| bad("truncated"))?;
        let len = u32::from_le_bytes(len_bytes) as usize;
        let g = rest.get(4..4 + len).ok_or_else(|| bad("truncated"))?;
        if g != self.guid().as_bytes() {
            return Err(bad("it was written by a different model or version"));
        }
        let body = &rest[4 + len..];
        let (s, used): (Snapshot, usize) = bincode::serde::decode_from_slice(
            body,
            bincode::config::standard().with_limit::<{ 64 << 20 }>(),
        )
        .map_err(|e| bad(&e.to_string()))?;
        if used != body.len() {
            return Err(bad("trailing bytes"));
        }
        Ok(s)
    }

    /// The resources directory, if usable.
    pub fn resources(&self) -> Option<&Path> {
        self.resources.as_deref()
    }
}

fn too_few(func: &str, n: usize) -> FmuError {
    FmuError::error(format!("{func}: the value array (length {n}) is too short"))
}

fn same_len(func: &str, a: usize, b: usize) -> Result<(), FmuError> {
    if a == b {
        Ok(())
    } else {
        Err(FmuError::error(format!(
            "{func}: {a} value references but {b} values"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resource_locations() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("a b ü");
        std::fs::create_dir(&sub).unwrap();
        let s = sub.to_str().unwrap();
        let enc = s.replace(' ', "%20").replace('ü', "%C3%BC");
        assert_eq!(
            parse_resource_location(&format!("file://{enc}")).unwrap(),
            sub
        );
        assert_eq!(
            parse_resource_location(&format!("file:{enc}")).unwrap(),
            sub
        );
        assert_eq!(
            parse_resource_location(&format!("file://localhost{enc}")).unwrap(),
            sub
        );
        assert_eq!(parse_resource_location(s).unwrap(), sub);
        assert!(parse_resource_location("file://host/x").is_err());
        assert!(parse_resource_location("http://x/y").is_err());
        assert!(parse_resource_location("/does/not/exist").is_err());
        assert!(parse_resource_location("file:///a%zz").is_err());
    }

    fn instance(version: FmiVersion) -> Instance {
        Instance::new(
            version,
            ModelKind::Planner,
            "test",
            None,
            Logger::new(Callback::None, "test", false),
        )
    }

    fn vr(name: &str) -> u32 {
        table::PLANNER_VARS
            .iter()
            .find(|v| v.name == name)
            .unwrap()
            .vr
    }

    #[test]
    fn refused_multi_value_sets_change_nothing() {
        for version in [FmiVersion::Fmi2, FmiVersion::Fmi3] {
            let mut inst = instance(version);
            let (alt, bw) = (vr("altitude_m"), vr("bandwidth_hz"));
            let e = inst
                .set_real("set", &[alt, bw], &[1100.0, f64::NAN])
                .unwrap_err();
            assert!(e.message.contains("bandwidth_hz"), "{}", e.message);
            assert!(inst
                .set_real("set", &[alt, 999_999], &[1100.0, 1.0])
                .is_err());
            // too few values for the array start_m after a good value
            if version == FmiVersion::Fmi3 {
                assert!(inst
                    .set_real("set", &[alt, vr("start_m")], &[1100.0, 1.0])
                    .is_err());
            }
            assert!(inst
                .set_string(
                    "set",
                    &[vr("mission_file"), alt],
                    &["other.toml".to_string(), "x".to_string()]
                )
                .is_err());
            assert!(inst
                .set_int(
                    "set",
                    &[table::planner_vr::DEBUG_INJECT_PANIC, vr("replan_count")],
                    &[1, 0]
                )
                .is_err());
            inst.enter_initialization("enter", Some((0.0, None)))
                .unwrap();
            let mut out = [0.0];
            inst.get_real("get", &[alt], &mut out).unwrap();
            assert_eq!(out[0], 1000.0, "{version:?}");
            let mut s = [std::ptr::null()];
            inst.get_string("get", &[vr("mission_file")], &mut s)
                .unwrap();
            // SAFETY: get_string hands out NUL-terminated strings that live until the next call.
            let text = unsafe { std::ffi::CStr::from_ptr(s[0]) };
            assert_eq!(text.to_str().unwrap(), "default_mission.toml");
            assert!(
                matches!(&inst.core, Core::Planner(c) if format!("{c:?}").contains("debug_panic: 0"))
            );
            // a good multi-value set applies every value
            inst.set_real("set", &[alt, bw], &[1100.0, 100e6]).unwrap();
            inst.get_real("get", &[bw], &mut out).unwrap();
            assert_eq!(out[0], 100e6);
        }
    }

    #[test]
    fn messages_write_extreme_numbers_short() {
        let mut inst = instance(FmiVersion::Fmi2);
        let e = inst.setup_experiment(0.0, Some(-1e308)).unwrap_err();
        assert_eq!(
            e.message,
            "stop time -1e308 must be finite and not before the start time 0"
        );
        let e = inst
            .set_real("set", &[vr("altitude_m")], &[f64::INFINITY])
            .unwrap_err();
        assert_eq!(
            e.message,
            "parameter `altitude_m` = inf: must be a finite number"
        );
        inst.mode = Mode::Step;
        let e = inst.do_step("doStep", 0.0, -1e-12).unwrap_err();
        assert_eq!(
            e.message,
            "doStep: communication step size must be > 0, got -1e-12"
        );
        let e = inst.do_step("doStep", 1e300, 1.0).unwrap_err();
        assert!(
            e.message.contains("communication point 1e300 s"),
            "{}",
            e.message
        );
    }
}
