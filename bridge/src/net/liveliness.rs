//! Liveliness: watching tokens ([`ZenohNode::watch_liveliness`], [`LivelinessWatcher`]) and
//! listing them ([`ZenohNode::alive_now`]).

use std::collections::BTreeSet;
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use zenoh::sample::{Sample, SampleKind};
use zenoh::Wait;

use super::{NetError, ZenohNode};

/// Most liveliness changes a [`LivelinessWatcher`] queues for [`LivelinessWatcher::next_event`];
/// later ones are dropped until it is read ([`LivelinessWatcher::alive`] stays exact).
pub const MAX_QUEUED_EVENTS: usize = 4096;

/// Most keys [`ZenohNode::alive_now`] lists.
pub const MAX_ALIVE_KEYS: usize = 65_536;

/// Most key bytes, all keys together, [`ZenohNode::alive_now`] lists (16 MiB).
pub const MAX_ALIVE_KEY_BYTES: usize = 16 << 20;

impl ZenohNode {
    /// Watches liveliness tokens matching `selector` (e.g. [`crate::keys::ALIVE_ALL`]), including
    /// the ones that exist already. At most [`MAX_QUEUED_EVENTS`] changes wait to be read.
    pub fn watch_liveliness(&self, selector: &str) -> Result<LivelinessWatcher, NetError> {
        let alive = Arc::new(Mutex::new(AliveSet::default()));
        // bounded: peers decide how many events come; past the bound they are dropped (the
        // set of alive keys stays exact)
        let (tx, rx) = mpsc::sync_channel(MAX_QUEUED_EVENTS);
        let a = alive.clone();
        let subscriber = self
            .session()
            .liveliness()
            .declare_subscriber(selector.to_string())
            .history(true)
            .callback(move |sample: Sample| {
                let key = sample.key_expr().as_str().to_string();
                let is_alive = sample.kind() == SampleKind::Put;
                if let Ok(mut set) = a.lock() {
                    set.note(&key, is_alive);
                }
                let _ = tx.try_send(AliveEvent {
                    key,
                    alive: is_alive,
                });
            })
            .wait()
            .map_err(|e| NetError::zenoh("declare liveliness subscriber", selector, e))?;
        Ok(LivelinessWatcher {
            _subscriber: subscriber,
            alive,
            events: rx,
        })
    }

    /// The liveliness tokens matching `selector` right now (a liveliness query): at most
    /// [`MAX_ALIVE_KEYS`] keys of [`MAX_ALIVE_KEY_BYTES`] in all (past that, a warning is
    /// logged and the rest are not listed).
    pub fn alive_now(&self, selector: &str, timeout: Duration) -> Result<Vec<String>, NetError> {
        let replies = self
            .session()
            .liveliness()
            .get(selector.to_string())
            .timeout(timeout)
            .wait()
            .map_err(|e| NetError::zenoh("liveliness get", selector, e))?;
        let mut out = BTreeSet::new();
        let mut bytes = 0usize;
        while let Ok(reply) = replies.recv() {
            if let Ok(sample) = reply.result() {
                let key = sample.key_expr().as_str();
                bytes = bytes.saturating_add(key.len());
                if out.len() >= MAX_ALIVE_KEYS || bytes > MAX_ALIVE_KEY_BYTES {
                    tracing::warn!(
                        selector,
                        keys = out.len(),
                        "more liveliness tokens than {MAX_ALIVE_KEYS} keys or \
                         {MAX_ALIVE_KEY_BYTES} bytes: the rest are not listed"
                    );
                    break;
                }
                out.insert(key.to_string());
            }
        }
        Ok(out.into_iter().collect())
    }
}

/// A liveliness change.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AliveEvent {
    /// The token's key, e.g. `cellsar/alive/planner/p1`.
    pub key: String,
    /// `true` when it appeared, `false` when it went away.
    pub alive: bool,
}

/// The keys alive, at most [`MAX_ALIVE_KEYS`] of [`MAX_ALIVE_KEY_BYTES`] together: peers
/// decide how many tokens appear; past the bounds a new key is not recorded (counted).
#[derive(Debug, Default)]
struct AliveSet {
    keys: BTreeSet<String>,
    bytes: usize,
    unrecorded: u64,
}

impl AliveSet {
    /// Notes that `key` appeared (`alive`) or went away; returns whether it is recorded as
    /// alive now.
    fn note(&mut self, key: &str, alive: bool) -> bool {
        if !alive {
            if self.keys.remove(key) {
                self.bytes -= key.len();
            }
            return false;
        }
        if self.keys.contains(key) {
            return true;
        }
        if self.keys.len() >= MAX_ALIVE_KEYS || self.bytes + key.len() > MAX_ALIVE_KEY_BYTES {
            self.unrecorded += 1;
            if self.unrecorded == 1 {
                tracing::warn!(
                    key,
                    "more liveliness tokens than {MAX_ALIVE_KEYS} keys or \
                     {MAX_ALIVE_KEY_BYTES} bytes: new ones are not recorded"
                );
            }
            return false;
        }
        self.bytes += key.len();
        self.keys.insert(key.to_string());
        true
    }
}

/// Tracks liveliness tokens matching a selector (at most [`MAX_ALIVE_KEYS`] keys of
/// [`MAX_ALIVE_KEY_BYTES`] together; past that, new ones are not recorded until others go).
pub struct LivelinessWatcher {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    alive: Arc<Mutex<AliveSet>>,
    events: Receiver<AliveEvent>,
}

impl LivelinessWatcher {
    /// The keys alive now.
    pub fn alive(&self) -> BTreeSet<String> {
        self.alive
            .lock()
            .map(|s| s.keys.clone())
            .unwrap_or_default()
    }

    /// Whether `key` is alive now.
    pub fn is_alive(&self, key: &str) -> bool {
        self.alive
            .lock()
            .map(|s| s.keys.contains(key))
            .unwrap_or(false)
    }

    /// Waits up to `timeout` for the next change.
    pub fn next_event(&self, timeout: Duration) -> Option<AliveEvent> {
        self.events.recv_timeout(timeout).ok()
    }

    /// Waits until `key`'s state is `alive` (or `timeout`); returns whether it got there.
    pub fn wait_for(&self, key: &str, alive: bool, timeout: Duration) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if self.is_alive(key) == alive {
                return true;
            }
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return false;
            }
            let _ = self
                .events
                .recv_timeout(left.min(Duration::from_millis(50)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flood of tokens is recorded up to the bound; once some go, new ones are again.
    #[test]
    fn the_alive_set_is_bounded() {
        let mut s = AliveSet::default();
        for n in 0..MAX_ALIVE_KEYS + 100 {
            s.note(&format!("cellsar/alive/echo/e{n}"), true);
        }
        assert_eq!(s.keys.len(), MAX_ALIVE_KEYS);
        assert_eq!(s.unrecorded, 100);
        assert!(!s.note("cellsar/alive/processor/p", true));
        assert!(!s.note("cellsar/alive/echo/e0", false));
        assert!(s.note("cellsar/alive/processor/p", true));
        assert_eq!(s.bytes, s.keys.iter().map(String::len).sum::<usize>());
        // bytes: one huge key at a time
        let mut s = AliveSet::default();
        let big = "k".repeat(MAX_ALIVE_KEY_BYTES / 2 + 1);
        assert!(s.note(&format!("a{big}"), true));
        assert!(!s.note(&format!("b{big}"), true));
        assert!(s.bytes <= MAX_ALIVE_KEY_BYTES);
    }
}
