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

/// Frames that did not reach the service loop, counted by the receiver thread: each one under
/// exactly one of its counters.
#[derive(Default)]
pub(super) struct FrameLoss {
    /// Frames the transport lost: sequence gaps (iceoryx2), a full subscriber queue (Zenoh).
    pub(super) lost: AtomicU64,
    /// Frames that arrived but failed to decode or validate: a header inconsistent with the
    /// payload, a bad checksum, a payload that is not complex f32.
    pub(super) malformed: AtomicU64,
    /// Frames dropped because the receive queue was full.
    pub(super) dropped: AtomicU64,
}

/// What a frame subscriber had counted when last looked at, to add only what is new to a
/// [`FrameLoss`].
#[derive(Default)]
pub(super) struct SeenLoss {
    /// Frames the transport lost (sequence gaps, a full subscriber queue).
    lost: u64,
    /// Frames the subscriber counted as malformed.
    malformed: u64,
}

impl FrameLoss {
    /// Adds to `lost` and `malformed` what the subscriber's totals, `lost_total` and
    /// `malformed_total`, hold beyond `seen`, then remembers them.
    pub(super) fn add_new(&self, seen: &mut SeenLoss, lost_total: u64, malformed_total: u64) {
        if lost_total > seen.lost {
            self.lost
                .fetch_add(lost_total - seen.lost, Ordering::Relaxed);
            seen.lost = lost_total;
        }
        if malformed_total > seen.malformed {
            self.malformed
                .fetch_add(malformed_total - seen.malformed, Ordering::Relaxed);
            seen.malformed = malformed_total;
        }
    }

