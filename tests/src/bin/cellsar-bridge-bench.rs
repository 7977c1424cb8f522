//! `cellsar-bridge-bench`: frame tools and the transport benchmark.
//!
//! Tools (each prints `READY` on stdout once set up, then one JSON report line at the end):
//!
//! - `iox-pub` / `iox-sub`: publish / consume frames on an iceoryx2 frame service;
//! - `z-pub` / `z-sub`: publish / consume the same frames on a plain Zenoh key;
//! - `z-flood`: send malformed and oversized frame payloads on a Zenoh key (each one checked
//!   to be rejected by this crate's own decoder before it is sent).
//!
//! `bench` runs them as child processes: the iceoryx2 hand-off (latency, throughput) for each
//! frame size, then a plain Zenoh publisher/subscriber against the path through two
//! `cellsar-bridge` processes, in the same run, and prints a Markdown table.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use bridge::envelope::now_unix_ns;
use bridge::flags::Seconds;
use bridge::frame::{self, FrameMeta, WIRE_PREFIX_LEN};
use bridge::iox::{
    init_iceoryx_logging, Backpressure, FrameNode, FramePublisherOptions, FrameServiceSpec, IoxArgs,
};
use bridge::net::{FrameSubscribeOptions, OnFull};
use bridge::zenoh::qos::CongestionControl;
use bridge::zenoh::sample::Locality;
use bridge::zenoh::Wait;
use bridge::{Complex32, MissionId, ZenohArgs, ZenohNode};
use clap::{Parser, Subcommand};
use serde::{Deserialize, Serialize};

#[derive(Parser, Debug)]
#[command(
    name = "cellsar-bridge-bench",
    version,
    about = "Frame tools and transport benchmark"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(clap::Args, Debug, Clone)]
struct FrameArgs {
    /// Number of frames.
    #[arg(long, default_value_t = 100)]
    frames: u64,
    /// Payload bytes per frame (a multiple of 8: complex f32 samples).
    #[arg(long, default_value_t = 1 << 20)]
    frame_bytes: usize,
    /// Frames per second (0: as fast as possible).
    #[arg(long, default_value_t = 0.0, value_parser = bridge::flags::parse_non_negative)]
    rate_hz: f64,
    /// Do not compute CRCs.
    #[arg(long)]
    no_checksum: bool,
}

#[derive(clap::Args, Debug, Clone)]
struct RxArgs {
    /// Frames to wait for.
    #[arg(long, default_value_t = 100)]
    frames: u64,
    /// Give up after this many seconds.
    #[arg(long, default_value = "60", value_parser = bridge::flags::parse_seconds)]
    timeout_s: Seconds,
    /// Stop when no frame arrived for this long after the first one, s.
    #[arg(long, default_value = "3", value_parser = bridge::flags::parse_seconds)]
    idle_s: Seconds,
    /// Verify each frame's CRC (reads the whole payload).
    #[arg(long)]
    verify: bool,
    /// Hold each frame this many milliseconds before taking the next (a slow consumer).
    #[arg(long, default_value_t = 0)]
    hold_ms: u64,
    /// Busy-poll instead of sleeping on the event (measures the bare hand-off; iceoryx2 only).
    #[arg(long)]
    spin: bool,
}

#[derive(clap::Args, Debug, Clone)]
struct ServiceArgs {
    /// iceoryx2 frame service name.
    #[arg(long)]
    service: String,
    /// Largest payload of the service (must match every process using it).
    #[arg(long, default_value_t = 32 << 20)]
    max_frame_bytes: usize,
    /// Frames a subscriber can queue.
    #[arg(long, default_value_t = 2)]
    subscriber_buffer: usize,
    #[command(flatten)]
    iox: IoxArgs,
}

