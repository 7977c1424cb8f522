//! Helpers shared by the FMI 2 and FMI 3 entry points: the panic guard, instance and array
//! pointer checks, C string conversion.

use std::any::Any;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::core::{FmuError, Status};
use crate::instance::Instance;
use crate::table::Category;

/// The status code for the C side.
pub fn code(status: Status) -> c_int {
    status as c_int
}

/// The text of a panic payload.
pub fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Logs an error of `func` on the instance (prefixing the function name once).
pub fn log_error(inst: &Instance, func: &str, e: &FmuError) {
    let category = if e.status >= Status::Error {
        Category::Error
    } else {
        Category::Warning
    };
    let message = if e.message.starts_with(func) {
        e.message.clone()
    } else {
        format!("{func}: {}", e.message)
    };
    inst.log(category, e.status, &message);
}

/// Runs `f` on the instance behind `ptr` and returns its status: the instance pointer is checked,
/// errors are logged, and a panic is caught, logged, and puts the instance into the error mode.
/// Returns `Error` for a NULL or foreign instance pointer (nothing can be logged then).
pub(crate) fn with_instance(
    ptr: *mut c_void,
    func: &str,
    f: impl FnOnce(&mut Instance) -> Result<Status, FmuError>,
) -> c_int {
    let result = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: the importer passes what instantiate returned (or garbage, which the magic
        // number check rejects as well as it can); FMI forbids concurrent calls on one instance.
        let Some(inst) = (unsafe { Instance::from_ptr(ptr) }) else {
            return Status::Error;
        };
        if inst.logger.wants(Category::Calls, Status::Ok) {
            inst.log(Category::Calls, Status::Ok, func);
        }
        match f(inst) {
            Ok(s) => s,
            Err(e) => {
                log_error(inst, func, &e);
                e.status
            }
        }
    }));
    match result {
        Ok(status) => code(status),
        Err(payload) => {
            let msg = panic_message(payload.as_ref());
            // Logging may itself fail; never let that unwind into C.
            let _ = catch_unwind(AssertUnwindSafe(|| {
                // SAFETY: as above.
                if let Some(inst) = unsafe { Instance::from_ptr(ptr) } {
                    inst.set_error_mode();
                    inst.log(
                        Category::Error,
                        Status::Error,
                        &format!(
                            "{func}: internal error (panic: {msg}); the instance is now in the error mode: reset or free it"
                        ),
                    );
                }
            }));
            code(Status::Error)
        }
    }
}

/// A slice from a C array; NULL is accepted only for `n == 0`.
///
/// # Safety
/// A non-NULL `ptr` must point to `n` valid elements.
pub unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], FmuError> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(FmuError::error(format!(
            "{what} is NULL but {n} elements were announced"
        )));
    }
    // SAFETY: the caller guarantees `n` valid elements.
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

/// A mutable slice from a C array; NULL is accepted only for `n == 0`.
///
/// # Safety
/// A non-NULL `ptr` must point to `n` valid, writable elements.
pub unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], FmuError> {
    if n == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(FmuError::error(format!(
            "{what} is NULL but {n} elements were announced"
        )));
    }
    // SAFETY: the caller guarantees `n` valid elements.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// A Rust string from a C string; `None` for NULL. Invalid UTF-8 is replaced.
///
/// # Safety
/// A non-NULL `ptr` must be a NUL-terminated string.
pub unsafe fn string(ptr: *const c_char) -> Option<String> {
    if ptr.is_null() {
        return None;
    }
    // SAFETY: the caller guarantees a NUL-terminated string.
    Some(
        unsafe { CStr::from_ptr(ptr) }
            .to_string_lossy()
            .into_owned(),
    )
}

/// Strings from a C array of C strings (NULL entries are errors).
///
/// # Safety
/// A non-NULL `ptr` must point to `n` pointers, each NULL or a NUL-terminated string.
pub unsafe fn strings(
    ptr: *const *const c_char,
    n: usize,
    what: &str,
) -> Result<Vec<String>, FmuError> {
    // SAFETY: forwarded.
    let ptrs = unsafe { slice(ptr, n, what) }?;
    ptrs.iter()
        .enumerate()
        .map(|(i, &p)| {
            // SAFETY: forwarded.
            unsafe { string(p) }.ok_or_else(|| FmuError::error(format!("{what}[{i}] is NULL")))
        })
        .collect()
}
