//! `cellsar-bridge`: forwards iceoryx2 frame services to Zenoh keys and back.
//!
//! ```text
//! cellsar-bridge --instance b1 --service cellsar/0123456789abcdef/echo \
//!     [--service NAME=KEY@out ...] [-m peer|client|router] [-e ENDPOINT] [-l ENDPOINT] \
//!     [-c zenoh.json5] [--multicast-scouting] [--iox-root DIR] [--iox-prefix P]
//! ```
//!
//! Logs its counters every `--stats-interval-s` and on exit, publishes them as JSON on
//! `cellsar/bridge/<instance>/stats` and answers queries there. Stops cleanly on SIGINT or
//! SIGTERM (exit code 0). Exit codes: 2 bad input (a flag, route, Zenoh or iceoryx2
//! configuration; the message names it, on one line), 1 a failure at run time (setting up
//! Zenoh or iceoryx2, a forwarding thread that dies).

use std::process::ExitCode;

use bridge::iox::init_iceoryx_logging;
use cellsar_error::exit::Failure;
use clap::Parser;
use pipeline::services::bridge::{self as service, BridgeArgs};

/// Forwards iceoryx2 frame services to Zenoh keys and back, without loops.
///
/// Exit codes: 0 stopped by SIGINT/SIGTERM; 1 failure at run time; 2 bad input (flag, route,
/// Zenoh or iceoryx2 configuration).
#[derive(Parser, Debug)]
#[command(name = "cellsar-bridge", version)]
struct Cli {
    #[command(flatten)]
    bridge: BridgeArgs,
}

fn main() -> ExitCode {
    init_tracing();
    let cli = Cli::parse();
    // SIGINT and SIGTERM set the flag; the bridge then stops cleanly (exit 0)
    let stop = pipeline::services::os::stop_on_signals().map_err(Failure::runtime);
    // printed once, on stderr (tracing's own output also goes there)
    match stop.and_then(|stop| service::run(&cli.bridge, &stop)) {
        Ok(_) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

fn init_tracing() {
    cellsar_error::init_logging(cellsar_error::SERVICE_LOG_FILTER);
    init_iceoryx_logging();
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn max_frame_bytes_defaults_to_the_services_value() {
        let cli = Cli::try_parse_from(["cellsar-bridge", "--service", "x"]).unwrap();
        assert_eq!(
            cli.bridge.max_frame_bytes,
            bridge::frame::SERVICE_MAX_FRAME_BYTES
        );
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