impl ServiceArgs {
    fn spec(&self) -> FrameServiceSpec {
        let mut s = FrameServiceSpec::new(&self.service, self.max_frame_bytes);
        s.subscriber_buffer = self.subscriber_buffer;
        s
    }
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Publish frames on an iceoryx2 frame service.
    IoxPub {
        #[command(flatten)]
        svc: ServiceArgs,
        #[command(flatten)]
        frames: FrameArgs,
        /// Wait (up to 20 s) for this many subscribers before sending.
        #[arg(long, default_value_t = 1)]
        wait_subscribers: usize,
        /// Block on full subscriber buffers instead of skipping them (lossless).
        #[arg(long)]
        block: bool,
    },
    /// Consume frames from an iceoryx2 frame service.
    IoxSub {
        #[command(flatten)]
        svc: ServiceArgs,
        #[command(flatten)]
        rx: RxArgs,
    },
    /// Publish frames on a Zenoh key (plain Zenoh, no bridge).
    ZPub {
        /// Zenoh key.
        #[arg(long)]
        key: String,
        #[command(flatten)]
        frames: FrameArgs,
        /// Wait (up to 20 s) for a matching subscriber before sending.
        #[arg(long)]
        wait_matching: bool,
        #[command(flatten)]
        zenoh: ZenohArgs,
    },
    /// Consume frames from a Zenoh key (plain Zenoh, no bridge).
    ZSub {
        /// Zenoh key.
        #[arg(long)]
        key: String,
        /// Largest accepted payload.
        #[arg(long, default_value_t = 32 << 20)]
        max_frame_bytes: usize,
        #[command(flatten)]
        rx: RxArgs,
        #[command(flatten)]
        zenoh: ZenohArgs,
    },
    /// Send malformed and oversized frame payloads on a Zenoh key.
    ZFlood {
        /// Zenoh key.
        #[arg(long)]
        key: String,
        /// Number of bad payloads.
        #[arg(long, default_value_t = 10_000)]
        count: u64,
        /// The receiver's payload limit (for the oversized ones).
        #[arg(long, default_value_t = 1 << 20)]
        max_frame_bytes: usize,
        /// Seed of the generator.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Wait (up to 20 s) for a matching subscriber before sending.
        #[arg(long)]
        wait_matching: bool,
        #[command(flatten)]
        zenoh: ZenohArgs,
    },
    /// Run the benchmark and print a Markdown table.
    Bench {
        /// Frame sizes in MiB.
        #[arg(long, value_delimiter = ',', default_value = "1,8,32")]
        sizes_mib: Vec<usize>,
        /// Frames per size and path.
        #[arg(long, default_value_t = 100)]
        frames: u64,
        /// Frames per second of the latency runs (at most).
        #[arg(long, default_value_t = 20.0, value_parser = bridge::flags::parse_non_negative)]
        latency_rate_hz: f64,
        /// Latency runs are paced to at most this many MB/s, so they measure latency and not
        /// queueing.
        #[arg(long, default_value_t = 100.0, value_parser = bridge::flags::parse_non_negative)]
        latency_budget_mb_s: f64,
        /// Repetitions (plain Zenoh and bridged runs alternate within each).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Also write the raw reports (JSON) here.
        #[arg(long)]
        json_out: Option<PathBuf>,
        /// `--inbound-queue` of the receiving bridge (0: re-publish in Zenoh's callback).
        #[arg(long, default_value_t = 4)]
        bridge_inbound_queue: usize,
    },
}

/// What a receiver saw.
#[derive(Debug, Default, Clone, Serialize, Deserialize)]
struct RxReport {
    frames: u64,
    bytes: u64,
    missed: u64,
    duplicates: u64,
    malformed: u64,
    checksum_errors: u64,
    last_seq: Option<u64>,
    elapsed_s: f64,
    throughput_mb_s: f64,
    lat_us_p50: f64,
    lat_us_p90: f64,
    lat_us_p99: f64,
    lat_us_max: f64,
}

/// What a sender did.
#[derive(Debug, Default, Clone, Serialize, Deserialize)]
struct TxReport {
    frames: u64,
    bytes: u64,
    dropped: u64,
    send_errors: u64,
    elapsed_s: f64,
    throughput_mb_s: f64,
}

fn main() {
    cellsar_error::init_logging(cellsar_error::COMMAND_LOG_FILTER);
    init_iceoryx_logging();
    if let Err(e) = run(Cli::parse()) {
        eprintln!(
            "cellsar-bridge-bench: {}",
            cellsar_error::error_chain(e.as_ref())
        );
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::IoxPub {
            svc,
            frames,
            wait_subscribers,
            block,
        } => iox_pub(&svc, &frames, wait_subscribers, block),
        Cmd::IoxSub { svc, rx } => iox_sub(&svc, &rx),
        Cmd::ZPub {
            key,
            frames,
            wait_matching,
            zenoh,
        } => z_pub(&key, &frames, wait_matching, &zenoh),
        Cmd::ZSub {
            key,
            max_frame_bytes,
            rx,
            zenoh,
        } => z_sub(&key, max_frame_bytes, &rx, &zenoh),
        Cmd::ZFlood {
            key,
            count,
            max_frame_bytes,
            seed,
            wait_matching,
            zenoh,
        } => z_flood(&key, count, max_frame_bytes, seed, wait_matching, &zenoh),
        Cmd::Bench {
            sizes_mib,
            frames,
            latency_rate_hz,
            latency_budget_mb_s,
            repeats,
            json_out,
            bridge_inbound_queue,
        } => bench(
            &sizes_mib,
            frames,
            latency_rate_hz,
            latency_budget_mb_s,
            repeats.max(1),
            json_out.as_deref(),
            bridge_inbound_queue,
        ),
    }
}

fn ready() {
    println!("READY");
    let _ = std::io::stdout().flush();
}

fn report<T: Serialize>(r: &T) -> Result<()> {
    println!("{}", serde_json::to_string(r)?);
    std::io::stdout().flush()?;
    Ok(())
}

fn pattern(frame_bytes: usize) -> Result<Vec<Complex32>> {
    if !frame_bytes.is_multiple_of(8) || frame_bytes == 0 {
        bail!("--frame-bytes must be a positive multiple of 8, got {frame_bytes}");
    }
    Ok((0..frame_bytes / 8)
        .map(|i| Complex32::new((i % 1000) as f32, -((i % 777) as f32)))
        .collect())
}

fn meta_for(seq: u64, samples: usize) -> Result<FrameMeta> {
    let cols = u32::try_from(samples).context("frame too large")?;
    Ok(FrameMeta::iq(
        MissionId(0xbe7c),
        seq,
        seq as i64 * 1_000_000,
        1,
        cols,
    ))
}

