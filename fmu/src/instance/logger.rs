//! Logging to the importer's callback (FMI 2 and FMI 3 loggers), with debug categories.

use super::*;

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
