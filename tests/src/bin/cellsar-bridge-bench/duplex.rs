//! `z-duplex`: one Zenoh session that publishes frames on one key while it takes frames from
//! another, so that each of its links carries traffic both ways at the same time. Two of them
//! over TLS are the reproduction of the crash that `third_party/zenoh-link-tls` fixes (its
//! reading and writing tasks raced on one rustls connection).

use super::*;
use tools::{meta_for, pattern, z_node};

/// The flags of `z-duplex`.
#[derive(clap::Args, Debug, Clone)]
pub(super) struct DuplexArgs {
    /// Zenoh key this session publishes on.
    #[arg(long)]
    send_key: String,
    /// Zenoh key this session takes frames from.
    #[arg(long)]
    recv_key: String,
    /// Payload bytes per frame (a multiple of 8: complex f32 samples).
    #[arg(long, default_value_t = 256 << 10)]
    frame_bytes: usize,
    /// Seconds of traffic both ways, counted from the moment a subscriber matched.
    #[arg(long, default_value = "10", value_parser = bridge::flags::parse_seconds)]
    duration_s: Seconds,
    #[command(flatten)]
    zenoh: ZenohArgs,
}

/// What a duplex session did.
#[derive(Debug, Default, Clone, Serialize, Deserialize)]
struct DuplexReport {
    sent: u64,
    send_errors: u64,
    received: u64,
    received_bytes: u64,
    malformed: u64,
    elapsed_s: f64,
}

/// Runs `z-duplex`: waits (up to 20 s) for a subscriber of `--send-key`, prints `READY`, then
/// publishes as fast as the link takes frames while it receives, for `--duration-s`.
pub(super) fn z_duplex(args: &DuplexArgs) -> Result<()> {
    let node = z_node(&args.zenoh, "bench-zduplex")?;
    let publisher =
        node.frame_publisher(&args.send_key, CongestionControl::Block, Locality::Any)?;
    let sub = node.frame_subscriber(
        &args.recv_key,
        FrameSubscribeOptions {
            capacity: 8,
            on_full: OnFull::Drop,
            max_payload_bytes: args.frame_bytes,
            verify_checksum: true,
            allowed_origin: Locality::Any,
        },
    )?;
    let deadline = Instant::now() + Duration::from_secs(20);
    while !publisher.has_remote_subscribers() {
        if Instant::now() > deadline {
            bail!("no subscriber matched {} within 20 s", args.send_key);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    ready();
    let samples = pattern(args.frame_bytes)?;
    let payload = frame::samples_as_bytes(&samples);
    let checksum = Some(frame::checksum(payload));
    let start = Instant::now();
    let end = start + args.duration_s.duration();
    let (mut received, mut received_bytes) = (0u64, 0u64);
    std::thread::scope(|scope| -> Result<()> {
        let sender = scope.spawn(|| -> Result<()> {
            let mut seq = 0;
            while Instant::now() < end {
                let mut h = meta_for(seq, samples.len())?.header(checksum)?;
                h.time_unix_ns = now_unix_ns();
                publisher.put(&h, payload)?;
                seq += 1;
            }
            Ok(())
        });
        while Instant::now() < end {
            if let Some(f) = sub.recv_frame_timeout(Duration::from_millis(50)) {
                received += 1;
                received_bytes += f.header.payload_len;
            }
        }
        sender
            .join()
            .map_err(|_| anyhow!("the sending thread panicked"))?
    })?;
    let elapsed_s = start.elapsed().as_secs_f64();
    let (tx, rx) = (publisher.counters().snapshot(), sub.counters().snapshot());
    drop((publisher, sub));
    node.close()?;
    report(&DuplexReport {
        sent: tx.sent,
        send_errors: tx.send_errors,
        received,
        received_bytes,
        malformed: rx.malformed,
        elapsed_s,
    })
}
