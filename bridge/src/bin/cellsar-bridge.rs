//! `cellsar-bridge`: forwards iceoryx2 frame services to Zenoh keys and back.
//!
//! ```text
//! cellsar-bridge --instance b1 --service cellsar/0123456789abcdef/echo \
//!     [--service NAME=KEY@out ...] [-m peer|client|router] [-e ENDPOINT] [-l ENDPOINT] \
//!     [-c zenoh.json5] [--no-multicast-scouting] [--iox-root DIR] [--iox-prefix P]
//! ```
//!
//! Logs its counters every `--stats-interval-s` and on exit, publishes them as JSON on
//! `cellsar/bridge/<instance>/stats` and answers queries there. Stops cleanly on SIGINT or
//! SIGTERM (exit code 0). Exit codes: 2 bad input (a flag, route, Zenoh or iceoryx2
//! configuration; the message names it, on one line), 1 a failure at run time (setting up
//! Zenoh or iceoryx2, a forwarding thread that dies).

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use bridge::envelope::{encode_json, Meta};
use bridge::forward::{Forwarder, ForwarderConfig, Route};
use bridge::iox::{init_iceoryx_logging, Backpressure, IoxArgs};
use bridge::net::{PublishOptions, WireFormat};
use bridge::stats::BridgeStats;
use bridge::zenoh::qos::CongestionControl;
use bridge::zenoh::query::Query;
use bridge::zenoh::Wait;
use bridge::{keys, Message, ZenohArgs, ZenohNode};
use cellsar_error::exit::Failure;
use clap::Parser;

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Congestion {
    /// Lossless: a slow network back-pressures the bridge (and its iceoryx2 subscriber then
    /// skips frames, counted as `missed`).
    Block,
    /// Never stall: Zenoh drops what its queues cannot take.
    Drop,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum LocalBackpressure {
    /// Skip the full subscriber for that frame and count it.
    Discard,
    /// Wait until it has room.
    Block,
}

/// Forwards iceoryx2 frame services to Zenoh keys and back, without loops.
///
/// Exit codes: 0 stopped by SIGINT/SIGTERM; 1 failure at run time; 2 bad input (flag, route,
/// Zenoh or iceoryx2 configuration).
#[derive(Parser, Debug)]
#[command(name = "cellsar-bridge", version)]
struct Cli {
    /// Instance name (liveliness token `cellsar/alive/bridge/<instance>`, stats key).
    #[arg(long, default_value = "bridge")]
    instance: String,
    /// A route `NAME[=KEY][@both|out|in]`: iceoryx2 frame service NAME <-> Zenoh key KEY
    /// (default: the same string), both ways unless told otherwise. Repeatable.
    #[arg(long = "service", value_name = "ROUTE", required = true)]
    services: Vec<String>,
    /// Largest frame payload in bytes (sizes every service's samples; the echo and the
    /// processor must be given the same value, and have the same default).
    #[arg(long, default_value_t = bridge::frame::SERVICE_MAX_FRAME_BYTES)]
    max_frame_bytes: usize,
    /// Subscribers each service admits.
    #[arg(long, default_value_t = 4)]
    max_subscribers: usize,
    /// Publishers each service admits.
    #[arg(long, default_value_t = 2)]
    max_publishers: usize,
    /// Frames each subscriber can queue.
    #[arg(long, default_value_t = 2)]
    subscriber_buffer: usize,
    /// Do not verify the CRC of frames arriving from Zenoh.
    #[arg(long)]
    no_verify_checksum: bool,
    /// Congestion control of the Zenoh publishers.
    #[arg(long, value_enum, default_value_t = Congestion::Block)]
    congestion: Congestion,
    /// Frames queued between Zenoh and a thread that re-publishes them on iceoryx2; 0
    /// re-publishes in Zenoh's callback without a thread hand-off (no latency gain measured on
    /// a 2-vCPU host: see bridge/BENCHMARKS.md).
    #[arg(long, default_value_t = 4)]
    inbound_queue: usize,
    /// When a local subscriber's buffer is full: discard (skip and count; never stall) or
    /// block (lossless; back-pressures Zenoh and the remote sender).
    #[arg(long, value_enum, default_value_t = LocalBackpressure::Discard)]
    inbound_backpressure: LocalBackpressure,
    /// Seconds between counter logs and stats publications (finite, > 0).
    #[arg(long, default_value_t = 5.0, value_parser = bridge::flags::parse_seconds)]
    stats_interval_s: f64,
    #[command(flatten)]
    zenoh: ZenohArgs,
    #[command(flatten)]
    iox: IoxArgs,
}

fn main() -> ExitCode {
    init_tracing();
    let cli = Cli::parse();
    // printed once, on stderr (tracing's own output also goes there)
    let r = check(&cli)
        .map_err(Failure::bad_input)
        .and_then(|setup| run(&cli, setup).map_err(Failure::runtime));
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

/// What [`check`] derived from the flags.
struct Setup {
    config: ForwarderConfig,
    zconfig: bridge::zenoh::Config,
    env: bridge::IoxEnv,
    interval: Duration,
}

/// Checks every flag before anything starts (bad input: exit code 2).
fn check(cli: &Cli) -> Result<Setup> {
    let interval = bridge::flags::seconds("--stats-interval-s", cli.stats_interval_s)?;
    let mut routes = Vec::new();
    for s in &cli.services {
        let mut r = Route::parse(s, cli.max_frame_bytes)?;
        r.service.max_subscribers = cli.max_subscribers;
        r.service.max_publishers = cli.max_publishers;
        r.service.subscriber_buffer = cli.subscriber_buffer;
        r.service.validate()?;
        routes.push(r);
    }
    let config = ForwarderConfig {
        instance: cli.instance.clone(),
        routes,
        verify_checksum: !cli.no_verify_checksum,
        congestion_control: match cli.congestion {
            Congestion::Block => CongestionControl::Block,
            Congestion::Drop => CongestionControl::Drop,
        },
        inbound_queue: cli.inbound_queue,
        inbound_backpressure: match cli.inbound_backpressure {
            LocalBackpressure::Discard => Backpressure::Discard,
            LocalBackpressure::Block => Backpressure::Block,
        },
    };
    config.validate()?;
    keys::alive("bridge", &cli.instance)?;
    let zconfig = cli.zenoh.to_config()?;
    let env = cli.iox.env()?;
    Ok(Setup {
        config,
        zconfig,
        env,
        interval,
    })
}

fn init_tracing() {
    cellsar_error::init_logging("info");
    init_iceoryx_logging();
}

fn run(cli: &Cli, setup: Setup) -> Result<()> {
    let Setup {
        config,
        zconfig,
        env,
        interval,
    } = setup;
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone())
            .with_context(|| format!("installing the handler of signal {sig}"))?;
    }

    let node = ZenohNode::open(zconfig, "bridge", &cli.instance)?;
    let forwarder = Forwarder::start(&node, &env, &config)?;

    let stats_key = keys::bridge_stats(&cli.instance)?;
    let stats_pub = node.publisher::<BridgeStats>(&stats_key, PublishOptions::json())?;
    let source = forwarder.stats_source();
    let seq = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let qseq = seq.clone();
    let qkey = stats_key.clone();
    let _queryable = node
        .session()
        .declare_queryable(stats_key.clone())
        .callback(move |query: Query| {
            let meta = Meta {
                seq: qseq.fetch_add(1, Ordering::Relaxed),
                ..Meta::default()
            };
            match encode_json(&source.snapshot(), meta) {
                Ok(bytes) => {
                    let _ = query
                        .reply(qkey.clone(), bytes)
                        .encoding(WireFormat::Json.encoding::<BridgeStats>())
                        .wait();
                }
                Err(e) => {
                    let _ = query.reply_err(e.to_string()).wait();
                }
            }
        })
        .wait()
        .map_err(|e| anyhow::anyhow!("declaring the stats queryable on {stats_key}: {e}"))?;

    tracing::info!(
        instance = %cli.instance,
        routes = cli.services.len(),
        stats = %stats_key,
        "bridge running (kind {}); stops on SIGINT/SIGTERM",
        BridgeStats::NAME
    );
    let mut last = Instant::now();
    let mut failed = false;
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
        if !forwarder.is_running() {
            failed = true;
            break;
        }
        if last.elapsed() >= interval {
            last = Instant::now();
            let stats = forwarder.stats();
            log_stats(&stats, false);
            if let Err(e) = stats_pub.put(&stats) {
                tracing::warn!(error = %e, "publishing stats failed");
            }
        }
    }
    tracing::info!("stopping");
    let stats = forwarder.stop();
    let stats = match stats {
        Ok(s) => s,
        Err(e) => {
            let _ = node.close();
            return Err(e.into());
        }
    };
    log_stats(&stats, true);
    let _ = stats_pub.put(&stats);
    drop(stats_pub);
    node.close()?;
    if failed {
        bail!("a forwarding thread stopped unexpectedly");
    }
    Ok(())
}

