//! The FMI 2.0 co-simulation C API: all 34 functions of `fmi2Functions.h` that a co-simulation
//! importer looks up. Each one checks its instance pointer and the call sequence, runs behind
//! `catch_unwind`, and reports errors through the logger with an error status.
//!
//! # Safety
//! Every function is `unsafe extern "C"`: the importer must pass the pointers the FMI 2.0
//! standard describes (instances from `fmi2Instantiate`, arrays of the announced length,
//! NUL-terminated strings) and must not call one instance from two threads at once.
#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_int, c_uint, c_void};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

use crate::core::Log;
use crate::core::{guid, FmiVersion, FmuError, Status, MODELS};
use crate::ffi::{code, panic_message, slice, slice_mut, string, strings, with_instance};
use crate::instance::{
    parse_resource_location, Callback, Fmi2Logger, Instance, Logger, Mode, StateBox,
};
use crate::table::Category;

/// `fmi2Component`.
pub type Fmi2Component = *mut c_void;
/// `fmi2Status` as returned to C.
pub type Fmi2Status = c_int;
/// `fmi2Boolean`.
pub type Fmi2Boolean = c_int;
/// `fmi2ValueReference`.
pub type Fmi2ValueReference = c_uint;

/// `fmi2CallbackFunctions`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct Fmi2CallbackFunctions {
    /// Logger (printf-style).
    pub logger: Option<Fmi2Logger>,
    /// Memory allocation (not used: the FMU uses Rust's allocator).
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    /// Memory release (not used).
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    /// Asynchronous step callback (not used: doStep is synchronous).
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    /// Passed back to the logger.
    pub component_environment: *mut c_void,
}

const CO_SIMULATION: c_int = 1;

static TYPES_PLATFORM: &[u8] = b"default\0";
static VERSION: &[u8] = b"2.0\0";

/// `fmi2GetTypesPlatform`: "default".
#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    TYPES_PLATFORM.as_ptr().cast()
}

/// `fmi2GetVersion`: "2.0".
#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    VERSION.as_ptr().cast()
}

/// `fmi2SetDebugLogging`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const *const c_char,
) -> Fmi2Status {
    with_instance(c, "fmi2SetDebugLogging", |inst| {
        // SAFETY: FMI contract: `n_categories` C strings.
        let names = unsafe { strings(categories, n_categories, "categories") }?;
        inst.logger.set_debug(logging_on != 0, &names)?;
        Ok(Status::Ok)
    })
}

/// `fmi2Instantiate`: co-simulation only; checks the name, the GUID and the resource location.
/// Returns NULL (after logging why) when the instance cannot be created.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    fmu_guid: *const c_char,
    fmu_resource_location: *const c_char,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let result = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: FMI contract: NULL or a valid callback struct.
        let callbacks = unsafe { functions.as_ref() }.copied();
        let callback = match callbacks.and_then(|f| f.logger.map(|l| (l, f.component_environment)))
        {
            Some((l, env)) => Callback::Fmi2(l, env),
            None => Callback::None,
        };
        // SAFETY: FMI contract: NUL-terminated strings or NULL.
        let name = unsafe { string(instance_name) }.unwrap_or_default();
        let logger = Logger::new(callback, &name, logging_on != 0);
        let fail = |msg: String| {
            logger.log(
                Category::Error,
                Status::Error,
                &format!("fmi2Instantiate: {msg}"),
            );
            ptr::null_mut()
        };
        if callbacks.is_none() {
            return ptr::null_mut();
        }
        if name.trim().is_empty() {
            return fail("the instance name is empty".into());
        }
        if fmu_type != CO_SIMULATION {
            return fail(format!(
                "fmuType {fmu_type} is not supported: this FMU implements co-simulation only (fmi2CoSimulation = 1)"
            ));
        }
        // SAFETY: as above.
        let Some(given) = (unsafe { string(fmu_guid) }) else {
            return fail("the GUID is NULL".into());
        };
        let Some(info) = MODELS.iter().find(|m| guid(m, FmiVersion::Fmi2) == given) else {
            return fail(format!(
                "wrong GUID `{given}`: expected {}",
                MODELS
                    .iter()
                    .map(|m| format!("{} for {}", guid(m, FmiVersion::Fmi2), m.identifier))
                    .collect::<Vec<_>>()
                    .join(" or ")
            ));
        };
        // SAFETY: as above.
        let resources = match unsafe { string(fmu_resource_location) } {
            None => {
                logger.log(
                    Category::Warning,
                    Status::Warning,
                    "fmi2Instantiate: no resource location given: a relative mission_file is looked up in the working directory only",
                );
                None
            }
            Some(loc) => match parse_resource_location(&loc) {
                Ok(p) => Some(p),
                Err(why) => {
                    logger.log(
                        Category::Warning,
                        Status::Warning,
                        &format!("fmi2Instantiate: resource location unusable ({why}): a relative mission_file is looked up in the working directory only"),
                    );
                    None
                }
            },
        };
        let inst = Instance::new(FmiVersion::Fmi2, info.kind, &name, resources, logger);
        inst.log(
            Category::Events,
            Status::Ok,
            &format!("instantiated {} ({})", info.identifier, inst.guid()),
        );
        inst.into_raw()
    }));
    match result {
        Ok(p) => p,
        Err(payload) => {
            let _ = panic_message(payload.as_ref());
            ptr::null_mut()
        }
    }
}

