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
#![allow(clippy::too_many_arguments)]

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

/// A get/set of a type the model has no variables of: OK for an empty request, else an error
/// naming the first value reference.
macro_rules! no_variables_of_type {
    ($get:ident, $set:ident, $t:ty, $name:literal) => {
        #[doc = concat!("`", stringify!($get), "`: the model has no ", $name, " variables.")]
        #[no_mangle]
        pub unsafe extern "C" fn $get(
            instance: Fmi3Instance,
            vr: *const Vr,
            nvr: usize,
            _values: *mut $t,
            _n_values: usize,
        ) -> Fmi3Status {
            with_instance(instance, stringify!($get), |_| {
                // SAFETY: FMI contract.
                no_such_type(
                    stringify!($get),
                    unsafe { slice(vr, nvr, "valueReferences") }?,
                    $name,
                )
            })
        }

        #[doc = concat!("`", stringify!($set), "`: the model has no ", $name, " variables.")]
        #[no_mangle]
        pub unsafe extern "C" fn $set(
            instance: Fmi3Instance,
            vr: *const Vr,
            nvr: usize,
            _values: *const $t,
            _n_values: usize,
        ) -> Fmi3Status {
            with_instance(instance, stringify!($set), |_| {
                // SAFETY: FMI contract.
                no_such_type(
                    stringify!($set),
                    unsafe { slice(vr, nvr, "valueReferences") }?,
                    $name,
                )
            })
        }
    };
}

fn no_such_type(func: &str, vrs: &[Vr], ty: &str) -> Result<Status, FmuError> {
    match vrs.first() {
        None => Ok(Status::Ok),
        Some(vr) => Err(FmuError::error(format!(
            "{func}: value reference {vr} is not a {ty} variable (the model has none)"
        ))),
    }
}

no_variables_of_type!(fmi3GetFloat32, fmi3SetFloat32, f32, "Float32");
no_variables_of_type!(fmi3GetInt8, fmi3SetInt8, i8, "Int8");
no_variables_of_type!(fmi3GetUInt8, fmi3SetUInt8, u8, "UInt8");
no_variables_of_type!(fmi3GetInt16, fmi3SetInt16, i16, "Int16");
no_variables_of_type!(fmi3GetUInt16, fmi3SetUInt16, u16, "UInt16");
no_variables_of_type!(fmi3GetUInt32, fmi3SetUInt32, u32, "UInt32");
no_variables_of_type!(fmi3GetInt64, fmi3SetInt64, i64, "Int64");
no_variables_of_type!(fmi3GetUInt64, fmi3SetUInt64, u64, "UInt64");

/// `fmi3GetFloat64` (arrays take one value per element).
#[no_mangle]
pub unsafe extern "C" fn fmi3GetFloat64(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *mut f64,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetFloat64", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(values, n_values, "values") }?;
        inst.get_real("fmi3GetFloat64", vrs, out)?;
        Ok(Status::Ok)
    })
}

/// `fmi3SetFloat64`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetFloat64(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *const f64,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetFloat64", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let v = unsafe { slice(values, n_values, "values") }?;
        inst.set_real("fmi3SetFloat64", vrs, v)?;
        Ok(Status::Ok)
    })
}

/// `fmi3GetInt32`.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetInt32(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *mut i32,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetInt32", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(values, n_values, "values") }?;
        inst.get_int("fmi3GetInt32", vrs, out)?;
        Ok(Status::Ok)
    })
}

/// `fmi3SetInt32`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetInt32(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *const i32,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetInt32", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let v = unsafe { slice(values, n_values, "values") }?;
        inst.set_int("fmi3SetInt32", vrs, v)?;
        Ok(Status::Ok)
    })
}

/// `fmi3GetBoolean`.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetBoolean(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *mut Fmi3Boolean,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetBoolean", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(values, n_values, "values") }?;
        let mut b = vec![false; n_values];
        inst.get_bool("fmi3GetBoolean", vrs, &mut b)?;
        for (o, v) in out.iter_mut().zip(b) {
            *o = u8::from(v);
        }
        Ok(Status::Ok)
    })
}