    /// Counts one frame that arrived but could not be decoded (the receiver's own checks).
    pub(super) fn on_malformed(&self) {
        self.malformed.fetch_add(1, Ordering::Relaxed);
    }
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
    let mut seen = SeenLoss::default();
    while !out.stop.load(Ordering::Relaxed) {
        // the subscriber's `dropped` are frames its full queue lost; its `malformed` arrived
        let c = sub.counters().snapshot();
        out.loss.add_new(&mut seen, c.dropped, c.malformed);
        let Some(f) = sub.recv_timeout(Duration::from_millis(50)) else {
            continue;
        };
        let samples = match f.samples() {
            Ok(s) => s.to_vec(),
            Err(e) => {
                tracing::warn!(error = %e, "frame with a payload that is not complex f32");
                out.loss.on_malformed();
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
    let (frames, cleanup) = FrameNode::new(env, &format!("processor-{}", args.instance))?;
    if cleanup.cleaned > 0 {
        tracing::info!(
            cleaned = cleanup.cleaned,
            "stale iceoryx2 resources of dead processes removed"
        );
    }
    let mut subs: Vec<(MissionId, bridge::FrameSubscriber, SeenLoss)> = Vec::new();
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
            subs.push((id, frames.subscriber(&spec)?, SeenLoss::default()));
            tracing::info!(mission = %id, service = %spec.name, "subscribed to frames");
            let _ = control.watching.send(id);
        }
        let mut got = false;
        for (_, s, seen) in &mut subs {
            while let Some(f) = s.receive()? {
                got = true;
                let h = *f.header();
                if let Err(e) = f.verify_checksum() {
                    tracing::warn!(seq = h.seq, error = %e, "frame checksum");
                    out.loss.on_malformed();
                    continue;
                }
                let samples = match f.samples() {
                    Ok(s) => s.to_vec(),
                    Err(e) => {
                        tracing::warn!(seq = h.seq, error = %e, "frame payload is not complex f32");
                        out.loss.on_malformed();
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
            // sequence gaps are frames the transport lost; an inconsistent header arrived
            out.loss
                .add_new(seen, s.missed(), s.counters().snapshot().malformed);
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

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::mpsc;
    use std::time::{Duration, Instant};

    use bridge::{Complex32, FrameMeta, FrameNode, FramePublisherOptions, FrameServiceSpec};
    use clap::Parser;

    use super::{receive_iox, FrameLoss, FrameOutlet, IoxControl, ReceiverCmd, SeenLoss};
    use crate::protocol::keys as pkeys;
    use crate::services::process::ProcessArgs;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        args: ProcessArgs,
    }

    /// Removes the shared-memory files under a prefix when dropped (iceoryx2 leaves its
    /// global management segment behind after its last node).
    struct ShmCleanup(String);

    impl Drop for ShmCleanup {
        fn drop(&mut self) {
            crate::launch::shm::remove_own(&self.0);
        }
    }

    /// Sets its flag when dropped.
    struct StopOnDrop<'a>(&'a AtomicBool);

    impl Drop for StopOnDrop<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Relaxed);
        }
    }

    #[test]
    fn a_subscribers_totals_are_added_once_each_to_their_own_counter() {
        let loss = FrameLoss::default();
        let mut seen = SeenLoss::default();
        loss.add_new(&mut seen, 2, 0);
        loss.add_new(&mut seen, 2, 3);
        loss.add_new(&mut seen, 2, 3);
        loss.on_malformed();
        assert_eq!(loss.lost.load(Ordering::Relaxed), 2);
        assert_eq!(loss.malformed.load(Ordering::Relaxed), 4);
        assert_eq!(loss.dropped.load(Ordering::Relaxed), 0);
    }

    /// The iceoryx2 receiver, fed a sequence gap (one frame the transport lost) and a frame
    /// that arrives but is not complex f32 (malformed): it forwards the good frames and counts
    /// the gap as lost and the bad frame as malformed, neither under the other.
    #[test]
    fn the_iceoryx2_receiver_counts_a_lost_frame_and_a_malformed_one_apart() {
        let dir = tempfile::tempdir().unwrap();
        let prefix = format!("prx{}_", std::process::id());
        // declared first, so dropped after every iceoryx2 object of the test
        let _cleanup = ShmCleanup(prefix.clone());
        let root = dir.path().join("iox").display().to_string();
        let args = Cli::try_parse_from([
            "process",
            "--scene",
            "unused.toml",
            "--instance",
            "rx-test",
            "--max-frame-bytes",
            "4096",
            "--iox-root",
            root.as_str(),
            "--iox-prefix",
            prefix.as_str(),
        ])
        .unwrap()
        .args;
        let env = args.iox.env().unwrap();
        let mission = bridge::MissionId(0x5eed);
        let (frame_tx, frame_rx) = mpsc::sync_channel(16);
        let (cmd_tx, cmd_rx) = mpsc::channel();
        let (watch_tx, watch_rx) = mpsc::channel();
        let loss = FrameLoss::default();
        let stop = AtomicBool::new(false);
        let (seqs, lost, malformed) = std::thread::scope(|scope| {
            let out = FrameOutlet {
                tx: frame_tx,
                stop: &stop,
                loss: &loss,
            };
            let control = IoxControl {
                cmds: cmd_rx,
                watching: watch_tx,
            };
            let receiver = scope.spawn(|| receive_iox(&env, &args, control, out));
            // a failed assertion still stops the receiver, so the scope ends
            let _stop_receiver = StopOnDrop(&stop);
            cmd_tx.send(ReceiverCmd::Watch(mission)).unwrap();
            assert_eq!(watch_rx.recv_timeout(Duration::from_secs(10)), Ok(mission));

            let (node, _) = FrameNode::new(&env, "rx-test-echo").unwrap();
            let spec = FrameServiceSpec::new(&pkeys::echo(mission).unwrap(), 4096);
            let publisher = node
                .publisher(&spec, FramePublisherOptions::default())
                .unwrap();
            assert!(publisher.wait_for_subscribers(
                1,
                Duration::from_secs(10),
                Duration::from_millis(50)
            ));
            let samples = [Complex32::new(1.0, -1.0); 4];
            let mut seqs = Vec::new();
            // one frame at a time (the subscriber's buffer holds 2), each waited for
            let mut wait_until = |what: &str, done: &dyn Fn(&[u64]) -> bool| {
                let deadline = Instant::now() + Duration::from_secs(10);
                while !done(&seqs) && Instant::now() < deadline {
                    if let Ok(f) = frame_rx.recv_timeout(Duration::from_millis(20)) {
                        seqs.push(f.seq);
                    }
                }
                assert!(done(&seqs), "{what}: got {seqs:?}");
            };
            let malformed_now = || loss.malformed.load(Ordering::Relaxed);
            let lost_now = || loss.lost.load(Ordering::Relaxed);
            // seq 1 is never sent: a gap, lost in transport
            for seq in [0, 2] {
                let meta = FrameMeta::iq(mission, seq, 0, 1, 4);
                let sent = publisher.send_samples(&meta, &samples).unwrap();
                assert_eq!(sent.delivered, 1);
                wait_until("a good frame", &|s| s.last() == Some(&seq));
            }
            wait_until("the gap", &|_| lost_now() >= 1);
            // seq 3 arrives, but 5 bytes are no complex f32 samples
            let meta = FrameMeta::bytes(1, mission, 3, 5).unwrap();
            let sent = publisher.send_bytes(&meta, &[7u8; 5]).unwrap();
            assert_eq!(sent.delivered, 1);
            wait_until("the malformed frame", &|_| malformed_now() >= 1);
            // anything more would have come by now
            std::thread::sleep(Duration::from_millis(200));
            while let Ok(f) = frame_rx.try_recv() {
                seqs.push(f.seq);
            }
            stop.store(true, Ordering::Relaxed);
            receiver.join().unwrap().unwrap();
            (
                seqs,
                loss.lost.load(Ordering::Relaxed),
                loss.malformed.load(Ordering::Relaxed),
            )
        });
        assert_eq!(seqs, [0, 2]);
        assert_eq!((lost, malformed), (1, 1), "(lost, malformed)");
        assert_eq!(loss.dropped.load(Ordering::Relaxed), 0);
    }
}
