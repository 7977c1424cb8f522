//! The roles the `cellsar` binary runs as a child: the bridge (a thin front end of
//! `bridge::forward`, the same engine and flags as `cellsar-bridge`) and a plain Zenoh router.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use bridge::forward::{Forwarder, ForwarderConfig, Route};
use bridge::iox::Backpressure;
use bridge::net::PublishOptions;
use bridge::stats::BridgeStats;
use bridge::zconfig::Mode;
use bridge::zenoh::qos::CongestionControl;
use bridge::{flags, keys, IoxArgs, ZenohArgs, ZenohNode};

use crate::exit::Failure;

/// Congestion control of the bridge's Zenoh publishers.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Congestion {
    /// Lossless: a slow network back-pressures the bridge.
    Block,
    /// Never stall: Zenoh drops what its queues cannot take.
    Drop,
}

/// Flags of `cellsar bridge` (as `cellsar-bridge`).
#[derive(clap::Args, Debug, Clone)]
pub struct BridgeArgs {
    /// Instance name (liveliness token `cellsar/alive/bridge/<instance>`, stats key).
    #[arg(long, default_value = "bridge")]
    pub instance: String,
    /// A route `NAME[=KEY][@both|out|in]` (repeatable).
    #[arg(long = "service", value_name = "ROUTE", required = true)]
    pub services: Vec<String>,
    /// Largest frame payload in bytes (as given to the echo and the processor; the same
    /// default as theirs and `cellsar-bridge`'s).
    #[arg(long, default_value_t = bridge::frame::SERVICE_MAX_FRAME_BYTES)]
    pub max_frame_bytes: usize,
    /// Congestion control of the Zenoh publishers.
    #[arg(long, value_enum, default_value_t = Congestion::Block)]
    pub congestion: Congestion,
    /// Seconds between counter logs and stats publications (finite, > 0).
    #[arg(long, default_value_t = 5.0, value_parser = flags::parse_seconds)]
    pub stats_interval_s: f64,
    /// Zenoh flags.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// iceoryx2 flags.
    #[command(flatten)]
    pub iox: IoxArgs,
}

/// Runs the bridge until `stop` is set. Flags, routes and the Zenoh and iceoryx2
/// configuration are checked before anything starts (bad input).
pub fn run_bridge(args: &BridgeArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let interval =
        flags::seconds("--stats-interval-s", args.stats_interval_s).map_err(Failure::bad_input)?;
    let mut routes = Vec::new();
    for s in &args.services {
        let r = Route::parse(s, args.max_frame_bytes).map_err(Failure::bad_input)?;
        r.service.validate().map_err(Failure::bad_input)?;
        routes.push(r);
    }
    let config = ForwarderConfig {
        instance: args.instance.clone(),
        routes,
        verify_checksum: true,
        congestion_control: match args.congestion {
            Congestion::Block => CongestionControl::Block,
            Congestion::Drop => CongestionControl::Drop,
        },
        inbound_queue: 4,
        // A frozen local consumer must never stall the bridge (SIGSTOP test).
        inbound_backpressure: Backpressure::Discard,
    };
    config.validate().map_err(Failure::bad_input)?;
    keys::alive("bridge", &args.instance).map_err(Failure::bad_input)?;
    let zconfig = args.zenoh.to_config().map_err(Failure::bad_input)?;
    let env = args.iox.env().map_err(Failure::bad_input)?;
    forward(args, &config, zconfig, &env, interval, stop).map_err(Failure::runtime)
}

fn forward(
    args: &BridgeArgs,
    config: &ForwarderConfig,
    zconfig: bridge::zenoh::Config,
    env: &bridge::IoxEnv,
    interval: Duration,
    stop: &AtomicBool,
) -> Result<()> {
    let node = ZenohNode::open(zconfig, "bridge", &args.instance)?;
    let forwarder = Forwarder::start(&node, env, config)?;
    let stats_pub = node.publisher::<BridgeStats>(
        &keys::bridge_stats(&args.instance)?,
        PublishOptions {
            congestion_control: CongestionControl::Drop,
            ..PublishOptions::json()
        },
    )?;
    tracing::info!(instance = %args.instance, routes = args.services.len(), "bridge running");
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
            let _ = stats_pub.put(&forwarder.stats());
        }
    }
    let stats = forwarder.stop()?;
    for r in &stats.routes {
        tracing::info!(final_counters = true, service = %r.service, key = %r.key,
            out_received = r.to_zenoh.received, out_forwarded = r.to_zenoh.forwarded,
            out_missed = r.to_zenoh.missed, out_unmatched = r.to_zenoh.unmatched,
            in_received = r.from_zenoh.received, in_forwarded = r.from_zenoh.forwarded,
            in_malformed = r.from_zenoh.malformed, in_dropped = r.from_zenoh.dropped,
            "route counters");
    }
    let _ = stats_pub.put(&stats);
    drop(stats_pub);
    node.close()?;
    if failed {
        bail!("a forwarding thread stopped unexpectedly");
    }
    Ok(())
}

/// Flags of `cellsar router`.
#[derive(clap::Args, Debug, Clone)]
pub struct RouterArgs {
    /// Instance name (liveliness token `cellsar/alive/router/<instance>`).
    #[arg(long, default_value = "router")]
    pub instance: String,
    /// Zenoh flags (mode defaults to router; give -l ENDPOINT or -c FILE).
    #[command(flatten)]
    pub zenoh: ZenohArgs,
}

/// A plain Zenoh router (what `zenohd` does without plugins) until `stop` is set. The flags
/// are checked before anything starts (bad input).
pub fn run_router(args: &RouterArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let mut z = args.zenoh.clone();
    if z.listen.is_empty() && z.config.is_none() {
        return Err(Failure::bad_input(anyhow!("a router needs an endpoint to listen on: give -l ENDPOINT (e.g. -l tcp/0.0.0.0:7447) or -c FILE")));
    }
    if z.mode.is_none() {
        z.mode = Some(Mode::Router);
    }
    let config = z
        .to_config()
        .context("router configuration")
        .map_err(Failure::bad_input)?;
    keys::alive("router", &args.instance).map_err(Failure::bad_input)?;
    route(args, &z, config, stop).map_err(Failure::runtime)
}

fn route(
    args: &RouterArgs,
    z: &ZenohArgs,
    config: bridge::zenoh::Config,
    stop: &AtomicBool,
) -> Result<()> {
    let node = ZenohNode::open(config, "router", &args.instance)?;
    tracing::info!(instance = %args.instance, listen = ?z.listen, "router running");
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
    }
    node.close()?;
    Ok(())
}