/// `fmi3SetBoolean`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetBoolean(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *const Fmi3Boolean,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetBoolean", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let v = unsafe { slice(values, n_values, "values") }?;
        let b: Vec<bool> = v.iter().map(|&x| x != 0).collect();
        inst.set_bool("fmi3SetBoolean", vrs, &b)?;
        Ok(Status::Ok)
    })
}

/// `fmi3GetString`: the strings stay valid until the next `fmi3GetString` on this instance.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetString(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *mut *const c_char,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetString", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(values, n_values, "values") }?;
        inst.get_string("fmi3GetString", vrs, out)?;
        Ok(Status::Ok)
    })
}

/// `fmi3SetString`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetString(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    values: *const *const c_char,
    n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetString", |inst| {
        // SAFETY: FMI contract.
        let vrs = unsafe { slice(vr, nvr, "valueReferences") }?;
        // SAFETY: FMI contract.
        let v = unsafe { strings(values, n_values, "values") }?;
        inst.set_string("fmi3SetString", vrs, &v)?;
        Ok(Status::Ok)
    })
}

/// `fmi3GetBinary`: the model has no Binary variables.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetBinary(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    _value_sizes: *mut usize,
    _values: *mut *const u8,
    _n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetBinary", |_| {
        // SAFETY: FMI contract.
        no_such_type(
            "fmi3GetBinary",
            unsafe { slice(vr, nvr, "valueReferences") }?,
            "Binary",
        )
    })
}

/// `fmi3SetBinary`: the model has no Binary variables.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetBinary(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    _value_sizes: *const usize,
    _values: *const *const u8,
    _n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetBinary", |_| {
        // SAFETY: FMI contract.
        no_such_type(
            "fmi3SetBinary",
            unsafe { slice(vr, nvr, "valueReferences") }?,
            "Binary",
        )
    })
}

/// `fmi3GetClock`: the model has no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetClock(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    _values: *mut Fmi3Boolean,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetClock", |_| {
        // SAFETY: FMI contract.
        no_such_type(
            "fmi3GetClock",
            unsafe { slice(vr, nvr, "valueReferences") }?,
            "Clock",
        )
    })
}

/// `fmi3SetClock`: the model has no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetClock(
    instance: Fmi3Instance,
    vr: *const Vr,
    nvr: usize,
    _values: *const Fmi3Boolean,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetClock", |_| {
        // SAFETY: FMI contract.
        no_such_type(
            "fmi3SetClock",
            unsafe { slice(vr, nvr, "valueReferences") }?,
            "Clock",
        )
    })
}

/// `fmi3GetNumberOfVariableDependencies`: not supported (no dependency information).
#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfVariableDependencies(
    instance: Fmi3Instance,
    _vr: Vr,
    _n: *mut usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetNumberOfVariableDependencies", |_| {
        unsupported(
            "fmi3GetNumberOfVariableDependencies",
            "providesPerElementDependencies is false",
        )
    })
}

/// `fmi3GetVariableDependencies`: not supported (no dependency information).
#[no_mangle]
pub unsafe extern "C" fn fmi3GetVariableDependencies(
    instance: Fmi3Instance,
    _dependent: Vr,
    _element_indices_of_dependent: *mut usize,
    _independents: *mut Vr,
    _element_indices_of_independents: *mut usize,
    _dependency_kinds: *mut c_int,
    _n_dependencies: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetVariableDependencies", |_| {
        unsupported(
            "fmi3GetVariableDependencies",
            "providesPerElementDependencies is false",
        )
    })
}

/// `fmi3GetFMUState`: a new state, or the given one overwritten.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetFMUState(
    instance: Fmi3Instance,
    state: *mut *mut c_void,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetFMUState", |inst| {
        // SAFETY: FMI contract.
        let slot = unsafe { state.as_mut() }.ok_or_else(|| FmuError::error("FMUState is NULL"))?;
        get_state(inst, slot)
    })
}