fn log_stats(stats: &BridgeStats, last: bool) {
    for r in &stats.routes {
        let o = &r.to_zenoh;
        let i = &r.from_zenoh;
        tracing::info!(
            final_counters = last,
            service = %r.service,
            key = %r.key,
            out_received = o.received,
            out_forwarded = o.forwarded,
            out_missed = o.missed,
            out_unmatched = o.unmatched,
            out_malformed = o.malformed,
            out_send_errors = o.send_errors,
            in_received = i.received,
            in_forwarded = i.forwarded,
            in_malformed = i.malformed,
            in_dropped_full = i.dropped,
            in_send_errors = i.send_errors,
            "route counters"
        );
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn max_frame_bytes_defaults_to_the_services_value() {
        let cli = Cli::try_parse_from(["cellsar-bridge", "--service", "x"]).unwrap();
        assert_eq!(cli.max_frame_bytes, bridge::frame::SERVICE_MAX_FRAME_BYTES);
    }

    #[test]
    fn stats_interval_must_be_positive_seconds() {
        for bad in ["nan", "-1", "0", "inf"] {
            let e = Cli::try_parse_from([
                "cellsar-bridge",
                "--service",
                "x",
                &format!("--stats-interval-s={bad}"),
            ])
            .unwrap_err();
            assert_eq!(e.exit_code(), 2, "{bad}");
            assert!(e.to_string().contains("--stats-interval-s"), "{e}");
        }
    }
}
