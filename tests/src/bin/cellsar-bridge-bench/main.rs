//! `cellsar-bridge-bench`: frame tools and the transport benchmark.
//!
//! Tools (each prints `READY` on stdout once set up, then one JSON report line at the end):
//!
//! - `iox-pub` / `iox-sub`: publish / consume frames on an iceoryx2 frame service;
//! - `z-pub` / `z-sub`: publish / consume the same frames on a plain Zenoh key;
//! - `z-duplex`: publish frames on one Zenoh key while taking them from another (a link
//!   carrying traffic both ways at once);
//! - `z-flood`: send malformed and oversized frame payloads on a Zenoh key (each one checked
//!   to be rejected by this crate's own decoder before it is sent);
//! - `forge`: a hostile peer publishing a forged processor status, detections, images and
//!   metrics for every mission it learns of, forged plans, and floods of plans and queries.
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

mod bench;
mod duplex;
mod forge;
mod tools;

use bench::bench;
use tools::{iox_pub, iox_sub, z_flood, z_pub, z_sub};

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
    /// Publish frames on one Zenoh key while taking frames from another, for a time.
    ZDuplex(duplex::DuplexArgs),
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
    /// Forge statuses, results and plans, and flood plans and queries (a hostile peer).
    Forge(forge::ForgeArgs),
    /// Run the benchmark and print a Markdown table.
    Bench(BenchArgs),
}

/// The flags of `bench`.
#[derive(clap::Args, Debug, Clone)]
struct BenchArgs {
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
    /// Also run the bridged path over mutual TLS (`bridge-tls`, certificates of a test CA
    /// made for the run), alternating with the plain TCP one.
    #[arg(long)]
    tls: bool,
    /// Only the bridged paths (and plain Zenoh): skip memcpy and iceoryx2.
    #[arg(long)]
    only_network: bool,
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
        Cmd::ZDuplex(args) => duplex::z_duplex(&args),
        Cmd::Forge(args) => forge::forge(&args),
        Cmd::Bench(args) => bench(&args),
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
