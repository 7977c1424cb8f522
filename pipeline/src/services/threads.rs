//! The threads a service depends on (the processor's frame receiver and requester, the
//! planner's request taker): each one reports how it ended to its service's loop, which stops
//! the service with an error naming the thread and the cause ([`ThreadExits::check`]), so that
//! a service never waits for a thread that is gone. A thread of a running service ends only
//! when it fails: its error, a panic (with its message), or a return while the service still
//! runs are all reported.

use std::fmt::Display;
use std::sync::mpsc::{channel, Receiver, Sender};

use super::plan::ServiceError;

/// How a thread ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ThreadExit {
    /// The thread, in words (`frame receiver`).
    pub thread: &'static str,
    /// Why it ended: its error, its panic's message, or that it returned.
    pub cause: String,
}

/// The service loop's end of the threads' reports.
#[derive(Debug)]
pub struct ThreadExits {
    rx: Receiver<ThreadExit>,
}

/// A channel for the reports of a service's threads: the sender goes to each thread
/// ([`report_exit`]), the receiver to the service loop.
pub fn thread_exits() -> (Sender<ThreadExit>, ThreadExits) {
    let (tx, rx) = channel();
    (tx, ThreadExits { rx })
}

impl ThreadExits {
    /// The first thread that ended, as the service's error
    /// ([`ServiceError::ThreadStopped`]); `Ok` while every thread runs.
    pub fn check(&self) -> Result<(), ServiceError> {
        match self.rx.try_recv() {
            Ok(e) => Err(ServiceError::ThreadStopped {
                thread: e.thread.to_string(),
                cause: e.cause,
            }),
            Err(_) => Ok(()),
        }
    }
}

/// Runs `body` (the whole of the thread `thread`) and reports to `exits` how it ended: its
/// error, its panic (caught, with its message) or its return. Returns `body`'s value when it
/// returned one.
pub fn report_exit<T, E: Display>(
    thread: &'static str,
    exits: &Sender<ThreadExit>,
    body: impl FnOnce() -> Result<T, E>,
) -> Option<T> {
    let (value, cause) = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(body)) {
        Ok(Ok(v)) => (Some(v), "it returned while the service ran".to_string()),
        Ok(Err(e)) => (None, e.to_string()),
        Err(payload) => (None, format!("panicked: {}", panic_message(&*payload))),
    };
    if value.is_none() {
        tracing::error!(thread, cause = %cause, "a thread of the service failed");
    }
    // the service loop may be gone already (a thread that ends at the service's stop)
    let _ = exits.send(ThreadExit { thread, cause });
    value
}

/// The message of a caught panic.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// Runs `body` as a thread named `name` and returns what the service loop sees.
    fn exit_of(body: impl FnOnce() -> Result<(), String> + Send + 'static) -> ServiceError {
        let (tx, exits) = thread_exits();
        assert!(exits.check().is_ok(), "nothing ended yet");
        let h = std::thread::spawn(move || report_exit("test helper", &tx, body));
        // the thread itself never panics: the panic is caught and reported
        assert!(h.join().is_ok());
        let deadline = std::time::Instant::now() + Duration::from_secs(10);
        loop {
            if let Err(e) = exits.check() {
                return e;
            }
            assert!(std::time::Instant::now() < deadline, "no report");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn a_failing_thread_is_named_with_its_error() {
        let e = exit_of(|| Err("create node: UnableToGenerateUniqueNodeId".into()));
        assert_eq!(
            e.to_string(),
            "the test helper thread stopped: create node: UnableToGenerateUniqueNodeId"
        );
    }

    #[test]
    fn a_panicking_thread_is_named_with_its_message() {
        let e = exit_of(|| panic!("index out of range"));
        assert_eq!(
            e.to_string(),
            "the test helper thread stopped: panicked: index out of range"
        );
    }

    #[test]
    fn a_thread_that_returns_is_reported_too() {
        let e = exit_of(|| Ok(()));
        assert!(e.to_string().contains("returned"), "{e}");
    }
}
