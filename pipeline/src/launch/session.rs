//! One run on the launcher's Zenoh session: what the launcher subscribes to, the children it
//! starts and supervises, its deadlines. The plan ([`super::plan`]), the collection
//! ([`super::imaging`]) and the outputs ([`super::outputs`]) are its steps.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Result};
use bridge::envelope::DecodeLimits;
use bridge::net::{LivelinessWatcher, SubscribeOptions, TypedSubscriber};
use bridge::{keys, IoxArgs, MissionId, ZenohNode};

use super::net::Net;
use super::{RunArgs, Transport};
use crate::events::{Event, Events};
use crate::protocol::{
    self, ApertureDetections, ApertureImage, MissionMetrics, Role, ServiceStatus,
};
use crate::senders::Senders;
use crate::services::wait::WaitLog;
use crate::supervise::{ChildSpec, Supervised};

/// What a run is given: its options, its places, its network, its event log.
pub(super) struct Setup<'a> {
    pub args: &'a RunArgs,
    /// The output directory.
    pub out: &'a Path,
    /// The children's state directory.
    pub state: &'a Path,
    /// The scene file.
    pub scene: &'a Path,
    pub net: &'a Net,
    pub iox: &'a IoxArgs,
    pub events: &'a Arc<Events>,
    /// Set by SIGINT/SIGTERM.
    pub stop: &'a AtomicBool,
    /// How a child of a role is started.
    pub spec: &'a dyn Fn(Role, Vec<String>) -> ChildSpec,
    /// When the run started.
    pub wall: Instant,
}

/// What the launcher reads: every mission's detections, images, metrics and service status.
pub(super) struct Subscriptions {
    pub detections: TypedSubscriber<ApertureDetections>,
    pub images: TypedSubscriber<ApertureImage>,
    pub metrics: TypedSubscriber<MissionMetrics>,
    pub statuses: TypedSubscriber<ServiceStatus>,
}

impl Subscriptions {
    fn open(node: &ZenohNode) -> Result<Self> {
        let queue = |capacity| SubscribeOptions {
            capacity,
            ..SubscribeOptions::default()
        };
        Ok(Subscriptions {
            detections: node.subscriber(protocol::keys::ALL_DETECTIONS, queue(1024))?,
            images: node.subscriber(
                protocol::keys::ALL_IMAGES,
                SubscribeOptions {
                    limits: DecodeLimits::default(),
                    ..queue(256)
                },
            )?,
            metrics: node.subscriber(protocol::keys::ALL_METRICS, SubscribeOptions::default())?,
            statuses: node.subscriber(protocol::keys::ALL_STATUS, queue(1024))?,
        })
    }
}

/// A run in progress on the launcher's session.
pub(super) struct Session<'a> {
    pub setup: Setup<'a>,
    pub node: &'a ZenohNode,
    pub subs: Subscriptions,
    children: &'a mut Vec<Supervised>,
    alive: LivelinessWatcher,
    /// The instances seen alive, which statuses and detections must come from.
    pub senders: Senders,
    /// Plan replies that did not answer the request ([`super::plan::plan_mismatch`]), skipped.
    pub refused_plans: u64,
    /// `--timeout-s` from the start; `None`: no limit (also for one past what an `Instant`
    /// can hold, rather than a panic).
    deadline: Option<Instant>,
    /// What the launcher waits for now, and since when.
    waits: WaitLog,
}

impl<'a> Session<'a> {
    /// Subscribes to the results and to the liveliness of every process, before any child
    /// starts (so that nothing they publish is missed).
    pub fn open(
        setup: Setup<'a>,
        node: &'a ZenohNode,
        children: &'a mut Vec<Supervised>,
    ) -> Result<Self> {
        Ok(Session {
            alive: node.watch_liveliness(keys::ALIVE_ALL)?,
            senders: Senders::default(),
            refused_plans: 0,
            subs: Subscriptions::open(node)?,
            deadline: setup
                .args
                .timeout_s
                .and_then(|t| setup.wall.checked_add(t.duration())),
            setup,
            node,
            children,
            // the launcher's waits are said from 2 s on, as its session's
            waits: WaitLog::after(std::time::Duration::from_secs(2)),
        })
    }

