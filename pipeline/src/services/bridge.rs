//! The bridge as a process: its flags ([`BridgeArgs`]), their checked set-up
//! ([`BridgeArgs::setup`]) and the run loop ([`BridgeSetup::run`]). `cellsar-bridge` and the
//! `cellsar bridge` role of the launcher are both this code, with the same flags.
//!
//! ```text
//! cellsar/alive/bridge/<instance>          liveliness token
//! cellsar/bridge/<instance>/stats          BridgeStats (JSON), published every
//!                                          --stats-interval-s and at exit, answered to queries
//! cellsar/bridged/<instance>/<data key>    liveliness token per route
//! ```

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bridge::zenoh::qos::CongestionControl;
use bridge::zenoh::query::Query;
use bridge::zenoh::Wait;
use cellsar_error::exit::Failure;

use bridge::envelope::{encode_json, Message, Meta};
use bridge::flags::{self, Seconds};
use bridge::forward::{ForwardError, Forwarder, ForwarderConfig, Route};
use bridge::iox::{Backpressure, IoxArgs, IoxEnv, IoxError};
use bridge::keys::{self, KeyError};
use bridge::net::{refuse_query, NetError, PublishOptions, WireFormat, ZenohNode};
use bridge::refusal::{Refusal, RefusalKind};
use bridge::stats::BridgeStats;
use bridge::zconfig::{ConfigError, ZenohArgs};

/// Congestion control of the bridge's Zenoh frame publishers.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Congestion {
    /// Lossless: a slow network back-pressures the bridge (and its iceoryx2 subscriber then
    /// skips frames, counted as `missed`).
    Block,
    /// Never stall: Zenoh drops what its queues cannot take.
    Drop,
}

impl From<Congestion> for CongestionControl {
    fn from(c: Congestion) -> Self {
        match c {
            Congestion::Block => CongestionControl::Block,
            Congestion::Drop => CongestionControl::Drop,
        }
    }
}

/// What re-publishing a frame from Zenoh does when a local subscriber's buffer is full.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocalBackpressure {
    /// Skip the full subscriber for that frame and count it.
    Discard,
    /// Wait until it has room.
    Block,
}

impl From<LocalBackpressure> for Backpressure {
    fn from(b: LocalBackpressure) -> Self {
        match b {
            LocalBackpressure::Discard => Backpressure::Discard,
            LocalBackpressure::Block => Backpressure::Block,
        }
    }
}

/// Flags of `cellsar-bridge` and `cellsar bridge` (flatten with `#[command(flatten)]`).
#[derive(clap::Args, Debug, Clone)]
pub struct BridgeArgs {
    /// Instance name (liveliness token `cellsar/alive/bridge/<instance>`, stats key).
    #[arg(long, default_value = "bridge")]
    pub instance: String,
    /// A route `NAME[=KEY][@both|out|in]`: iceoryx2 frame service NAME <-> Zenoh key KEY
    /// (default: the same string), both ways unless told otherwise. Repeatable.
    #[arg(long = "service", value_name = "ROUTE", required = true)]
    pub services: Vec<String>,
    /// Largest frame payload in bytes (sizes every service's samples; the echo and the
    /// processor must be given the same value, and have the same default).
    #[arg(long, default_value_t = bridge::frame::SERVICE_MAX_FRAME_BYTES)]
    pub max_frame_bytes: usize,
    /// Subscribers each service admits.
    #[arg(long, default_value_t = 4)]
    pub max_subscribers: usize,
    /// Publishers each service admits.
    #[arg(long, default_value_t = 2)]
    pub max_publishers: usize,
    /// Frames each subscriber can queue.
    #[arg(long, default_value_t = 2)]
    pub subscriber_buffer: usize,
    /// Do not verify the CRC of frames arriving from Zenoh.
    #[arg(long)]
    pub no_verify_checksum: bool,
    /// Congestion control of the Zenoh publishers.
    #[arg(long, value_enum, default_value_t = Congestion::Block)]
    pub congestion: Congestion,
    /// Frames queued between Zenoh and a thread that re-publishes them on iceoryx2; 0
    /// re-publishes in Zenoh's callback without a thread hand-off (no latency gain measured on
    /// a 2-vCPU host: see bridge/BENCHMARKS.md, "Bridge B").
    #[arg(long, default_value_t = 4)]
    pub inbound_queue: usize,
    /// When a local subscriber's buffer is full: discard (skip and count; never stall: a
    /// frozen local consumer never stalls the bridge) or block (lossless; back-pressures Zenoh
    /// and the remote sender).
    #[arg(long, value_enum, default_value_t = LocalBackpressure::Discard)]
    pub inbound_backpressure: LocalBackpressure,
    /// Seconds between counter logs and stats publications (finite, > 0).
    #[arg(long, default_value = "5", value_parser = flags::parse_seconds)]
    pub stats_interval_s: Seconds,
    /// Zenoh flags.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// iceoryx2 flags.
    #[command(flatten)]
    pub iox: IoxArgs,
}