/// `fmi2FreeInstance`.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: FMI contract: a pointer from fmi2Instantiate, not used afterwards.
        unsafe { Instance::free(c) };
    }));
}

/// `fmi2SetupExperiment`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Fmi2Component,
    _tolerance_defined: Fmi2Boolean,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: Fmi2Boolean,
    stop_time: f64,
) -> Fmi2Status {
    with_instance(c, "fmi2SetupExperiment", |inst| {
        inst.setup_experiment(start_time, (stop_time_defined != 0).then_some(stop_time))?;
        Ok(Status::Ok)
    })
}

/// `fmi2EnterInitializationMode`.
#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2EnterInitializationMode", |inst| {
        inst.enter_initialization("fmi2EnterInitializationMode", None)?;
        Ok(Status::Ok)
    })
}

/// `fmi2ExitInitializationMode`: plans the mission.
#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2ExitInitializationMode", |inst| {
        inst.exit_initialization("fmi2ExitInitializationMode")?;
        Ok(Status::Ok)
    })
}

/// `fmi2Terminate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2Terminate", |inst| {
        inst.terminate("fmi2Terminate")?;
        Ok(Status::Ok)
    })
}

/// `fmi2Reset`.
#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2Reset", |inst| {
        inst.reset();
        Ok(Status::Ok)
    })
}

/// `fmi2GetReal`.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut f64,
) -> Fmi2Status {
    with_instance(c, "fmi2GetReal", |inst| {
        // SAFETY: FMI contract: `nvr` elements each.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: as above.
        let out = unsafe { slice_mut(value, nvr, "value") }?;
        inst.get_real("fmi2GetReal", vrs, out)?;
        Ok(Status::Ok)
    })
}

/// `fmi2GetInteger`.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut c_int,
) -> Fmi2Status {
    with_instance(c, "fmi2GetInteger", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(value, nvr, "value") }?;
        inst.get_int("fmi2GetInteger", vrs, out)?;
        Ok(Status::Ok)
    })
}

/// `fmi2GetBoolean`.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2GetBoolean", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(value, nvr, "value") }?;
        inst.get_bool("fmi2GetBoolean", vrs, out)?;
        Ok(Status::Ok)
    })
}

/// `fmi2GetString`: the strings stay valid until the next `fmi2GetString` on this instance.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut *const c_char,
) -> Fmi2Status {
    with_instance(c, "fmi2GetString", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(value, nvr, "value") }?;
        inst.get_string("fmi2GetString", vrs, out)?;
        Ok(Status::Ok)
    })
}

/// `fmi2SetReal`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const f64,
) -> Fmi2Status {
    with_instance(c, "fmi2SetReal", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: FMI contract.
        let values = unsafe { slice(value, nvr, "value") }?;
        inst.set_real("fmi2SetReal", vrs, values)?;
        Ok(Status::Ok)
    })
}

/// `fmi2SetInteger`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const c_int,
) -> Fmi2Status {
    with_instance(c, "fmi2SetInteger", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: FMI contract.
        let values = unsafe { slice(value, nvr, "value") }?;
        inst.set_int("fmi2SetInteger", vrs, values)?;
        Ok(Status::Ok)
    })
}

/// `fmi2SetBoolean`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2SetBoolean", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: FMI contract.
        let values = unsafe { slice(value, nvr, "value") }?;
        inst.set_bool("fmi2SetBoolean", vrs, values)?;
        Ok(Status::Ok)
    })
}

/// `fmi2SetString`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const *const c_char,
) -> Fmi2Status {
    with_instance(c, "fmi2SetString", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: FMI contract.
        let values = unsafe { strings(value, nvr, "value") }?;
        inst.set_string("fmi2SetString", vrs, &values)?;
        Ok(Status::Ok)
    })
}

/// `fmi2GetFMUstate`: a new state, or the given one overwritten.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Fmi2Component, state: *mut *mut c_void) -> Fmi2Status {
    with_instance(c, "fmi2GetFMUstate", |inst| {
        // SAFETY: FMI contract: a writable pointer.
        let slot = unsafe { state.as_mut() }.ok_or_else(|| FmuError::error("FMUstate is NULL"))?;
        get_state(inst, slot)
    })
}

