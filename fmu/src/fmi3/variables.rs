//! FMI 3 variable access: get/set of each type (those the model has no variables of return an
//! error for a non-empty request), clocks, and variable dependencies.

use super::*;

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
        inst.get_bool("fmi3GetBoolean", vrs, out)?;
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
        inst.set_bool("fmi3SetBoolean", vrs, v)?;
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
