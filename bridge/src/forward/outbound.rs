//! The direction to Zenoh: a thread waits on the local services' events and sends each local
//! frame (never one that came from Zenoh) on its route's data key, without copying it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::Duration;

use iceoryx2::prelude::*;
use zenoh::sample::Locality;

use super::forwarder::wait_ready;
use super::stats::RouteCounters;
use super::{DirectionCounters, ForwardError, Forwarder, ForwarderConfig, Route, FLAG_BRIDGED};
use crate::counters::BadPayloadLog;
use crate::iox::{FrameNode, FrameSubscriber, IoxEnv, IoxError, IoxService};
use crate::net::{ZenohFramePublisher, ZenohNode};

/// An outbound route: its index, the route, its Zenoh publisher.
type OutboundRoute = (usize, Route, ZenohFramePublisher);

/// An outbound route with its local subscriber.
type Outbound = (usize, Route, ZenohFramePublisher, FrameSubscriber);

/// Sets up the direction to Zenoh for every outbound route of `config`: a Zenoh frame
/// publisher per route (heard by other sessions only) and the thread that feeds them.
pub(super) fn start(
    fwd: &mut Forwarder,
    node: &ZenohNode,
    env: &IoxEnv,
    config: &ForwarderConfig,
) -> Result<(), ForwardError> {
    let routes: Vec<OutboundRoute> = config
        .routes
        .iter()
        .enumerate()
        .filter(|(_, r)| r.direction.outbound())
        .map(|(i, r)| {
            node.frame_publisher(&r.key, config.congestion_control, Locality::Remote)
                .map(|p| (i, r.clone(), p))
        })
        .collect::<Result<_, _>>()?;
    if routes.is_empty() {
        return Ok(());
    }
    let (ready_tx, ready_rx) = mpsc::channel();
    let thread = OutboundThread {
        env: env.clone(),
        instance: config.instance.clone(),
        counters: fwd.counters.clone(),
        stop: fwd.stop.clone(),
    };
    let h = std::thread::Builder::new()
        .name("bridge-outbound".into())
        .spawn(move || thread.run(routes, &ready_tx))
        .map_err(|e| ForwardError::Thread {
            thread: "outbound",
            reason: e.to_string(),
        })?;
    fwd.threads.push(("outbound", h));
    wait_ready(&ready_rx, "outbound")
}

/// The thread that sends local frames to Zenoh, with what it needs.
struct OutboundThread {
    env: IoxEnv,
    instance: String,
    counters: Arc<Vec<RouteCounters>>,
    stop: Arc<AtomicBool>,
}

/// What the outbound thread sets up before it reports ready: its node, a subscriber per
/// route and the wait set their listeners are attached to.
type Setup = (FrameNode, Vec<Outbound>, WaitSet<IoxService>);

impl OutboundThread {
    /// Sets up, says on `ready` whether that worked, then forwards until the stop flag is set.
    fn run(
        self,
        routes: Vec<OutboundRoute>,
        ready: &mpsc::Sender<Result<(), ForwardError>>,
    ) -> Result<(), ForwardError> {
        let (_node, subs, waitset) = match self.setup(routes) {
            Ok(v) => v,
            Err(e) => return Err(report_failed(ready, e)),
        };
        let mut guards = Vec::new();
        for (_, r, _, s) in &subs {
            match waitset.attach_notification(s.listener()) {
                Ok(g) => guards.push(g),
                Err(e) => {
                    let err = ForwardError::Iox(IoxError::Iceoryx {
                        step: "attach listener to waitset",
                        service: r.service.name.clone(),
                        reason: format!("{e:?}"),
                    });
                    return Err(report_failed(ready, err));
                }
            }
        }
        let _ = ready.send(Ok(()));
        let log = BadPayloadLog::default();
        let mut seen = vec![Seen::default(); subs.len()];
        while !self.stop.load(Ordering::Relaxed) {
            if let Err(e) = waitset.wait_and_process_once_with_timeout(
                |_| CallbackProgression::Continue,
                Duration::from_millis(100),
            ) {
                tracing::warn!(error = ?e, "waitset wait failed");
                std::thread::sleep(Duration::from_millis(10));
            }
            for ((i, route, zpub, sub), seen) in subs.iter().zip(seen.iter_mut()) {
                let Some(rc) = self.counters.get(*i) else {
                    continue;
                };
                rc.remote_subscribers
                    .store(zpub.has_remote_subscribers(), Ordering::Relaxed);
                forward_pending(route, zpub, sub, &rc.out, &log);
                seen.update(sub, &rc.out);
            }
        }
        drop(guards);
        Ok(())
    }