    /// Notes what the launcher waits for (`None`: nothing): says so in the log and as a
    /// `waiting` event from 2 s on and every 30 s, with the session's endpoints; an error once
    /// it has waited `limit` for the same thing (`limit_flag` names the option).
    pub fn waiting_for(
        &mut self,
        what: Option<&str>,
        limit: Option<(std::time::Duration, &str)>,
    ) -> Result<()> {
        let Some(w) = self.waits.note(what) else {
            return Ok(());
        };
        let what = what.unwrap_or_default();
        if let Some((limit, flag)) = limit {
            if w.waited >= limit {
                bail!(
                    "gave up waiting for {what} after {flag} {} s, on the launcher's Zenoh \
                     session ({})",
                    limit.as_secs_f64(),
                    self.node.describe()
                );
            }
        }
        if w.notice_due {
            let (routers, peers) = self.node.connected();
            let until = match limit {
                Some((l, flag)) => format!("gives up after {flag} {} s", l.as_secs_f64()),
                None => "no limit".to_string(),
            };
            tracing::warn!(
                session = %self.node.describe(),
                routers,
                peers,
                waited_s = w.waited.as_secs(),
                "waiting for {what} ({until})"
            );
            self.setup.events.emit(&Event::Waiting {
                waiting_for: what.into(),
                session: self.node.describe().to_string(),
                routers,
                peers,
                waited_s: w.waited.as_secs(),
            });
        }
        Ok(())
    }