/// `fmi3SetFMUState`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetFMUState(instance: Fmi3Instance, state: *mut c_void) -> Fmi3Status {
    with_instance(instance, "fmi3SetFMUState", |inst| {
        // SAFETY: FMI contract.
        let s = unsafe { StateBox::from_ptr(state) }?;
        let snap = s.snapshot_ref().clone();
        inst.restore(&snap)?;
        Ok(Status::Ok)
    })
}

/// `fmi3FreeFMUState`: frees the state and sets `*state` to NULL.
#[no_mangle]
pub unsafe extern "C" fn fmi3FreeFMUState(
    instance: Fmi3Instance,
    state: *mut *mut c_void,
) -> Fmi3Status {
    with_instance(instance, "fmi3FreeFMUState", |_| {
        // SAFETY: FMI contract.
        let slot = unsafe { state.as_mut() }.ok_or_else(|| FmuError::error("FMUState is NULL"))?;
        if !slot.is_null() {
            // SAFETY: a state from this library, freed once.
            unsafe { StateBox::free(*slot) }?;
            *slot = ptr::null_mut();
        }
        Ok(Status::Ok)
    })
}

/// `fmi3SerializedFMUStateSize`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
    instance: Fmi3Instance,
    state: *mut c_void,
    size: *mut usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SerializedFMUStateSize", |inst| {
        // SAFETY: FMI contract.
        let s = unsafe { StateBox::from_ptr(state) }?;
        let bytes = inst.serialize_state(s.snapshot_ref())?;
        // SAFETY: FMI contract.
        let out = unsafe { size.as_mut() }.ok_or_else(|| FmuError::error("size is NULL"))?;
        *out = bytes.len();
        Ok(Status::Ok)
    })
}

/// `fmi3SerializeFMUState`.
#[no_mangle]
pub unsafe extern "C" fn fmi3SerializeFMUState(
    instance: Fmi3Instance,
    state: *mut c_void,
    serialized: *mut u8,
    size: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SerializeFMUState", |inst| {
        // SAFETY: FMI contract.
        let s = unsafe { StateBox::from_ptr(state) }?;
        let bytes = inst.serialize_state(s.snapshot_ref())?;
        if bytes.len() != size {
            return Err(FmuError::error(format!(
                "the buffer holds {size} bytes, the state needs {} (see fmi3SerializedFMUStateSize)",
                bytes.len()
            )));
        }
        // SAFETY: FMI contract.
        let out = unsafe { slice_mut(serialized, size, "serializedState") }?;
        out.copy_from_slice(&bytes);
        Ok(Status::Ok)
    })
}

/// `fmi3DeserializeFMUState`.
#[no_mangle]
pub unsafe extern "C" fn fmi3DeserializeFMUState(
    instance: Fmi3Instance,
    serialized: *const u8,
    size: usize,
    state: *mut *mut c_void,
) -> Fmi3Status {
    with_instance(instance, "fmi3DeserializeFMUState", |inst| {
        // SAFETY: FMI contract.
        let bytes = unsafe { slice(serialized, size, "serializedState") }?;
        let snap = inst.deserialize_state(bytes)?;
        // SAFETY: FMI contract.
        let slot = unsafe { state.as_mut() }.ok_or_else(|| FmuError::error("FMUState is NULL"))?;
        if !slot.is_null() {
            // SAFETY: an existing state of this library is replaced.
            unsafe { StateBox::free(*slot) }?;
        }
        *slot = StateBox::into_raw(snap);
        Ok(Status::Ok)
    })
}

