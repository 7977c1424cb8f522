//! The processor's frame receiver thread: copies frames out of iceoryx2 (the services of the
//! missions it is told to watch) or Zenoh (`cellsar/*/echo`) into the service loop's queue,
//! counting what is lost on the way.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, Sender, SyncSender, TrySendError};
use std::time::Duration;

use bridge::{Complex32, FrameNode, FrameServiceSpec, MissionId};

use super::ProcessArgs;
use crate::protocol::keys as pkeys;
use crate::services::radar::ServiceResult;

/// A frame copied out of the transport.
pub(super) struct RawFrame {
    /// Mission of the frame.
    pub(super) mission: MissionId,
    /// Its sequence number within the mission.
    pub(super) seq: u64,
    /// Mission time of its first pulse, ns.
    pub(super) mission_time_ns: i64,
    /// Pulses.
    pub(super) rows: usize,
    /// Samples per pulse.
    pub(super) cols: usize,
    /// The samples, pulse after pulse.
    pub(super) samples: Vec<Complex32>,
    /// The frame's header (its tag is checked against the mission's key).
    pub(super) header: bridge::FrameHeader,
}

/// What the service loop tells the iceoryx2 receiver.
pub(super) enum ReceiverCmd {
    /// Subscribe to the frames of this mission.
    Watch(MissionId),
    /// Drop the subscription to this mission's frames (the mission was let go).
    Unwatch(MissionId),
}

/// Frames lost before they reached the service loop, counted by the receiver thread.
#[derive(Default)]
pub(super) struct FrameLoss {
    /// Frames the transport reported as missed (sequence gaps) or malformed.
    pub(super) lost: AtomicU64,
    /// Frames dropped because the receive queue was full.
    pub(super) dropped: AtomicU64,
}

/// Where a receiver thread hands its frames, when it stops and what it counts.
pub(super) struct FrameOutlet<'a> {
    /// The service loop's frame queue.
    pub(super) tx: SyncSender<RawFrame>,
    /// Set when the receiver is to stop.
    pub(super) stop: &'a AtomicBool,
    /// Frames lost on the way.
    pub(super) loss: &'a FrameLoss,
}

impl FrameOutlet<'_> {
    /// Queues `f` (a full queue drops it, counted); false once the service loop is gone.
    fn forward(&self, f: RawFrame) -> bool {
        match self.tx.try_send(f) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                self.loss.dropped.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(TrySendError::Disconnected(_)) => false,
        }
    }
}

/// The iceoryx2 receiver's link with the service loop: the missions to subscribe to, and the
/// missions subscribed to (only then are their apertures asked for).
pub(super) struct IoxControl {
    /// Missions to watch.
    pub(super) cmds: Receiver<ReceiverCmd>,
    /// Missions now watched.
    pub(super) watching: Sender<MissionId>,
}

/// Receives frames from Zenoh until `out.stop` is set or the service loop is gone.
pub(super) fn receive_zenoh(
    sub: bridge::net::ZenohFrameSubscriber,
    out: FrameOutlet<'_>,
) -> ServiceResult<()> {
    let lost = &out.loss.lost;
    let mut last_bad = 0;
    while !out.stop.load(Ordering::Relaxed) {
        let c = sub.counters().snapshot();
        let bad = c.malformed + c.dropped;
        if bad > last_bad {
            lost.fetch_add(bad - last_bad, Ordering::Relaxed);
            last_bad = bad;
        }
        let Some(f) = sub.recv_timeout(Duration::from_millis(50)) else {
            continue;
        };
        let samples = match f.samples() {
            Ok(s) => s.to_vec(),
            Err(e) => {
                tracing::warn!(error = %e, "frame with a payload that is not complex f32");
                lost.fetch_add(1, Ordering::Relaxed);
                continue;
            }
        };
        let h = f.header;
        let raw = RawFrame {
            mission: h.mission(),
            seq: h.seq,
            mission_time_ns: h.mission_time_ns,
            rows: h.shape[0] as usize,
            cols: h.shape[1] as usize,
            samples,
            header: h,
        };
        if !out.forward(raw) {
            break;
        }
    }
    Ok(())
}

/// Receives frames from the iceoryx2 services of the missions `control` names, until
/// `out.stop` is set or the service loop is gone.
pub(super) fn receive_iox(
    env: &bridge::IoxEnv,
    args: &ProcessArgs,
    control: IoxControl,
    out: FrameOutlet<'_>,
) -> ServiceResult<()> {
    let lost = &out.loss.lost;
    let (frames, cleanup) = FrameNode::new(env, &format!("processor-{}", args.instance))?;
    if cleanup.cleaned > 0 {
        tracing::info!(
            cleaned = cleanup.cleaned,
            "stale iceoryx2 resources of dead processes removed"
        );
    }
    let mut subs: Vec<(MissionId, bridge::FrameSubscriber, u64)> = Vec::new();
    while !out.stop.load(Ordering::Relaxed) {
        while let Ok(cmd) = control.cmds.try_recv() {
            let id = match cmd {
                ReceiverCmd::Watch(id) => id,
                ReceiverCmd::Unwatch(id) => {
                    subs.retain(|(m, _, _)| *m != id);
                    continue;
                }
            };
            if subs.iter().any(|(m, _, _)| *m == id) {
                continue;
            }
            let spec = FrameServiceSpec::new(&pkeys::echo(id)?, args.max_frame_bytes);
            subs.push((id, frames.subscriber(&spec)?, 0));
            tracing::info!(mission = %id, service = %spec.name, "subscribed to frames");
            let _ = control.watching.send(id);
        }
        let mut got = false;
        for (_, s, seen_lost) in &mut subs {
            while let Some(f) = s.receive()? {
                got = true;
                let h = *f.header();
                if let Err(e) = f.verify_checksum() {
                    tracing::warn!(seq = h.seq, error = %e, "frame checksum");
                    lost.fetch_add(1, Ordering::Relaxed);
                    continue;
                }
                let samples = match f.samples() {
                    Ok(s) => s.to_vec(),
                    Err(e) => {
                        tracing::warn!(seq = h.seq, error = %e, "frame payload is not complex f32");
                        lost.fetch_add(1, Ordering::Relaxed);
                        continue;
                    }
                };
                drop(f);
                let raw = RawFrame {
                    mission: h.mission(),
                    seq: h.seq,
                    mission_time_ns: h.mission_time_ns,
                    rows: h.shape[0] as usize,
                    cols: h.shape[1] as usize,
                    samples,
                    header: h,
                };
                if !out.forward(raw) {
                    return Ok(());
                }
            }
            let now_lost = s.missed() + s.counters().snapshot().malformed;
            if now_lost > *seen_lost {
                lost.fetch_add(now_lost - *seen_lost, Ordering::Relaxed);
                *seen_lost = now_lost;
            }
        }
        if !got {
            match subs.last() {
                Some((_, s, _)) => {
                    s.wait(Duration::from_millis(20))?;
                }
                None => std::thread::sleep(Duration::from_millis(20)),
            }
        }
    }
    Ok(())
}
