//! The FMI 3.0 C API: all functions of `fmi3Functions.h` (75), as fmpy looks them up. The FMU
//! implements co-simulation without event mode; model exchange, scheduled execution, clocks,
//! configuration mode, derivatives and the variable types it has no variables of return an error
//! (with a log message) or, for an empty request, OK. Each function checks its instance pointer
//! and the call sequence and runs behind `catch_unwind`.
//!
//! # Safety
//! Every function is `unsafe extern "C"`: the importer must pass the pointers the FMI 3.0
//! standard describes and must not call one instance from two threads at once.
#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_int, c_uint, c_void};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

use crate::core::{guid, FmiVersion, FmuError, Status, MODELS};
use crate::ffi::{slice, slice_mut, string, strings, with_instance};
use crate::fmi2::get_state;
use crate::instance::{parse_resource_location, Callback, Fmi3Logger, Instance, Logger, StateBox};
use crate::table::Category;

/// `fmi3Instance`.
pub type Fmi3Instance = *mut c_void;
/// `fmi3Status`.
pub type Fmi3Status = c_int;
/// `fmi3ValueReference`.
pub type Vr = c_uint;
/// `fmi3Boolean` read as a byte (any non-zero value is true).
pub type Fmi3Boolean = u8;

static VERSION: &[u8] = b"3.0\0";

/// `fmi3GetVersion`: "3.0".
#[no_mangle]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    VERSION.as_ptr().cast()
}

/// `fmi3SetDebugLogging`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetDebugLogging(
    instance: Fmi3Instance,
    logging_on: Fmi3Boolean,
    n_categories: usize,
    categories: *const *const c_char,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetDebugLogging", |inst| {
        // SAFETY: FMI contract.
        let names = unsafe { strings(categories, n_categories, "categories") }?;
        inst.logger.set_debug(logging_on != 0, &names)?;
        Ok(Status::Ok)
    })
}

fn refuse_instantiate(
    func: &str,
    log: Option<Fmi3Logger>,
    env: *mut c_void,
    name: &str,
    why: &str,
) -> Fmi3Instance {
    let callback = log.map_or(Callback::None, |l| Callback::Fmi3(l, env));
    Logger::new(callback, name, false).log_now(&format!("{func}: {why}"));
    ptr::null_mut()
}

/// `fmi3InstantiateModelExchange`: not supported (co-simulation only); returns NULL.
#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateModelExchange(
    instance_name: *const c_char,
    _instantiation_token: *const c_char,
    _resource_path: *const c_char,
    _visible: Fmi3Boolean,
    _logging_on: Fmi3Boolean,
    instance_environment: *mut c_void,
    log_message: Option<Fmi3Logger>,
) -> Fmi3Instance {
    catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: FMI contract.
        let name = unsafe { string(instance_name) }.unwrap_or_default();
        refuse_instantiate(
            "fmi3InstantiateModelExchange",
            log_message,
            instance_environment,
            &name,
            "model exchange is not supported: this FMU implements co-simulation only",
        )
    }))
    .unwrap_or(ptr::null_mut())
}

/// `fmi3InstantiateScheduledExecution`: not supported; returns NULL.
#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
    instance_name: *const c_char,
    _instantiation_token: *const c_char,
    _resource_path: *const c_char,
    _visible: Fmi3Boolean,
    _logging_on: Fmi3Boolean,
    instance_environment: *mut c_void,
    log_message: Option<Fmi3Logger>,
    _clock_update: *mut c_void,
    _lock_preemption: *mut c_void,
    _unlock_preemption: *mut c_void,
) -> Fmi3Instance {
    catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: FMI contract.
        let name = unsafe { string(instance_name) }.unwrap_or_default();
        refuse_instantiate(
            "fmi3InstantiateScheduledExecution",
            log_message,
            instance_environment,
            &name,
            "scheduled execution is not supported: this FMU implements co-simulation only",
        )
    }))
    .unwrap_or(ptr::null_mut())
}