struct Pacer {
    start: Instant,
    period: Option<Duration>,
    n: u32,
}

impl Pacer {
    fn new(rate_hz: f64) -> Self {
        Pacer {
            start: Instant::now(),
            period: (rate_hz > 0.0)
                .then(|| Duration::try_from_secs_f64(1.0 / rate_hz).unwrap_or(Duration::MAX)),
            n: 0,
        }
    }
    fn wait(&mut self) {
        if let Some(p) = self.period {
            // checked: an absurdly low rate must not overflow the clock (it is then not paced)
            let due = p
                .checked_mul(self.n)
                .and_then(|d| self.start.checked_add(d));
            let now = Instant::now();
            if let Some(due) = due.filter(|d| *d > now) {
                std::thread::sleep(due - now);
            }
        }
        self.n += 1;
    }
}

fn iox_pub(svc: &ServiceArgs, f: &FrameArgs, wait_subscribers: usize, block: bool) -> Result<()> {
    let env = svc.iox.env()?;
    let (node, _) = FrameNode::new(&env, "bench-iox-pub")?;
    let publisher = node.publisher(
        &svc.spec(),
        FramePublisherOptions {
            checksum: !f.no_checksum,
            backpressure: if block {
                Backpressure::Block
            } else {
                Backpressure::Discard
            },
        },
    )?;
    let samples = pattern(f.frame_bytes)?;
    // A subscriber connects to a new publisher on its next receive or wake-up: wait for the
    // subscribers, then give them that moment, or the first frames find no connection.
    let settle = if wait_subscribers > 0 {
        Duration::from_millis(250)
    } else {
        Duration::ZERO
    };
    if !publisher.wait_for_subscribers(wait_subscribers, Duration::from_secs(20), settle) {
        bail!(
            "no {wait_subscribers} subscriber(s) on {} within 20 s",
            svc.service
        );
    }
    ready();
    let start = Instant::now();
    let mut pacer = Pacer::new(f.rate_hz);
    for seq in 0..f.frames {
        pacer.wait();
        publisher.send_samples(&meta_for(seq, samples.len())?, &samples)?;
    }
    let elapsed = start.elapsed().as_secs_f64();
    let c = publisher.counters().snapshot();
    // let the last notifications land before the publisher goes away
    std::thread::sleep(Duration::from_millis(200));
    report(&TxReport {
        frames: c.sent,
        bytes: c.bytes_out,
        dropped: c.dropped,
        send_errors: c.send_errors,
        elapsed_s: elapsed,
        throughput_mb_s: c.bytes_out as f64 / elapsed / 1e6,
    })
}

struct RxStats {
    lat_us: Vec<f64>,
    frames: u64,
    bytes: u64,
    checksum_errors: u64,
    first: Option<Instant>,
    last: Option<Instant>,
    last_seq: Option<u64>,
}

impl RxStats {
    fn new() -> Self {
        RxStats {
            lat_us: Vec::new(),
            frames: 0,
            bytes: 0,
            checksum_errors: 0,
            first: None,
            last: None,
            last_seq: None,
        }
    }
    fn on_frame(&mut self, sent_unix_ns: u64, bytes: usize, seq: u64, checksum_ok: bool) {
        let now = now_unix_ns();
        self.lat_us
            .push(now.saturating_sub(sent_unix_ns) as f64 / 1e3);
        self.frames += 1;
        self.bytes += bytes as u64;
        if !checksum_ok {
            self.checksum_errors += 1;
        }
        let t = Instant::now();
        self.first.get_or_insert(t);
        self.last = Some(t);
        self.last_seq = Some(seq);
    }
    /// Enough frames, or out of time.
    fn done(&self, rx: &RxArgs, start: Instant) -> bool {
        self.frames >= rx.frames || start.elapsed() > rx.timeout_s.duration()
    }
    /// Nothing for `idle_s` since the last frame (checked only when nothing is pending).
    fn idle(&self, rx: &RxArgs) -> bool {
        matches!(self.last, Some(l) if l.elapsed() > rx.idle_s.duration())
    }
    fn report(mut self, missed: u64, duplicates: u64, malformed: u64) -> RxReport {
        self.lat_us.sort_by(f64::total_cmp);
        let q = |p: f64| -> f64 {
            if self.lat_us.is_empty() {
                return f64::NAN;
            }
            let i = ((self.lat_us.len() - 1) as f64 * p).round() as usize;
            self.lat_us[i]
        };
        let elapsed = match (self.first, self.last) {
            (Some(a), Some(b)) => (b - a).as_secs_f64(),
            _ => 0.0,
        };
        // throughput over the frames after the first (the first only starts the clock)
        let per_frame = if self.frames > 0 {
            self.bytes as f64 / self.frames as f64
        } else {
            0.0
        };
        let tp = if elapsed > 0.0 && self.frames > 1 {
            per_frame * (self.frames - 1) as f64 / elapsed / 1e6
        } else {
            f64::NAN
        };
        RxReport {
            frames: self.frames,
            bytes: self.bytes,
            missed,
            duplicates,
            malformed,
            checksum_errors: self.checksum_errors,
            last_seq: self.last_seq,
            elapsed_s: elapsed,
            throughput_mb_s: tp,
            lat_us_p50: q(0.5),
            lat_us_p90: q(0.9),
            lat_us_p99: q(0.99),
            lat_us_max: q(1.0),
        }
    }
}