/// `fmi3GetDirectionalDerivative`: not supported.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetDirectionalDerivative(
    instance: Fmi3Instance,
    _unknowns: *const Vr,
    _n_unknowns: usize,
    _knowns: *const Vr,
    _n_knowns: usize,
    _seed: *const f64,
    _n_seed: usize,
    _sensitivity: *mut f64,
    _n_sensitivity: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetDirectionalDerivative", |_| {
        unsupported(
            "fmi3GetDirectionalDerivative",
            "providesDirectionalDerivatives is false",
        )
    })
}

/// `fmi3GetAdjointDerivative`: not supported.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetAdjointDerivative(
    instance: Fmi3Instance,
    _unknowns: *const Vr,
    _n_unknowns: usize,
    _knowns: *const Vr,
    _n_knowns: usize,
    _seed: *const f64,
    _n_seed: usize,
    _sensitivity: *mut f64,
    _n_sensitivity: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetAdjointDerivative", |_| {
        unsupported(
            "fmi3GetAdjointDerivative",
            "providesAdjointDerivatives is false",
        )
    })
}

/// `fmi3EnterConfigurationMode`: not supported (no structural parameters).
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterConfigurationMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EnterConfigurationMode", |_| {
        unsupported(
            "fmi3EnterConfigurationMode",
            "the model has no structural parameters",
        )
    })
}

/// `fmi3ExitConfigurationMode`: not supported (no structural parameters).
#[no_mangle]
pub unsafe extern "C" fn fmi3ExitConfigurationMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3ExitConfigurationMode", |_| {
        unsupported(
            "fmi3ExitConfigurationMode",
            "the model has no structural parameters",
        )
    })
}

/// `fmi3GetIntervalDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetIntervalDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _intervals: *mut f64,
    _qualifiers: *mut c_int,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetIntervalDecimal", |_| {
        unsupported("fmi3GetIntervalDecimal", NO_CLOCKS)
    })
}

/// `fmi3GetIntervalFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetIntervalFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *mut u64,
    _resolutions: *mut u64,
    _qualifiers: *mut c_int,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetIntervalFraction", |_| {
        unsupported("fmi3GetIntervalFraction", NO_CLOCKS)
    })
}

/// `fmi3GetShiftDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetShiftDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _shifts: *mut f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetShiftDecimal", |_| {
        unsupported("fmi3GetShiftDecimal", NO_CLOCKS)
    })
}

/// `fmi3GetShiftFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetShiftFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *mut u64,
    _resolutions: *mut u64,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetShiftFraction", |_| {
        unsupported("fmi3GetShiftFraction", NO_CLOCKS)
    })
}

/// `fmi3SetIntervalDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetIntervalDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _intervals: *const f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetIntervalDecimal", |_| {
        unsupported("fmi3SetIntervalDecimal", NO_CLOCKS)
    })
}

/// `fmi3SetIntervalFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetIntervalFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *const u64,
    _resolutions: *const u64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetIntervalFraction", |_| {
        unsupported("fmi3SetIntervalFraction", NO_CLOCKS)
    })
}

/// `fmi3SetShiftDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetShiftDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _shifts: *const f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetShiftDecimal", |_| {
        unsupported("fmi3SetShiftDecimal", NO_CLOCKS)
    })
}

/// `fmi3SetShiftFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetShiftFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *const u64,
    _resolutions: *const u64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetShiftFraction", |_| {
        unsupported("fmi3SetShiftFraction", NO_CLOCKS)
    })
}

/// `fmi3EvaluateDiscreteStates`: no event mode.
#[no_mangle]
pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EvaluateDiscreteStates", |_| {
        unsupported("fmi3EvaluateDiscreteStates", NO_EVENT_MODE)
    })
}

/// `fmi3UpdateDiscreteStates`: no event mode.
#[no_mangle]
pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
    instance: Fmi3Instance,
    _discrete_states_need_update: *mut Fmi3Boolean,
    _terminate_simulation: *mut Fmi3Boolean,
    _nominals_changed: *mut Fmi3Boolean,
    _values_changed: *mut Fmi3Boolean,
    _next_event_time_defined: *mut Fmi3Boolean,
    _next_event_time: *mut f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3UpdateDiscreteStates", |_| {
        unsupported("fmi3UpdateDiscreteStates", NO_EVENT_MODE)
    })
}