    /// The run's options.
    pub fn args(&self) -> &'a RunArgs {
        self.setup.args
    }

    /// Whether the launcher starts `role` itself (not `--external`).
    pub fn local(&self, role: Role) -> bool {
        !self.args().external.contains(&role)
    }

    /// Whether SIGINT/SIGTERM asked the run to stop.
    pub fn stopped(&self) -> bool {
        self.setup.stop.load(Ordering::Relaxed)
    }

    fn start(&mut self, role: Role, mut args: Vec<String>) -> Result<()> {
        // on the private mesh, a Unix socket of its own (children only grow: unique per start)
        args.extend(self.setup.net.child_listen(role, self.children.len()));
        let args = match self.args().child_config.iter().find(|(r, _)| *r == role) {
            Some((_, file)) => super::net::with_child_config(args, file),
            None => args,
        };
        let child = Supervised::start((self.setup.spec)(role, args), self.setup.events)?;
        self.children.push(child);
        Ok(())
    }

    /// Starts the planner, the echo and the processor (those not `--external`).
    pub fn start_children(&mut self) -> Result<()> {
        let (args, s) = (self.args(), &self.setup);
        let zenoh = s.net.child.to_cli_args();
        let iox = s.iox.to_cli_args();
        let frames = args.max_frame_bytes.to_string();
        let scene = s.scene.display().to_string();
        let mut planner = vec![
            "planner".to_string(),
            "--state-dir".into(),
            s.state.join("planner").display().to_string(),
        ];
        planner.extend(zenoh.clone());
        let mut echo = vec![
            "echo".to_string(),
            "--scene".into(),
            scene.clone(),
            "--max-frame-bytes".into(),
            frames.clone(),
        ];
        echo.extend(zenoh.clone());
        echo.extend(iox.clone());
        let mut processor = vec![
            "process".to_string(),
            "--scene".into(),
            scene,
            "--max-frame-bytes".into(),
            frames,
            "--frames".into(),
            match args.transport {
                Transport::Iox => "iox".into(),
                Transport::Zenoh => "zenoh".into(),
            },
            "--window".into(),
            args.window.to_string(),
            "--resend-after-s".into(),
            args.resend_after_s.to_string(),
            "--state-dir".into(),
            s.state.join("processor").display().to_string(),
        ];
        processor.extend(zenoh);
        processor.extend(iox);
        for (role, a) in [
            (Role::Planner, planner),
            (Role::Echo, echo),
            (Role::Processor, processor),
        ] {
            if self.local(role) {
                self.start(role, a)?;
            }
        }
        Ok(())
    }

    /// Starts the bridge that carries mission `id`'s frames to Zenoh, when the frames go over
    /// Zenoh (`--transport zenoh`) or `--bridge` asks for it.
    pub fn start_bridge(&mut self, id: MissionId) -> Result<()> {
        let args = self.args();
        if !((args.transport == Transport::Zenoh || args.bridge) && self.local(Role::Bridge)) {
            return Ok(());
        }
        let mut a = vec![
            "bridge".to_string(),
            "--service".into(),
            protocol::keys::echo_route_out(id)?,
            "--max-frame-bytes".into(),
            args.max_frame_bytes.to_string(),
        ];
        a.extend(self.setup.net.child.to_cli_args());
        a.extend(self.setup.iox.to_cli_args());
        self.start(Role::Bridge, a)
    }

    /// One step of supervision: restarts children that died (within `--max-restarts`; an
    /// error when one keeps failing) and logs liveliness changes.
    pub fn tick(&mut self) -> Result<()> {
        let backoff = std::time::Duration::from_millis(500);
        let max_restarts = self.args().max_restarts;
        for c in self.children.iter_mut() {
            c.poll(self.setup.events, max_restarts, backoff)?;
        }
        while let Some(e) = self.alive.next_event(std::time::Duration::ZERO) {
            if let Some((role, instance)) = keys::parse_alive(&e.key) {
                if e.alive {
                    let alive = &self.alive;
                    self.senders.saw_within(role, instance, |r, i| {
                        keys::alive(r, i).is_ok_and(|k| alive.is_alive(&k))
                    });
                }
                if !e.alive {
                    tracing::warn!(role, instance, "liveliness lost");
                }
                self.setup.events.emit(&Event::Alive {
                    role: role.into(),
                    instance: instance.into(),
                    alive: e.alive,
                });
            }
        }
        Ok(())
    }

    /// Whether a planner's liveliness token is up.
    pub fn planner_alive(&self) -> bool {
        self.role_alive(Role::Planner)
    }

    /// Whether a liveliness token of `role` is up.
    pub fn role_alive(&self, role: Role) -> bool {
        self.alive
            .alive()
            .iter()
            .any(|k| keys::parse_alive(k).is_some_and(|(r, _)| r == role.as_str()))
    }

    /// The first of the roles imaging needs (the echo, the processor, and the bridge with
    /// `--transport zenoh`) whose liveliness token is not up, as the launcher says it waits
    /// for it.
    pub fn missing_peer(&self) -> Option<String> {
        let mut roles = vec![Role::Echo, Role::Processor];
        if self.args().transport == Transport::Zenoh {
            roles.push(Role::Bridge);
        }
        roles.into_iter().find(|r| !self.role_alive(*r)).map(|r| {
            let how = if self.local(r) {
                format!("see logs/{r}.log")
            } else {
                "--external: start it with the same Zenoh flags".to_string()
            };
            format!("the {r} to announce itself (cellsar/alive/{r}/*; {how})")
        })
    }

    /// An error once `--timeout-s` has passed, naming what the run was doing.
    pub fn check_time(&self, what: &str) -> Result<()> {
        if let Some(d) = self.deadline {
            if Instant::now() >= d {
                bail!(
                    "timed out after {:.0} s while {what}",
                    self.setup.wall.elapsed().as_secs_f64()
                );
            }
        }
        Ok(())
    }

    /// How many times each child was restarted, by role.
    pub fn restarts(&self) -> std::collections::BTreeMap<String, u32> {
        self.children
            .iter()
            .map(|c| (c.spec.role.to_string(), c.restarts))
            .collect()
    }

    /// A line for people: on stdout, or in the log when stdout carries the events.
    pub fn say(&self, line: &str) {
        if self.args().events_json {
            tracing::info!("{line}");
        } else {
            println!("{line}");
        }
    }
}