/// `fmi3InstantiateCoSimulation`: checks the name, the instantiation token and the resource path;
/// event mode and intermediate updates are not supported. Returns NULL (after logging why) when
/// the instance cannot be created.
#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
    instance_name: *const c_char,
    instantiation_token: *const c_char,
    resource_path: *const c_char,
    _visible: Fmi3Boolean,
    logging_on: Fmi3Boolean,
    event_mode_used: Fmi3Boolean,
    _early_return_allowed: Fmi3Boolean,
    _required_intermediate_variables: *const Vr,
    n_required_intermediate_variables: usize,
    instance_environment: *mut c_void,
    log_message: Option<Fmi3Logger>,
    _intermediate_update: *mut c_void,
) -> Fmi3Instance {
    catch_unwind(AssertUnwindSafe(|| {
        const F: &str = "fmi3InstantiateCoSimulation";
        // SAFETY: FMI contract.
        let name = unsafe { string(instance_name) }.unwrap_or_default();
        let fail = |why: String| {
            refuse_instantiate(F, log_message, instance_environment, &name, &why)
        };
        if name.trim().is_empty() {
            return fail("the instance name is empty".into());
        }
        if event_mode_used != 0 {
            return fail("eventModeUsed must be false: the FMU has no event mode (hasEventMode = false)".into());
        }
        if n_required_intermediate_variables != 0 {
            return fail("requiredIntermediateVariables must be empty: the FMU provides no intermediate update".into());
        }
        // SAFETY: FMI contract.
        let Some(given) = (unsafe { string(instantiation_token) }) else {
            return fail("the instantiation token is NULL".into());
        };
        let Some(info) = MODELS.iter().find(|m| guid(m, FmiVersion::Fmi3) == given) else {
            return fail(format!(
                "wrong instantiation token `{given}`: expected {}",
                MODELS
                    .iter()
                    .map(|m| format!("{} for {}", guid(m, FmiVersion::Fmi3), m.identifier))
                    .collect::<Vec<_>>()
                    .join(" or ")
            ));
        };
        let callback = log_message.map_or(Callback::None, |l| Callback::Fmi3(l, instance_environment));
        let logger = Logger::new(callback, &name, logging_on != 0);
        // SAFETY: FMI contract.
        let resources = match unsafe { string(resource_path) } {
            None => {
                logger.log_warning(&format!("{F}: no resource path given: a relative mission_file is looked up in the working directory only"));
                None
            }
            Some(p) => match parse_resource_location(&p) {
                Ok(p) => Some(p),
                Err(why) => {
                    logger.log_warning(&format!("{F}: resource path unusable ({why}): a relative mission_file is looked up in the working directory only"));
                    None
                }
            },
        };
        let inst = Instance::new(FmiVersion::Fmi3, info.kind, &name, resources, logger);
        inst.log(
            Category::Events,
            Status::Ok,
            &format!("instantiated {} ({})", info.identifier, inst.guid()),
        );
        inst.into_raw()
    }))
    .unwrap_or(ptr::null_mut())
}

/// `fmi3FreeInstance`.
#[no_mangle]
pub unsafe extern "C" fn fmi3FreeInstance(instance: Fmi3Instance) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: FMI contract: from instantiate, not used afterwards.
        unsafe { Instance::free(instance) };
    }));
}

/// `fmi3EnterInitializationMode`.
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterInitializationMode(
    instance: Fmi3Instance,
    _tolerance_defined: Fmi3Boolean,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: Fmi3Boolean,
    stop_time: f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3EnterInitializationMode", |inst| {
        inst.enter_initialization(
            "fmi3EnterInitializationMode",
            Some((start_time, (stop_time_defined != 0).then_some(stop_time))),
        )?;
        Ok(Status::Ok)
    })
}

/// `fmi3ExitInitializationMode`: plans the mission; the instance enters Step Mode.
#[no_mangle]
pub unsafe extern "C" fn fmi3ExitInitializationMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3ExitInitializationMode", |inst| {
        inst.exit_initialization("fmi3ExitInitializationMode")?;
        Ok(Status::Ok)
    })
}

fn unsupported(func: &str, why: &str) -> Result<Status, FmuError> {
    Err(FmuError::error(format!("{func} is not supported: {why}")))
}

const NO_EVENT_MODE: &str = "the FMU has no event mode (hasEventMode = false)";
const CS_ONLY: &str = "model exchange is not supported (co-simulation only)";
const NO_CLOCKS: &str = "the FMU has no clocks";

/// `fmi3EnterEventMode`: not supported (no event mode).
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterEventMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EnterEventMode", |_| {
        unsupported("fmi3EnterEventMode", NO_EVENT_MODE)
    })
}

/// `fmi3Terminate`.
#[no_mangle]
pub unsafe extern "C" fn fmi3Terminate(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3Terminate", |inst| {
        inst.terminate("fmi3Terminate")?;
        Ok(Status::Ok)
    })
}

/// `fmi3Reset`.
#[no_mangle]
pub unsafe extern "C" fn fmi3Reset(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3Reset", |inst| {
        inst.reset();
        Ok(Status::Ok)
    })
}

/// `fmi3EnterStepMode`: no event mode (ExitInitializationMode enters Step Mode directly).
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterStepMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EnterStepMode", |_| {
        unsupported("fmi3EnterStepMode", NO_EVENT_MODE)
    })
}

/// `fmi3DoStep`: synchronous; may re-plan when a landmark input moved. Past the mission horizon
/// the step stops there with `terminateSimulation` set and status Discard.
#[no_mangle]
pub unsafe extern "C" fn fmi3DoStep(
    instance: Fmi3Instance,
    current_communication_point: f64,
    communication_step_size: f64,
    _no_set_fmu_state_prior_to_current_point: Fmi3Boolean,
    event_handling_needed: *mut Fmi3Boolean,
    terminate_simulation: *mut Fmi3Boolean,
    early_return: *mut Fmi3Boolean,
    last_successful_time: *mut f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3DoStep", |inst| {
        let out = inst.do_step(
            "fmi3DoStep",
            current_communication_point,
            communication_step_size,
        )?;
        // SAFETY: FMI contract: writable (NULL tolerated).
        unsafe {
            if let Some(p) = event_handling_needed.as_mut() {
                *p = 0;
            }
            if let Some(p) = terminate_simulation.as_mut() {
                *p = u8::from(out.terminate);
            }
            if let Some(p) = early_return.as_mut() {
                *p = 0;
            }
            if let Some(p) = last_successful_time.as_mut() {
                *p = out.last_successful_time;
            }
        }
        Ok(out.status)
    })
}

mod state;
mod unsupported;
mod variables;

pub use state::*;
pub use unsupported::*;
pub use variables::*;