/// `fmi3EnterContinuousTimeMode`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EnterContinuousTimeMode", |_| {
        unsupported("fmi3EnterContinuousTimeMode", CS_ONLY)
    })
}

/// `fmi3CompletedIntegratorStep`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3CompletedIntegratorStep(
    instance: Fmi3Instance,
    _no_set_fmu_state_prior_to_current_point: Fmi3Boolean,
    _enter_event_mode: *mut Fmi3Boolean,
    _terminate_simulation: *mut Fmi3Boolean,
) -> Fmi3Status {
    with_instance(instance, "fmi3CompletedIntegratorStep", |_| {
        unsupported("fmi3CompletedIntegratorStep", CS_ONLY)
    })
}

/// `fmi3SetTime`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetTime(instance: Fmi3Instance, _time: f64) -> Fmi3Status {
    with_instance(instance, "fmi3SetTime", |_| {
        unsupported("fmi3SetTime", CS_ONLY)
    })
}

/// `fmi3SetContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetContinuousStates(
    instance: Fmi3Instance,
    _states: *const f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetContinuousStates", |_| {
        unsupported("fmi3SetContinuousStates", CS_ONLY)
    })
}

/// `fmi3GetContinuousStateDerivatives`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetContinuousStateDerivatives(
    instance: Fmi3Instance,
    _derivatives: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetContinuousStateDerivatives", |_| {
        unsupported("fmi3GetContinuousStateDerivatives", CS_ONLY)
    })
}

/// `fmi3GetEventIndicators`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetEventIndicators(
    instance: Fmi3Instance,
    _indicators: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetEventIndicators", |_| {
        unsupported("fmi3GetEventIndicators", CS_ONLY)
    })
}

/// `fmi3GetContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetContinuousStates(
    instance: Fmi3Instance,
    _states: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetContinuousStates", |_| {
        unsupported("fmi3GetContinuousStates", CS_ONLY)
    })
}

/// `fmi3GetNominalsOfContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetNominalsOfContinuousStates(
    instance: Fmi3Instance,
    _nominals: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetNominalsOfContinuousStates", |_| {
        unsupported("fmi3GetNominalsOfContinuousStates", CS_ONLY)
    })
}

/// `fmi3GetNumberOfEventIndicators`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(
    instance: Fmi3Instance,
    _n: *mut usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetNumberOfEventIndicators", |_| {
        unsupported("fmi3GetNumberOfEventIndicators", CS_ONLY)
    })
}

/// `fmi3GetNumberOfContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(
    instance: Fmi3Instance,
    _n: *mut usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetNumberOfContinuousStates", |_| {
        unsupported("fmi3GetNumberOfContinuousStates", CS_ONLY)
    })
}

/// `fmi3EnterStepMode`: no event mode (ExitInitializationMode enters Step Mode directly).
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterStepMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EnterStepMode", |_| {
        unsupported("fmi3EnterStepMode", NO_EVENT_MODE)
    })
}

/// `fmi3GetOutputDerivatives`: not supported (maxOutputDerivativeOrder = 0).
#[no_mangle]
pub unsafe extern "C" fn fmi3GetOutputDerivatives(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _orders: *const i32,
    _values: *mut f64,
    _n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetOutputDerivatives", |_| {
        unsupported("fmi3GetOutputDerivatives", "maxOutputDerivativeOrder is 0")
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

/// `fmi3ActivateModelPartition`: scheduled execution only.
#[no_mangle]
pub unsafe extern "C" fn fmi3ActivateModelPartition(
    instance: Fmi3Instance,
    _clock_reference: Vr,
    _activation_time: f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3ActivateModelPartition", |_| {
        unsupported(
            "fmi3ActivateModelPartition",
            "scheduled execution is not supported",
        )
    })
}