/// Stores the instance's state in `*slot` (reusing an existing state object).
pub(crate) fn get_state(inst: &Instance, slot: &mut *mut c_void) -> Result<Status, FmuError> {
    let snap = inst.snapshot();
    if slot.is_null() {
        *slot = StateBox::into_raw(snap);
    } else {
        // SAFETY: a non-NULL state must come from this library.
        unsafe { StateBox::from_ptr(*slot) }?.replace(snap);
    }
    Ok(Status::Ok)
}

/// `fmi2SetFMUstate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, state: *mut c_void) -> Fmi2Status {
    with_instance(c, "fmi2SetFMUstate", |inst| {
        // SAFETY: FMI contract: a state from fmi2GetFMUstate.
        let s = unsafe { StateBox::from_ptr(state) }?;
        let snap = s.snapshot_ref().clone();
        inst.restore(&snap)?;
        Ok(Status::Ok)
    })
}

/// `fmi2FreeFMUstate`: frees the state and sets `*state` to NULL.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Fmi2Component, state: *mut *mut c_void) -> Fmi2Status {
    with_instance(c, "fmi2FreeFMUstate", |_inst| {
        // SAFETY: FMI contract.
        let slot = unsafe { state.as_mut() }.ok_or_else(|| FmuError::error("FMUstate is NULL"))?;
        if !slot.is_null() {
            // SAFETY: a state from this library, freed once.
            unsafe { StateBox::free(*slot) }?;
            *slot = ptr::null_mut();
        }
        Ok(Status::Ok)
    })
}

/// `fmi2SerializedFMUstateSize`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Fmi2Component,
    state: *mut c_void,
    size: *mut usize,
) -> Fmi2Status {
    with_instance(c, "fmi2SerializedFMUstateSize", |inst| {
        // SAFETY: FMI contract.
        let s = unsafe { StateBox::from_ptr(state) }?;
        let bytes = inst.serialize_state(s.snapshot_ref())?;
        // SAFETY: FMI contract: writable.
        let out = unsafe { size.as_mut() }.ok_or_else(|| FmuError::error("size is NULL"))?;
        *out = bytes.len();
        Ok(Status::Ok)
    })
}

/// `fmi2SerializeFMUstate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Fmi2Component,
    state: *mut c_void,
    serialized: *mut u8,
    size: usize,
) -> Fmi2Status {
    with_instance(c, "fmi2SerializeFMUstate", |inst| {
        // SAFETY: FMI contract.
        let s = unsafe { StateBox::from_ptr(state) }?;
        let bytes = inst.serialize_state(s.snapshot_ref())?;
        if bytes.len() != size {
            return Err(FmuError::error(format!(
                "the buffer holds {size} bytes, the state needs {} (see fmi2SerializedFMUstateSize)",
                bytes.len()
            )));
        }
        // SAFETY: FMI contract: `size` writable bytes.
        let out = unsafe { slice_mut(serialized, size, "serializedState") }?;
        out.copy_from_slice(&bytes);
        Ok(Status::Ok)
    })
}

/// `fmi2DeSerializeFMUstate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Fmi2Component,
    serialized: *const u8,
    size: usize,
    state: *mut *mut c_void,
) -> Fmi2Status {
    with_instance(c, "fmi2DeSerializeFMUstate", |inst| {
        // SAFETY: FMI contract.
        let bytes = unsafe { slice(serialized, size, "serializedState") }?;
        let snap = inst.deserialize_state(bytes)?;
        // SAFETY: FMI contract.
        let slot = unsafe { state.as_mut() }.ok_or_else(|| FmuError::error("FMUstate is NULL"))?;
        if !slot.is_null() {
            // SAFETY: an existing state of this library is replaced.
            unsafe { StateBox::free(*slot) }?;
        }
        *slot = StateBox::into_raw(snap);
        Ok(Status::Ok)
    })
}

fn unsupported(func: &str, why: &str) -> Result<Status, FmuError> {
    Err(FmuError::error(format!("{func} is not supported: {why}")))
}

/// `fmi2GetDirectionalDerivative`: not supported (providesDirectionalDerivative = false).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Fmi2Component,
    _v_unknown_ref: *const Fmi2ValueReference,
    _n_unknown: usize,
    _v_known_ref: *const Fmi2ValueReference,
    _n_known: usize,
    _dv_known: *const f64,
    _dv_unknown: *mut f64,
) -> Fmi2Status {
    with_instance(c, "fmi2GetDirectionalDerivative", |_| {
        unsupported(
            "fmi2GetDirectionalDerivative",
            "providesDirectionalDerivative is false",
        )
    })
}