fn iox_sub(svc: &ServiceArgs, rx: &RxArgs) -> Result<()> {
    let env = svc.iox.env()?;
    let (node, _) = FrameNode::new(&env, "bench-iox-sub")?;
    let sub = node.subscriber(&svc.spec())?;
    ready();
    let start = Instant::now();
    let mut st = RxStats::new();
    while !st.done(rx, start) {
        match sub.receive()? {
            Some(f) => {
                let ok = !rx.verify || f.verify_checksum().is_ok();
                let h = *f.header();
                st.on_frame(h.time_unix_ns, f.payload().len(), h.seq, ok);
                if rx.hold_ms > 0 {
                    std::thread::sleep(Duration::from_millis(rx.hold_ms));
                }
            }
            None => {
                if st.idle(rx) {
                    break;
                }
                if rx.spin {
                    std::hint::spin_loop();
                } else {
                    sub.wait(Duration::from_millis(50))?;
                }
            }
        }
    }
    let missed = sub.missed();
    let malformed = sub.counters().snapshot().malformed;
    report(&st.report(missed, sub.duplicates(), malformed))
}

fn z_node(zenoh: &ZenohArgs, role: &str) -> Result<ZenohNode> {
    let instance = format!("{role}-{}", std::process::id());
    Ok(ZenohNode::open(zenoh.to_config()?, role, &instance)?)
}

