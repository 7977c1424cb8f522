//! The Zenoh session of a process ([`ZenohNode`]): opening it (with its liveliness token),
//! optionally until a stop flag is set, and closing it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::{Duration, Instant};

use zenoh::liveliness::LivelinessToken;
use zenoh::{Config, Session, Wait};

use super::NetError;
use crate::keys;
use crate::zconfig;

/// A Zenoh session of one cellsar process, announced by the liveliness token
/// `cellsar/alive/<role>/<instance>` for as long as it is open.
pub struct ZenohNode {
    session: Session,
    role: String,
    instance: String,
    /// The session's mode and endpoints in words ([`zconfig::describe`]).
    described: String,
    _token: LivelinessToken,
}

impl std::fmt::Debug for ZenohNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohNode")
            .field("role", &self.role)
            .field("instance", &self.instance)
            .field("zid", &self.session.zid().to_string())
            .finish()
    }
}

/// How long [`ZenohNode::open_until`] waits before it says that it is still waiting.
const OPEN_NOTICE_AFTER: Duration = Duration::from_secs(2);
/// How often it says so again.
const OPEN_NOTICE_EVERY: Duration = Duration::from_secs(30);
/// How often it looks at its stop flag.
const OPEN_POLL: Duration = Duration::from_millis(20);

impl ZenohNode {
    /// Opens a session and declares its liveliness token.
    ///
    /// This blocks until Zenoh has opened the session: with `connect.timeout_ms: -1` (a
    /// client that waits for its router, `pipeline/deploy/client.json5`) for as long as no
    /// router is reachable. A process that must stay stoppable meanwhile uses
    /// [`ZenohNode::open_until`].
    pub fn open(config: Config, role: &str, instance: &str) -> Result<Self, NetError> {
        let alive = keys::alive(role, instance)?;
        let described = zconfig::describe(&config);
        let session = zenoh::open(config).wait().map_err(|e| NetError::Open {
            session: described.clone(),
            error: e.into(),
        })?;
        let token = session
            .liveliness()
            .declare_token(alive.clone())
            .wait()
            .map_err(|e| NetError::zenoh("declare liveliness token", &alive, e))?;
        tracing::info!(%alive, zid = %session.zid(), session = %described, "zenoh session open");
        Ok(ZenohNode {
            session,
            role: role.to_string(),
            instance: instance.to_string(),
            described,
            _token: token,
        })
    }

    /// Opens a session as [`ZenohNode::open`] does, but gives up as soon as `stop` is set
    /// (the flag SIGINT/SIGTERM set): `Ok(None)` then, `Ok(Some(node))` once the session is
    /// open. Zenoh opens it on a thread of its own, which is left behind when `stop` is set
    /// first (the process is about to exit). While no router or peer answers (a client
    /// started before its router waits for it), it logs every 30 s, from 2 s on, what it
    /// waits for; a stop is logged too. It waits as long as Zenoh does: with
    /// `connect.timeout_ms: -1`, until stopped ([`ZenohNode::open_within`] bounds it).
    pub fn open_until(
        config: Config,
        role: &str,
        instance: &str,
        stop: &AtomicBool,
    ) -> Result<Option<Self>, NetError> {
        Self::open_within(config, role, instance, stop, None)
    }

    /// [`ZenohNode::open_until`], giving up after `limit` (when given) with
    /// [`NetError::OpenTimeout`], which names the session's endpoints.
    pub fn open_within(
        config: Config,
        role: &str,
        instance: &str,
        stop: &AtomicBool,
        limit: Option<Duration>,
    ) -> Result<Option<Self>, NetError> {
        keys::alive(role, instance)?;
        let session = zconfig::describe(&config);
        let (tx, rx) = mpsc::sync_channel(1);
        let (r, i) = (role.to_string(), instance.to_string());
        std::thread::Builder::new()
            .name("zenoh-open".into())
            .spawn(move || {
                let _ = tx.send(ZenohNode::open(config, &r, &i));
            })
            .map_err(|e| NetError::OpenThread {
                session: session.clone(),
                reason: format!("starting the thread that opens it: {e}"),
            })?;
        let started = Instant::now();
        let deadline = limit.and_then(|l| started.checked_add(l));
        let mut notice_at = started + OPEN_NOTICE_AFTER;
        loop {
            if stop.load(Ordering::Relaxed) {
                tracing::warn!(
                    %session,
                    waited_s = started.elapsed().as_secs(),
                    "stopped before the Zenoh session opened"
                );
                return Ok(None);
            }
            match rx.recv_timeout(OPEN_POLL) {
                Ok(opened) => return opened.map(Some),
                Err(RecvTimeoutError::Timeout) => {
                    let now = Instant::now();
                    if let (Some(d), Some(l)) = (deadline, limit) {
                        if now >= d {
                            return Err(NetError::OpenTimeout { session, waited: l });
                        }
                    }
                    if now >= notice_at {
                        notice_at += OPEN_NOTICE_EVERY;
                        let until = match limit {
                            Some(l) => format!("gives up after {} s", l.as_secs_f64()),
                            None => "waits until SIGINT/SIGTERM stops it".to_string(),
                        };
                        tracing::warn!(
                            %session,
                            waited_s = started.elapsed().as_secs(),
                            "waiting for the Zenoh session to open: no router or peer \
                             reachable yet ({until})"
                        );
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(NetError::OpenThread {
                        session,
                        reason: "the thread that opened it ended without an answer".into(),
                    })
                }
            }
        }
    }

    /// The session's mode and endpoints in words, as configured ([`zconfig::describe`]),
    /// e.g. `mode client, connect [tcp/192.168.1.10:7447], listen []`: what a process names
    /// when it says what it waits for.
    pub fn describe(&self) -> &str {
        &self.described
    }

    /// How many routers and peers this session is connected to now.
    pub fn connected(&self) -> (usize, usize) {
        let info = self.session.info();
        (
            info.routers_zid().wait().count(),
            info.peers_zid().wait().count(),
        )
    }

    /// The underlying session (for anything this wrapper does not cover).
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Role of this process.
    pub fn role(&self) -> &str {
        &self.role
    }

    /// Instance name of this process.
    pub fn instance(&self) -> &str {
        &self.instance
    }

    /// Declares an additional liveliness token (alive while the returned token lives).
    pub fn declare_token(&self, key: &str) -> Result<LivelinessToken, NetError> {
        self.session
            .liveliness()
            .declare_token(key.to_string())
            .wait()
            .map_err(|e| NetError::zenoh("declare liveliness token", key, e))
    }

    /// Closes the session (undeclaring everything, liveliness token included).
    pub fn close(self) -> Result<(), NetError> {
        let alive = keys::alive(&self.role, &self.instance).unwrap_or_default();
        self.session
            .close()
            .wait()
            .map_err(|e| NetError::zenoh("close session", &alive, e))
    }
}