    fn setup(&self, routes: Vec<OutboundRoute>) -> Result<Setup, ForwardError> {
        let (node, _) = FrameNode::new(&self.env, &format!("bridge-{}-out", self.instance))?;
        let mut subs = Vec::new();
        for (i, r, p) in routes {
            let s = node.subscriber(&r.service)?;
            subs.push((i, r, p, s));
        }
        let waitset = WaitSetBuilder::new()
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<IoxService>()
            .map_err(|e| IoxError::Iceoryx {
                step: "create waitset",
                service: self.instance.clone(),
                reason: format!("{e:?}"),
            })?;
        Ok((node, subs, waitset))
    }
}

/// Sends `e` to the starter and returns the thread's own error (naming the thread).
fn report_failed(ready: &mpsc::Sender<Result<(), ForwardError>>, e: ForwardError) -> ForwardError {
    let msg = e.to_string();
    let _ = ready.send(Err(e));
    ForwardError::Thread {
        thread: "outbound",
        reason: msg,
    }
}

/// Sends every frame waiting on `sub` to Zenoh (frames that came from Zenoh excepted).
fn forward_pending(
    route: &Route,
    zpub: &ZenohFramePublisher,
    sub: &FrameSubscriber,
    c: &DirectionCounters,
    log: &BadPayloadLog,
) {
    if let Err(e) = sub.clear_notifications() {
        tracing::warn!(service = %route.service.name, error = %e, "clearing notifications failed");
    }
    loop {
        let frame = match sub.receive() {
            Ok(Some(f)) => f,
            Ok(None) => break,
            Err(e) => {
                tracing::warn!(service = %route.service.name, error = %e, "receive failed");
                break;
            }
        };
        let header = *frame.header();
        if header.flags & FLAG_BRIDGED != 0 {
            continue; // came from Zenoh: never send it back
        }
        DirectionCounters::add(&c.received, 1);
        if !zpub.has_remote_subscribers() {
            DirectionCounters::add(&c.unmatched, 1);
            continue;
        }
        let len = frame.payload().len();
        // zero copy: Zenoh reads the payload straight from shared memory while it fragments
        // it; the sample goes back to the producer when `put` returns
        match zpub.put_owned(&header, frame) {
            Ok(()) => {
                DirectionCounters::add(&c.forwarded, 1);
                DirectionCounters::add(&c.bytes, header.payload_len);
            }
            Err(e) => {
                DirectionCounters::add(&c.send_errors, 1);
                log.log(&route.key, len, &e);
            }
        }
    }
}

/// What a subscriber had counted when last looked at: malformed local frames and sequence
/// gaps are counted by the subscriber and added to the route's counters as they grow.
#[derive(Clone, Copy, Debug, Default)]
struct Seen {
    malformed: u64,
    missed: u64,
}

impl Seen {
    fn update(&mut self, sub: &FrameSubscriber, c: &DirectionCounters) {
        let malformed = sub.counters().snapshot().malformed;
        DirectionCounters::add(&c.malformed, malformed.saturating_sub(self.malformed));
        self.malformed = malformed;
        let missed = sub.missed();
        DirectionCounters::add(&c.missed, missed.saturating_sub(self.missed));
        self.missed = missed;
    }
}