/// `fmi2SetRealInputDerivatives`: not supported (canInterpolateInputs = false).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const c_int,
    _value: *const f64,
) -> Fmi2Status {
    with_instance(c, "fmi2SetRealInputDerivatives", |_| {
        unsupported(
            "fmi2SetRealInputDerivatives",
            "canInterpolateInputs is false",
        )
    })
}

/// `fmi2GetRealOutputDerivatives`: not supported (maxOutputDerivativeOrder = 0).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const c_int,
    _value: *mut f64,
) -> Fmi2Status {
    with_instance(c, "fmi2GetRealOutputDerivatives", |_| {
        unsupported(
            "fmi2GetRealOutputDerivatives",
            "maxOutputDerivativeOrder is 0",
        )
    })
}

/// `fmi2DoStep`: synchronous; may re-plan when a landmark input moved.
#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Fmi2Component,
    current_communication_point: f64,
    communication_step_size: f64,
    _no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2DoStep", |inst| {
        let out = inst.do_step(
            "fmi2DoStep",
            current_communication_point,
            communication_step_size,
        )?;
        Ok(out.status)
    })
}

/// `fmi2CancelStep`: doStep never returns fmi2Pending, so there is nothing to cancel.
#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2CancelStep", |_| {
        unsupported(
            "fmi2CancelStep",
            "fmi2DoStep is synchronous and never returns fmi2Pending",
        )
    })
}

const DO_STEP_STATUS: c_int = 0;
const PENDING_STATUS: c_int = 1;
const LAST_SUCCESSFUL_TIME: c_int = 2;
const TERMINATED: c_int = 3;

fn status_kind_error(func: &str, kind: c_int) -> FmuError {
    FmuError {
        status: Status::Discard,
        message: format!("{func}: status kind {kind} is not provided by this function"),
    }
}

/// `fmi2GetStatus`: `fmi2DoStepStatus` is OK (doStep is synchronous).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(
    c: Fmi2Component,
    kind: c_int,
    value: *mut c_int,
) -> Fmi2Status {
    with_instance(c, "fmi2GetStatus", |inst| {
        inst.require(
            "fmi2GetStatus",
            &[Mode::Step, Mode::Terminated, Mode::Error],
        )?;
        // SAFETY: FMI contract.
        let out = unsafe { value.as_mut() }.ok_or_else(|| FmuError::error("value is NULL"))?;
        match kind {
            DO_STEP_STATUS | PENDING_STATUS => {
                *out = code(Status::Ok);
                Ok(Status::Ok)
            }
            _ => Err(status_kind_error("fmi2GetStatus", kind)),
        }
    })
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime`.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(
    c: Fmi2Component,
    kind: c_int,
    value: *mut f64,
) -> Fmi2Status {
    with_instance(c, "fmi2GetRealStatus", |inst| {
        inst.require(
            "fmi2GetRealStatus",
            &[Mode::Step, Mode::Terminated, Mode::Error],
        )?;
        // SAFETY: FMI contract.
        let out = unsafe { value.as_mut() }.ok_or_else(|| FmuError::error("value is NULL"))?;
        match kind {
            LAST_SUCCESSFUL_TIME => {
                *out = inst.time();
                Ok(Status::Ok)
            }
            _ => Err(status_kind_error("fmi2GetRealStatus", kind)),
        }
    })
}

/// `fmi2GetIntegerStatus`: no integer status is provided.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Fmi2Component,
    kind: c_int,
    _value: *mut c_int,
) -> Fmi2Status {
    with_instance(c, "fmi2GetIntegerStatus", |_| {
        Err(status_kind_error("fmi2GetIntegerStatus", kind))
    })
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` (true once the horizon ended a step).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2GetBooleanStatus", |inst| {
        inst.require(
            "fmi2GetBooleanStatus",
            &[Mode::Step, Mode::Terminated, Mode::Error],
        )?;
        // SAFETY: FMI contract.
        let out = unsafe { value.as_mut() }.ok_or_else(|| FmuError::error("value is NULL"))?;
        match kind {
            TERMINATED => {
                *out = Fmi2Boolean::from(inst.terminated);
                Ok(Status::Ok)
            }
            _ => Err(status_kind_error("fmi2GetBooleanStatus", kind)),
        }
    })
}

/// `fmi2GetStringStatus`: no string status is provided.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Fmi2Component,
    kind: c_int,
    _value: *mut *const c_char,
) -> Fmi2Status {
    with_instance(c, "fmi2GetStringStatus", |_| {
        Err(status_kind_error("fmi2GetStringStatus", kind))
    })
}
