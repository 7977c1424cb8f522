//! What a process waits for, said in its log ([`WaitLog`]): no process of the pipeline waits
//! silently.

use std::time::{Duration, Instant};

use bridge::ZenohNode;

/// A service's wait is first logged after this long (well within 5 s of its start)…
pub const WAIT_NOTICE_AFTER: Duration = Duration::from_secs(1);
/// …then again every this long while it lasts.
pub const WAIT_NOTICE_EVERY: Duration = Duration::from_secs(30);

/// What a process waits for and since when: a notice is due from `first_after` on and every
/// [`WAIT_NOTICE_EVERY`] while the same wait lasts. The services log it with
/// [`WaitLog::waiting_for`] (they are designed to wait for their peers until stopped, and say
/// so); the launcher logs it its own way and bounds the wait ([`WaitLog::note`]).
#[derive(Debug)]
pub struct WaitLog {
    first_after: Duration,
    /// What is waited for, since when, and when it is said next.
    current: Option<(String, Instant, Instant)>,
}

impl Default for WaitLog {
    fn default() -> Self {
        WaitLog::after(WAIT_NOTICE_AFTER)
    }
}

/// A wait in progress, as [`WaitLog::note`] reports it.
#[derive(Debug, Clone, Copy)]
pub struct Waited {
    /// How long the same thing has been waited for.
    pub waited: Duration,
    /// Whether it is time to say so.
    pub notice_due: bool,
}

impl WaitLog {
    /// A log whose first notice of a wait comes after `first_after`.
    pub fn after(first_after: Duration) -> Self {
        WaitLog {
            first_after,
            current: None,
        }
    }

    /// Notes what is waited for now (`None`: nothing); `None` when nothing is, else how long
    /// the same thing has been waited for and whether a notice is due (then the next one is
    /// [`WAIT_NOTICE_EVERY`] later).
    pub fn note(&mut self, what: Option<&str>) -> Option<Waited> {
        let Some(what) = what else {
            if let Some((w, since, _)) = self.current.take() {
                tracing::debug!(
                    waited_s = since.elapsed().as_secs(),
                    "no longer waiting for {w}"
                );
            }
            return None;
        };
        let now = Instant::now();
        if self.current.as_ref().is_none_or(|(w, _, _)| w != what) {
            self.current = Some((what.to_string(), now, now + self.first_after));
        }
        let (_, since, notice_at) = self.current.as_mut()?;
        let notice_due = now >= *notice_at;
        if notice_due {
            *notice_at = now + WAIT_NOTICE_EVERY;
        }
        Some(Waited {
            waited: now.duration_since(*since),
            notice_due,
        })
    }

    /// Notes what a service waits for now (`None`: nothing) and, when due, logs it with the
    /// session's mode and endpoints and how many routers and peers it is connected to.
    pub fn waiting_for(&mut self, node: &ZenohNode, what: Option<&str>) {
        let Some(w) = self.note(what).filter(|w| w.notice_due) else {
            return;
        };
        let (routers, peers) = node.connected();
        tracing::warn!(
            session = %node.describe(),
            routers,
            peers,
            waited_s = w.waited.as_secs(),
            "waiting for {} (a service waits until SIGINT/SIGTERM stops it)",
            what.unwrap_or_default()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A notice is due after the first delay, then only every 30 s; another wait starts over.
    #[test]
    fn a_wait_is_said_when_due_and_restarts_for_another_thing() {
        let mut w = WaitLog::after(Duration::from_millis(30));
        assert!(w.note(None).is_none());
        assert!(!w.note(Some("a")).unwrap().notice_due);
        std::thread::sleep(Duration::from_millis(40));
        let a = w.note(Some("a")).unwrap();
        assert!(a.notice_due && a.waited >= Duration::from_millis(30));
        assert!(!w.note(Some("a")).unwrap().notice_due);
        let b = w.note(Some("b")).unwrap();
        assert!(!b.notice_due && b.waited < Duration::from_millis(30));
        assert!(w.note(None).is_none());
    }
}
