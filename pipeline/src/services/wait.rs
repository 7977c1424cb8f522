//! What a long-running service waits for, said in its log ([`WaitLog`]): a service never
//! waits silently.

use std::time::{Duration, Instant};

use bridge::ZenohNode;

/// A wait is first logged after this long (well within 5 s of its start)…
pub const WAIT_NOTICE_AFTER: Duration = Duration::from_secs(1);
/// …then again every this long while it lasts.
pub const WAIT_NOTICE_EVERY: Duration = Duration::from_secs(30);

/// Says what a service waits for: from [`WAIT_NOTICE_AFTER`] on and every
/// [`WAIT_NOTICE_EVERY`] while the same wait lasts, with the session's mode and endpoints and
/// how many routers and peers it is connected to. The services are designed to wait for their
/// peers until stopped (SIGINT/SIGTERM), and say so; the launcher bounds its own waits.
#[derive(Debug, Default)]
pub struct WaitLog {
    /// What is waited for, since when, and when it is said next.
    current: Option<(String, Instant, Instant)>,
}

impl WaitLog {
    /// Notes what the service waits for now (`None`: nothing) and logs it when due.
    pub fn waiting_for(&mut self, node: &ZenohNode, what: Option<&str>) {
        let Some(what) = what else {
            if let Some((w, since, _)) = self.current.take() {
                tracing::debug!(
                    waited_s = since.elapsed().as_secs(),
                    "no longer waiting for {w}"
                );
            }
            return;
        };
        let now = Instant::now();
        if self.current.as_ref().is_none_or(|(w, _, _)| w != what) {
            self.current = Some((what.to_string(), now, now + WAIT_NOTICE_AFTER));
        }
        let Some((_, since, notice_at)) = self.current.as_mut() else {
            return;
        };
        if now >= *notice_at {
            *notice_at = now + WAIT_NOTICE_EVERY;
            let (routers, peers) = node.connected();
            tracing::warn!(
                session = %node.describe(),
                routers,
                peers,
                waited_s = now.duration_since(*since).as_secs(),
                "waiting for {what} (a service waits until SIGINT/SIGTERM stops it)"
            );
        }
    }
}