fn z_pub(key: &str, f: &FrameArgs, wait_matching: bool, zenoh: &ZenohArgs) -> Result<()> {
    let node = z_node(zenoh, "bench-zpub")?;
    let publisher = node.frame_publisher(key, CongestionControl::Block, Locality::Any)?;
    let samples = pattern(f.frame_bytes)?;
    let payload = frame::samples_as_bytes(&samples);
    let checksum = (!f.no_checksum).then(|| frame::checksum(payload));
    if wait_matching {
        let deadline = Instant::now() + Duration::from_secs(20);
        while !publisher.has_remote_subscribers() {
            if Instant::now() > deadline {
                bail!("no subscriber matched {key} within 20 s");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    ready();
    let start = Instant::now();
    let mut pacer = Pacer::new(f.rate_hz);
    for seq in 0..f.frames {
        pacer.wait();
        let mut h = meta_for(seq, samples.len())?.header(checksum)?;
        h.time_unix_ns = now_unix_ns();
        publisher.put(&h, payload)?;
    }
    let elapsed = start.elapsed().as_secs_f64();
    let c = publisher.counters().snapshot();
    std::thread::sleep(Duration::from_millis(200));
    drop(publisher);
    node.close()?;
    report(&TxReport {
        frames: c.sent,
        bytes: c.bytes_out,
        dropped: 0,
        send_errors: c.send_errors,
        elapsed_s: elapsed,
        throughput_mb_s: c.bytes_out as f64 / elapsed / 1e6,
    })
}

fn z_sub(key: &str, max_frame_bytes: usize, rx: &RxArgs, zenoh: &ZenohArgs) -> Result<()> {
    let node = z_node(zenoh, "bench-zsub")?;
    let sub = node.frame_subscriber(
        key,
        FrameSubscribeOptions {
            capacity: 4,
            on_full: OnFull::Block,
            max_payload_bytes: max_frame_bytes,
            verify_checksum: rx.verify,
            allowed_origin: Locality::Any,
        },
    )?;
    ready();
    let start = Instant::now();
    let mut st = RxStats::new();
    let mut tracker = bridge::seq::SeqTracker::new();
    while !st.done(rx, start) {
        // zero copy: the payload stays in Zenoh's buffers (CRC checked there with --verify)
        match sub.recv_frame_timeout(Duration::from_millis(50)) {
            Some(f) => {
                tracker.observe(0, f.header.seq);
                st.on_frame(
                    f.header.time_unix_ns,
                    f.header.payload_len as usize,
                    f.header.seq,
                    true,
                );
                if rx.hold_ms > 0 {
                    std::thread::sleep(Duration::from_millis(rx.hold_ms));
                }
            }
            None if st.idle(rx) => break,
            None => {}
        }
    }
    let c = sub.counters().snapshot();
    let r = st.report(tracker.missing(), tracker.duplicates(), c.malformed);
    drop(sub);
    node.close()?;
    report(&r)
}

/// xorshift64*: a tiny deterministic generator for the flood.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

/// One payload that this crate's decoder rejects (checked), of one of several kinds.
fn bad_payload(rng: &mut Rng, valid: &[u8], max_frame_bytes: usize, i: u64) -> Vec<u8> {
    loop {
        let p = match i % 5 {
            // random bytes of random length
            0 => {
                let n = rng.below(200) as usize;
                (0..n).map(|_| rng.next() as u8).collect()
            }
            // a valid frame with 1..4 flipped bits anywhere
            1 => {
                let mut v = valid.to_vec();
                for _ in 0..1 + rng.below(4) {
                    let pos = rng.below(v.len() as u64) as usize;
                    v[pos] ^= 1 << rng.below(8);
                }
                v
            }
            // truncated or extended
            2 => {
                let mut v = valid.to_vec();
                if rng.below(2) == 0 {
                    v.truncate(rng.below(v.len() as u64) as usize);
                } else {
                    v.extend((0..1 + rng.below(64)).map(|_| rng.next() as u8));
                }
                v
            }
            // header claiming an oversized payload
            3 => {
                let mut v = valid.to_vec();
                let big = (max_frame_bytes as u64 + 8 + rng.below(1 << 30)) / 8 * 8;
                let cols = (big / 8).min(u64::from(u32::MAX)) as u32;
                v[40..48].copy_from_slice(&(24 + u64::from(cols) * 8).to_le_bytes());
                v[frame::WIRE_PREFIX_LEN - 24 + 8..frame::WIRE_PREFIX_LEN - 24 + 12]
                    .copy_from_slice(&cols.to_le_bytes());
                v
            }
            // wrong magic / version / format / reserved
            _ => {
                let mut v = valid.to_vec();
                let pos =
                    [0usize, 1, 2, 3, 4, 5, 10, 11, 50, 51, 60, 61, 62, 63][rng.below(14) as usize];
                v[pos] = v[pos].wrapping_add(1 + rng.below(250) as u8);
                v
            }
        };
        if frame::decode_wire(&p, max_frame_bytes, true).is_err() {
            return p;
        }
    }
}

fn z_flood(
    key: &str,
    count: u64,
    max_frame_bytes: usize,
    seed: u64,
    wait_matching: bool,
    zenoh: &ZenohArgs,
) -> Result<()> {
    let node = z_node(zenoh, "bench-zflood")?;
    let publisher = node.frame_publisher(key, CongestionControl::Block, Locality::Any)?;
    let samples = pattern(4096)?;
    let payload = frame::samples_as_bytes(&samples);
    let valid = frame::encode_wire(
        &meta_for(0, samples.len())?.header(Some(frame::checksum(payload)))?,
        payload,
    )?;
    if wait_matching {
        let deadline = Instant::now() + Duration::from_secs(20);
        while !publisher.has_remote_subscribers() {
            if Instant::now() > deadline {
                bail!("no subscriber matched {key} within 20 s");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    ready();
    let mut rng = Rng(seed.max(1));
    let start = Instant::now();
    let mut oversized_real = 0u64;
    for i in 0..count {
        // two payloads really larger than the limit (the rest only claim to be)
        let p = if i == count / 3 || i == 2 * count / 3 {
            oversized_real += 1;
            vec![0xa5u8; WIRE_PREFIX_LEN + max_frame_bytes + 8]
        } else {
            bad_payload(&mut rng, &valid, max_frame_bytes, i)
        };
        publisher.put_raw(p)?;
    }
    let elapsed = start.elapsed().as_secs_f64();
    std::thread::sleep(Duration::from_millis(300));
    let c = publisher.counters().snapshot();
    drop(publisher);
    node.close()?;
    report(&serde_json::json!({
        "sent": c.sent, "oversized_real": oversized_real, "elapsed_s": elapsed
    }))
}

// ---------------------------------------------------------------------------------------
// The benchmark orchestrator.

struct Proc {
    name: String,
    child: Child,
    lines: mpsc::Receiver<String>,
}

impl Proc {
    fn spawn(name: &str, exe: &Path, args: &[String]) -> Result<Proc> {
        let mut child = Command::new(exe)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .with_context(|| format!("starting {name} ({})", exe.display()))?;
        let out: ChildStdout = child
            .stdout
            .take()
            .ok_or_else(|| anyhow!("no stdout of {name}"))?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Proc {
            name: name.to_string(),
            child,
            lines: rx,
        })
    }

    fn expect_line(&self, timeout: Duration) -> Result<String> {
        self.lines
            .recv_timeout(timeout)
            .map_err(|_| anyhow!("{}: no output within {timeout:?}", self.name))
    }

    fn ready(&self) -> Result<()> {
        let l = self.expect_line(Duration::from_secs(30))?;
        if l != "READY" {
            bail!("{}: expected READY, got {l:?}", self.name);
        }
        Ok(())
    }

    fn report<T: for<'de> Deserialize<'de>>(&mut self, timeout: Duration) -> Result<T> {
        let l = self.expect_line(timeout)?;
        let r = serde_json::from_str(&l).with_context(|| format!("{}: report {l:?}", self.name))?;
        let _ = self.child.wait();
        Ok(r)
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            harness::signal(self.child.id(), harness::Signal::SIGTERM);
            let deadline = Instant::now() + Duration::from_secs(5);
            while Instant::now() < deadline {
                if let Ok(Some(_)) = self.child.try_wait() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

fn s(v: &str) -> String {
    v.to_string()
}

fn free_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(l.local_addr()?.port())
}

#[derive(Serialize, Clone)]
struct BenchRow {
    path: String,
    mode: String,
    frame_mib: usize,
    rep: usize,
    rate_hz: f64,
    tx: TxReport,
    rx: RxReport,
}

struct BenchCtx {
    me: PathBuf,
    bridge_exe: PathBuf,
    root: PathBuf,
    max: usize,
    run: usize,
    inbound_queue: usize,
}

impl BenchCtx {
    fn prefix(&mut self, tag: &str) -> String {
        self.run += 1;
        format!("cb{}_{}_{tag}_", std::process::id(), self.run)
    }

    fn svc(&self, prefix: &str) -> Vec<String> {
        vec![
            s("--service"),
            s("bench/frames"),
            s("--max-frame-bytes"),
            self.max.to_string(),
            s("--iox-root"),
            self.root.display().to_string(),
            s("--iox-prefix"),
            prefix.to_string(),
        ]
    }

    fn timeout(frames: u64, rate: f64) -> Duration {
        let paced = if rate > 0.0 {
            frames as f64 / rate
        } else {
            0.0
        };
        Duration::from_secs_f64(
            (60.0 + 2.0 * paced + frames as f64).min(bridge::flags::MAX_SECONDS),
        )
    }

    /// Producer -> consumer on one iceoryx2 service.
    fn iox(
        &mut self,
        bytes: usize,
        frames: u64,
        rate: f64,
        block: bool,
        spin: bool,
    ) -> Result<(TxReport, RxReport)> {
        let prefix = self.prefix("iox");
        let mut sub_args = vec![s("iox-sub")];
        sub_args.extend(self.svc(&prefix));
        sub_args.extend([s("--frames"), frames.to_string()]);
        if spin {
            sub_args.push(s("--spin"));
        }
        let mut sub = Proc::spawn("iox-sub", &self.me, &sub_args)?;
        sub.ready()?;
        let mut pub_args = vec![s("iox-pub")];
        pub_args.extend(self.svc(&prefix));
        pub_args.extend(tx_args(frames, bytes, rate));
        if block {
            pub_args.push(s("--block"));
        }
        let mut publ = Proc::spawn("iox-pub", &self.me, &pub_args)?;
        publ.ready()?;
        let t = Self::timeout(frames, rate);
        Ok((publ.report(t)?, sub.report(t)?))
    }

    /// Plain Zenoh publisher -> subscriber (two processes, TCP loopback).
    fn zenoh(
        &mut self,
        bytes: usize,
        frames: u64,
        rate: f64,
        key: &str,
    ) -> Result<(TxReport, RxReport)> {
        let port = free_port()?;
        let ep = format!("tcp/127.0.0.1:{port}");
        let mut sub_args = vec![
            s("z-sub"),
            s("--key"),
            s(key),
            s("--frames"),
            frames.to_string(),
            s("--max-frame-bytes"),
            self.max.to_string(),
            s("--no-multicast-scouting"),
            s("-l"),
            ep.clone(),
        ];
        sub_args.push(s("--idle-s"));
        sub_args.push(s("10"));
        let mut sub = Proc::spawn("z-sub", &self.me, &sub_args)?;
        sub.ready()?;
        let mut pub_args = vec![
            s("z-pub"),
            s("--key"),
            s(key),
            s("--wait-matching"),
            s("--no-multicast-scouting"),
            s("-e"),
            ep,
        ];
        pub_args.extend(tx_args(frames, bytes, rate));
        let mut publ = Proc::spawn("z-pub", &self.me, &pub_args)?;
        publ.ready()?;
        let t = Self::timeout(frames, rate);
        Ok((publ.report(t)?, sub.report(t)?))
    }

    /// iceoryx2 producer (host A) -> bridge A -> Zenoh (TCP loopback) -> bridge B -> iceoryx2
    /// consumer (host B); the "hosts" are two isolated iceoryx2 environments.
    fn bridged(
        &mut self,
        bytes: usize,
        frames: u64,
        rate: f64,
        block: bool,
        key: &str,
    ) -> Result<(TxReport, RxReport)> {
        let port = free_port()?;
        let ep = format!("tcp/127.0.0.1:{port}");
        let pa = self.prefix("a");
        let pb = self.prefix("b");
        let bridge_args = |instance: &str, prefix: &str, dir: &str, z: &[String]| -> Vec<String> {
            let mut v = vec![
                s("--instance"),
                s(instance),
                s("--service"),
                format!("bench/frames={key}@{dir}"),
                s("--max-frame-bytes"),
                self.max.to_string(),
                s("--iox-root"),
                self.root.display().to_string(),
                s("--iox-prefix"),
                prefix.to_string(),
                s("--no-verify-checksum"),
                s("--stats-interval-s"),
                s("3600"),
                s("--no-multicast-scouting"),
            ];
            v.extend(z.iter().cloned());
            v
        };
        // lossless runs: bridge B waits for the consumer instead of skipping it
        let mut zb = vec![
            s("-l"),
            ep.clone(),
            s("--inbound-queue"),
            self.inbound_queue.to_string(),
        ];
        if block {
            zb.extend([s("--inbound-backpressure"), s("block")]);
        }
        let bb = Proc::spawn(
            "bridge-b",
            &self.bridge_exe,
            &bridge_args("bench-b", &pb, "in", &zb),
        )?;
        let mut sub_args = vec![s("iox-sub")];
        sub_args.extend(self.svc(&pb));
        sub_args.extend([s("--frames"), frames.to_string(), s("--idle-s"), s("10")]);
        let mut sub = Proc::spawn("iox-sub(b)", &self.me, &sub_args)?;
        sub.ready()?;
        let ba = Proc::spawn(
            "bridge-a",
            &self.bridge_exe,
            &bridge_args("bench-a", &pa, "out", &[s("-e"), ep.clone()]),
        )?;
        wait_bridged(&ep, key, Duration::from_secs(30))?;
        let mut pub_args = vec![s("iox-pub")];
        pub_args.extend(self.svc(&pa));
        pub_args.extend(tx_args(frames, bytes, rate));
        if block {
            pub_args.push(s("--block"));
        }
        let mut publ = Proc::spawn("iox-pub(a)", &self.me, &pub_args)?;
        publ.ready()?;
        let t = Self::timeout(frames, rate);
        let r = (publ.report(t)?, sub.report(t)?);
        drop(ba);
        drop(bb);
        Ok(r)
    }
}

/// Copies `bytes` from one buffer to another `frames` times (pages touched beforehand).
fn memcpy_baseline(bytes: usize, frames: u64) -> (TxReport, RxReport) {
    let src = vec![0x5au8; bytes];
    let mut dst = vec![0u8; bytes];
    dst.copy_from_slice(&src);
    let t = Instant::now();
    for i in 0..frames {
        dst.copy_from_slice(&src);
        std::hint::black_box(&dst[(i as usize * 4096) % bytes]);
    }
    let el = t.elapsed().as_secs_f64();
    let total = bytes as u64 * frames;
    let tp = total as f64 / el / 1e6;
    (
        TxReport {
            frames,
            bytes: total,
            dropped: 0,
            send_errors: 0,
            elapsed_s: el,
            throughput_mb_s: tp,
        },
        RxReport {
            frames,
            bytes: total,
            elapsed_s: el,
            throughput_mb_s: tp,
            lat_us_p50: f64::NAN,
            lat_us_p90: f64::NAN,
            lat_us_p99: f64::NAN,
            lat_us_max: f64::NAN,
            ..RxReport::default()
        },
    )
}

fn tx_args(frames: u64, bytes: usize, rate: f64) -> Vec<String> {
    vec![
        s("--frames"),
        frames.to_string(),
        s("--frame-bytes"),
        bytes.to_string(),
        s("--rate-hz"),
        rate.to_string(),
        s("--no-checksum"),
    ]
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[allow(clippy::too_many_arguments)]
fn bench(
    sizes_mib: &[usize],
    frames: u64,
    latency_rate_hz: f64,
    latency_budget_mb_s: f64,
    repeats: usize,
    json_out: Option<&Path>,
    inbound_queue: usize,
) -> Result<()> {
    let me = std::env::current_exe()?;
    let bridge_exe = me.with_file_name("cellsar-bridge");
    if !bridge_exe.exists() {
        bail!("{} not found next to this binary", bridge_exe.display());
    }
    let root = std::env::temp_dir().join(format!("cellsar-bench-{}", std::process::id()));
    std::fs::create_dir_all(&root)?;
    let mut ctx = BenchCtx {
        me,
        bridge_exe,
        root: root.clone(),
        max: sizes_mib.iter().copied().max().unwrap_or(32) << 20,
        run: 0,
        inbound_queue,
    };
    let mut rows: Vec<BenchRow> = Vec::new();
    let push = |rows: &mut Vec<BenchRow>,
                path: &str,
                mode: &str,
                mib: usize,
                rep: usize,
                rate: f64,
                r: (TxReport, RxReport)| {
        eprintln!(
            "{path} {mode} {mib} MiB rep {rep}: tx {:?}\n    rx {:?}",
            r.0, r.1
        );
        rows.push(BenchRow {
            path: s(path),
            mode: s(mode),
            frame_mib: mib,
            rep,
            rate_hz: rate,
            tx: r.0,
            rx: r.1,
        });
    };
    for &mib in sizes_mib {
        let bytes = mib << 20;
        // paced well below the path's capacity so latency is not queueing delay
        let lat_rate = latency_rate_hz.min(latency_budget_mb_s * 1e6 / bytes as f64);
        for rep in 0..repeats {
            // reference: one process copying the same bytes (the memory bandwidth the
            // iceoryx2 producer's copy into shared memory is bound by)
            let r = memcpy_baseline(bytes, frames);
            push(&mut rows, "memcpy", "throughput", mib, rep, 0.0, r);
            let r = ctx.iox(bytes, frames, lat_rate, false, false)?;
            push(&mut rows, "iceoryx2", "latency", mib, rep, lat_rate, r);
            let r = ctx.iox(bytes, frames, lat_rate, false, true)?;
            push(&mut rows, "iceoryx2", "latency-spin", mib, rep, lat_rate, r);
            let r = ctx.iox(bytes, frames, 0.0, true, false)?;
            push(&mut rows, "iceoryx2", "throughput", mib, rep, 0.0, r);
            // plain Zenoh and the bridged path alternate, so load changes hit both alike
            let key = format!("bench/{mib}/{rep}");
            let r = ctx.zenoh(bytes, frames, lat_rate, &format!("{key}/zl"))?;
            push(&mut rows, "zenoh", "latency", mib, rep, lat_rate, r);
            let r = ctx.bridged(bytes, frames, lat_rate, false, &format!("{key}/bl"))?;
            push(&mut rows, "bridge", "latency", mib, rep, lat_rate, r);
            let r = ctx.zenoh(bytes, frames, 0.0, &format!("{key}/zt"))?;
            push(&mut rows, "zenoh", "throughput", mib, rep, 0.0, r);
            let r = ctx.bridged(bytes, frames, 0.0, true, &format!("{key}/bt"))?;
            push(&mut rows, "bridge", "throughput", mib, rep, 0.0, r);
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    // iceoryx2 leaves a small management segment per prefix in /dev/shm: remove ours
    let ours = format!("cb{}_", std::process::id());
    if let Ok(rd) = std::fs::read_dir("/dev/shm") {
        for e in rd.flatten() {
            if e.file_name().to_string_lossy().starts_with(&ours) {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }

    println!("Medians over {repeats} repetition(s) of {frames} frames each.\n");
    println!("| path | mode | frame | rate | frames rx/tx (all reps) | p50 latency | p90 | p99 | throughput (rx) |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let mut keys: Vec<(String, String, usize)> = Vec::new();
    for r in &rows {
        let k = (r.path.clone(), r.mode.clone(), r.frame_mib);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (path, mode, mib) in &keys {
        let sel: Vec<&BenchRow> = rows
            .iter()
            .filter(|r| &r.path == path && &r.mode == mode && r.frame_mib == *mib)
            .collect();
        let rx: u64 = sel.iter().map(|r| r.rx.frames).sum();
        let tx: u64 = sel.iter().map(|r| r.tx.frames).sum();
        let m = |f: &dyn Fn(&BenchRow) -> f64| median(sel.iter().map(|r| f(r)).collect());
        let rate = sel.first().map(|r| r.rate_hz).unwrap_or(0.0);
        println!(
            "| {path} | {mode} | {mib} MiB | {} | {rx}/{tx} | {:.1} µs | {:.1} µs | {:.1} µs | {:.0} MB/s |",
            if rate > 0.0 { format!("{rate:.1} Hz") } else { s("max") },
            m(&|r| r.rx.lat_us_p50),
            m(&|r| r.rx.lat_us_p90),
            m(&|r| r.rx.lat_us_p99),
            m(&|r| r.rx.throughput_mb_s),
        );
    }
    println!("\n| frame | bridge / plain Zenoh throughput (median of per-repetition ratios) | bridge / plain p50 latency |");
    println!("|---:|---:|---:|");
    for &mib in sizes_mib {
        let pick = |path: &str, mode: &str, rep: usize| {
            rows.iter()
                .find(|r| r.path == path && r.mode == mode && r.frame_mib == mib && r.rep == rep)
        };
        let mut tp = Vec::new();
        let mut lat = Vec::new();
        for rep in 0..repeats {
            if let (Some(b), Some(z)) = (
                pick("bridge", "throughput", rep),
                pick("zenoh", "throughput", rep),
            ) {
                tp.push(b.rx.throughput_mb_s / z.rx.throughput_mb_s);
            }
            if let (Some(b), Some(z)) = (
                pick("bridge", "latency", rep),
                pick("zenoh", "latency", rep),
            ) {
                lat.push(b.rx.lat_us_p50 / z.rx.lat_us_p50);
            }
        }
        println!("| {mib} MiB | {:.3} | {:.3} |", median(tp), median(lat));
    }
    if let Some(p) = json_out {
        std::fs::write(p, serde_json::to_string_pretty(&rows)?)?;
    }
    Ok(())
}

/// Waits until bridge A's route on `key` is up and sees bridge B's subscriber (its stats say
/// `remote_subscribers`), so no frame is sent before it can be delivered.
fn wait_bridged(endpoint: &str, key: &str, timeout: Duration) -> Result<()> {
    let args = ZenohArgs {
        no_multicast_scouting: true,
        connect: vec![endpoint.to_string()],
        mode: Some(bridge::zconfig::Mode::Peer),
        ..ZenohArgs::default()
    };
    let node = ZenohNode::open(
        args.to_config()?,
        "bench-probe",
        &format!("p{}", std::process::id()),
    )?;
    let stats_key = bridge::keys::bridge_stats("bench-a")?;
    let deadline = Instant::now() + timeout;
    loop {
        let replies = node
            .session()
            .get(&stats_key)
            .timeout(Duration::from_millis(500))
            .wait()
            .map_err(|e| anyhow!("query {stats_key}: {e}"))?;
        let matched = replies.recv().ok().and_then(|r| {
            let sample = r.result().ok()?;
            let v: serde_json::Value = serde_json::from_slice(&sample.payload().to_bytes()).ok()?;
            v["body"]["routes"][0]["remote_subscribers"].as_bool()
        });
        if matched == Some(true) {
            break;
        }
        if Instant::now() > deadline {
            bail!("bridge A did not see a remote subscriber on {key}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    node.close()?;
    Ok(())
}
