//! FMI 3 FMU states: get, set, free, serialize and deserialize.

use super::*;

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