/// Errors of the bridge process: [`BridgeArgs::setup`] fails with bad input, a
/// [`BridgeSetup::run`] at run time. Each names what failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BridgeError {
    /// A route or the forwarder failed (an invalid route, a forwarding thread).
    #[error(transparent)]
    Forward(#[from] ForwardError),
    /// iceoryx2 failed, or its flags are invalid.
    #[error(transparent)]
    Iox(#[from] IoxError),
    /// The Zenoh flags or configuration file are invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A key (from `--instance`) is invalid.
    #[error(transparent)]
    Key(#[from] KeyError),
    /// Zenoh failed.
    #[error(transparent)]
    Net(#[from] NetError),
    /// A forwarding thread ended while the bridge ran.
    #[error("a forwarding thread stopped unexpectedly")]
    ThreadStopped,
}

/// What [`BridgeArgs::setup`] derived from the flags: everything [`BridgeSetup::run`] needs,
/// checked.
#[derive(Debug)]
pub struct BridgeSetup {
    /// The forwarder's routes and settings.
    pub config: ForwarderConfig,
    /// The Zenoh configuration.
    pub zconfig: bridge::zenoh::Config,
    /// The iceoryx2 environment.
    pub env: IoxEnv,
    /// Time between counter logs and stats publications.
    pub stats_interval: Duration,
}

impl BridgeArgs {
    /// Checks every flag before anything starts: the routes and their service sizes, the
    /// instance name, the Zenoh and iceoryx2 configuration (errors here are bad input).
    pub fn setup(&self) -> Result<BridgeSetup, BridgeError> {
        let mut routes = Vec::new();
        for s in &self.services {
            let mut r = Route::parse(s, self.max_frame_bytes)?;
            r.service.max_subscribers = self.max_subscribers;
            r.service.max_publishers = self.max_publishers;
            r.service.subscriber_buffer = self.subscriber_buffer;
            r.service.validate()?;
            routes.push(r);
        }
        let config = ForwarderConfig {
            instance: self.instance.clone(),
            routes,
            verify_checksum: !self.no_verify_checksum,
            congestion_control: self.congestion.into(),
            inbound_queue: self.inbound_queue,
            inbound_backpressure: self.inbound_backpressure.into(),
        };
        config.validate()?;
        keys::alive("bridge", &self.instance)?;
        Ok(BridgeSetup {
            config,
            zconfig: self.zenoh.to_config()?,
            env: self.iox.env()?,
            stats_interval: self.stats_interval_s.duration(),
        })
    }
}

/// Runs the bridge of `args` until `stop` is set: bad flags are bad input (exit code 2, nothing
/// started), a failure while running is a failure at run time (exit code 1).
pub fn run(args: &BridgeArgs, stop: &AtomicBool) -> Result<BridgeStats, Failure> {
    let setup = args.setup().map_err(Failure::bad_input)?;
    setup.run(stop).map_err(Failure::runtime)
}

impl BridgeSetup {
    /// Opens the Zenoh session (liveliness token `cellsar/alive/bridge/<instance>`), starts
    /// the forwarder, publishes its counters as JSON on `cellsar/bridge/<instance>/stats`
    /// (congestion `Drop`: a slow reader never stalls the bridge) every `stats_interval` and
    /// answers queries there, until `stop` is set or a forwarding thread ends. Logs the final
    /// counters (`final_counters=true`) and returns them. A stop while the session is still
    /// opening (a client waiting for its router) ends it at once, with empty counters
    /// ([`ZenohNode::open_until`]).
    pub fn run(self, stop: &AtomicBool) -> Result<BridgeStats, BridgeError> {
        let BridgeSetup {
            config,
            zconfig,
            env,
            stats_interval,
        } = self;
        let Some(node) = ZenohNode::open_until(zconfig, "bridge", &config.instance, stop)? else {
            tracing::info!(final_counters = true, "bridge stopped before it started");
            return Ok(BridgeStats {
                instance: config.instance.clone(),
                uptime_s: 0.0,
                routes: Vec::new(),
            });
        };
        let result = forward(&node, &env, &config, stats_interval, stop);
        match (result, node.close()) {
            (Ok(stats), Ok(())) => Ok(stats),
            (Ok(_), Err(e)) => Err(e.into()),
            (Err(e), close) => {
                if let Err(c) = close {
                    tracing::warn!(error = %c, "closing the Zenoh session");
                }
                Err(e)
            }
        }
    }
}

fn forward(
    node: &ZenohNode,
    env: &IoxEnv,
    config: &ForwarderConfig,
    interval: Duration,
    stop: &AtomicBool,
) -> Result<BridgeStats, BridgeError> {
    let forwarder = Forwarder::start(node, env, config)?;
    let stats_key = keys::bridge_stats(&config.instance)?;
    let stats_pub = node.publisher::<BridgeStats>(
        &stats_key,
        PublishOptions {
            congestion_control: CongestionControl::Drop,
            ..PublishOptions::json()
        },
    )?;
    let source = forwarder.stats_source();
    let seq = Arc::new(AtomicU64::new(0));
    let qkey = stats_key.clone();
    let _queryable = node
        .session()
        .declare_queryable(stats_key.clone())
        .callback(move |query: Query| {
            let meta = Meta {
                seq: seq.fetch_add(1, Ordering::Relaxed),
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
                    let _ = refuse_query(
                        &query,
                        &qkey,
                        WireFormat::Json,
                        &Refusal::new(RefusalKind::Internal, format!("encoding the stats: {e}")),
                    );
                }
            }
        })
        .wait()
        .map_err(|e| NetError::zenoh("declare queryable", &stats_key, e))?;
    tracing::info!(
        instance = %config.instance,
        routes = config.routes.len(),
        stats = %stats_key,
        "bridge running (kind {}); stops on SIGINT/SIGTERM",
        BridgeStats::NAME
    );
    let mut last = Instant::now();
    let mut last_wait_check = Instant::now();
    let mut waits = super::wait::WaitLog::default();
    let routes: Vec<String> = config
        .routes
        .iter()
        .map(|r| format!("iceoryx2 {} <-> Zenoh {}", r.service.name, r.key))
        .collect();
    let waiting = format!("frames on {}", routes.join(", "));
    let mut waiting_done = false;
    let mut failed = false;
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
        if !forwarder.is_running() {
            failed = true;
            break;
        }
        // until the first frame passes, say what the bridge waits for
        if !waiting_done && last_wait_check.elapsed() >= Duration::from_millis(500) {
            last_wait_check = Instant::now();
            waiting_done = forwarder
                .stats()
                .routes
                .iter()
                .any(|r| r.to_zenoh.received + r.from_zenoh.received > 0);
            waits.waiting_for(node, (!waiting_done).then_some(waiting.as_str()));
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
    let stats = forwarder.stop()?;
    log_stats(&stats, true);
    if let Err(e) = stats_pub.put(&stats) {
        tracing::debug!(error = %e, "publishing the final stats failed");
    }
    if failed {
        return Err(BridgeError::ThreadStopped);
    }
    Ok(stats)
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
    use super::*;
    use clap::Parser;

    #[derive(Parser, Debug)]
    struct Cli {
        #[command(flatten)]
        bridge: BridgeArgs,
    }

    fn parse(args: &[&str]) -> Result<BridgeArgs, clap::Error> {
        Cli::try_parse_from(std::iter::once("b").chain(args.iter().copied())).map(|c| c.bridge)
    }

    /// Every flag reaches the forwarder's configuration; the defaults are those of
    /// `cellsar-bridge` (and of the echo's and processor's services).
    #[test]
    fn flags_make_the_forwarder_configuration() {
        let a = parse(&["--service", "cellsar/m/echo@out"]).unwrap();
        let s = a.setup().unwrap();
        assert_eq!(s.config.instance, "bridge");
        assert_eq!(s.stats_interval, Duration::from_secs(5));
        assert!(s.config.verify_checksum);
        assert_eq!(s.config.congestion_control, CongestionControl::Block);
        assert_eq!(s.config.inbound_queue, 4);
        assert_eq!(s.config.inbound_backpressure, Backpressure::Discard);
        let r = &s.config.routes[0];
        assert_eq!(
            r.service,
            bridge::FrameServiceSpec::new("cellsar/m/echo", bridge::frame::SERVICE_MAX_FRAME_BYTES)
        );
        assert_eq!(r.key, "cellsar/m/echo");

        let a = parse(&[
            "--instance",
            "b2",
            "--service",
            "x=cellsar/y",
            "--max-frame-bytes",
            "65536",
            "--max-subscribers",
            "6",
            "--max-publishers",
            "3",
            "--subscriber-buffer",
            "5",
            "--no-verify-checksum",
            "--congestion",
            "drop",
            "--inbound-queue",
            "0",
            "--inbound-backpressure",
            "block",
            "--stats-interval-s",
            "0.25",
        ])
        .unwrap();
        let s = a.setup().unwrap();
        assert_eq!(s.config.instance, "b2");
        assert_eq!(s.stats_interval, Duration::from_millis(250));
        assert!(!s.config.verify_checksum);
        assert_eq!(s.config.congestion_control, CongestionControl::Drop);
        assert_eq!(s.config.inbound_queue, 0);
        assert_eq!(s.config.inbound_backpressure, Backpressure::Block);
        let r = &s.config.routes[0];
        assert_eq!(
            (r.service.name.as_str(), r.key.as_str()),
            ("x", "cellsar/y")
        );
        assert_eq!(r.service.max_payload_bytes, 65536);
        assert_eq!(
            (
                r.service.max_subscribers,
                r.service.max_publishers,
                r.service.subscriber_buffer
            ),
            (6, 3, 5)
        );
    }

    /// Bad flags are refused before anything starts, naming the route, flag or key.
    #[test]
    fn bad_flags_are_named() {
        for (args, needle) in [
            (vec!["--service", "x=a/*"], "a/*"),
            (vec!["--service", "x@sideways"], "sideways"),
            (vec!["--service", "x", "--service", "x"], "configured twice"),
            (vec!["--service", "x", "--instance", "a/b"], "instance"),
            (
                vec!["--service", "x", "--subscriber-buffer", "0"],
                "subscriber_buffer",
            ),
            (vec!["--service", "x", "-e", "garbage"], "--connect garbage"),
        ] {
            let e = parse(&args).unwrap().setup().unwrap_err();
            assert!(e.to_string().contains(needle), "{args:?}: {e}");
            let f = run(&parse(&args).unwrap(), &AtomicBool::new(true)).unwrap_err();
            assert_eq!(f.exit_code(), cellsar_error::exit::BAD_INPUT, "{args:?}");
        }
        let e = parse(&["--service", "x", "--stats-interval-s", "nan"]).unwrap_err();
        assert!(e.to_string().contains("--stats-interval-s"), "{e}");
    }
}
