//! What every service needs from the operating system: stopping on SIGINT/SIGTERM
//! ([`stop_on_signals`]) and replacing a state file without ever leaving a torn one
//! ([`write_atomic`]).

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use super::plan::ServiceError;

/// Installs SIGINT and SIGTERM handlers that set the returned flag (services poll it and stop
/// cleanly: liveliness token withdrawn, final counters logged, exit 0). The services open
/// their Zenoh session with [`bridge::ZenohNode::open_until`], so the flag also stops a service that
/// still waits for its router.
pub fn stop_on_signals() -> Result<Arc<AtomicBool>, ServiceError> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, stop.clone())
            .map_err(|source| ServiceError::Signal { signal, source })?;
    }
    Ok(stop)
}

/// Writes `bytes` to `path` through a temporary file and a rename (never a torn file).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ServiceError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(|e| ServiceError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| ServiceError::io(path, e))
}
