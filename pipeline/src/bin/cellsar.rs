//! `cellsar`: the pipeline launcher (`cellsar run`) and, as subcommands, every process it
//! starts (planner, echo, process, bridge, router).
//!
//! Exit codes ([`pipeline::exit`]): 0 done; 1 failure at run time; 2 bad input (an option,
//! the mission or the scene file; the message names it; nothing started); 3 the mission
//! cannot be flown; 4 `run --strict` completed but a landmark in view was missed; 130
//! interrupted.

use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use pipeline::exit::{self, Failure};
use pipeline::launch::{self, Outcome, RunArgs};
use pipeline::roles::{self, RouterArgs};
use pipeline::services::bridge::BridgeArgs;

const EXIT_CODES: &str = "Exit codes: 0 done; 1 failure at run time; 2 bad input (an option, the \
mission or the scene file; nothing started); 3 the mission cannot be flown; 4 `run --strict`: a \
landmark in view was not detected; 130 interrupted (SIGINT/SIGTERM, every child stopped).";

#[derive(Parser, Debug)]
#[command(
    name = "cellsar",
    version,
    about = "cellsar pipeline: planner, echo simulator and processor as supervised processes over Zenoh and iceoryx2",
    after_help = EXIT_CODES
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a mission through the whole pipeline (children: planner, echo, processor, and the
    /// bridge / a router when asked) and write plan/, images/, detections.csv, metrics.json,
    /// report.json, report.md, pipeline.json.
    #[command(after_help = EXIT_CODES)]
    Run(Box<RunArgs>),
    /// The plan service (as `cellsar-planner serve`).
    Planner(pipeline::services::plan::ServeArgs),
    /// The echo simulator service (as `cellsar-radar-sim echo`).
    Echo(pipeline::services::echo::EchoArgs),
    /// The processor service (as `cellsar-radar-sim process-service`).
    Process(pipeline::services::process::ProcessArgs),
    /// The iceoryx2 <-> Zenoh bridge (as `cellsar-bridge`: the same code and flags).
    Bridge(BridgeArgs),
    /// A plain Zenoh router (what `zenohd` does without plugins).
    Router(RouterArgs),
    /// Make a test CA, the router's server certificate and a client certificate per role, with
    /// their keys, for a deployment with mutual TLS (pipeline/deploy/tls/): DIR/ca.pem, ca.key,
    /// and ROLE.pem, ROLE.key for each role.
    Certs(pipeline::certs::CertsArgs),
    /// Plans one request for the plan service (its worker process; not for use by hand).
    #[command(name = "plan-worker", hide = true)]
    PlanWorker(pipeline::services::plan::worker::WorkerArgs),
}

fn init_tracing(default: &str) {
    cellsar_error::init_logging(default);
    bridge::iox::init_iceoryx_logging();
}

/// What the radar services would refuse, checked before they start: the scene, the Zenoh and
/// iceoryx2 flags. (Their seconds flags the services check themselves, first thing, as bad
/// input.)
fn check_radar_service(
    scene: &std::path::Path,
    zenoh: &bridge::ZenohArgs,
    iox: &bridge::IoxArgs,
) -> Result<(), Failure> {
    radar_sim::config::SceneFile::from_path(scene)
        .context("--scene")
        .map_err(Failure::bad_input)?;
    zenoh.to_config().map_err(Failure::bad_input)?;
    iox.env().map_err(Failure::bad_input)?;
    Ok(())
}

/// `cellsar certs`: bad flags and a set that exists already are bad input (exit 2).
fn make_certs(a: &pipeline::certs::CertsArgs) -> Result<(), Failure> {
    use pipeline::certs::CertsError;
    match pipeline::certs::make_certs(a) {
        Ok(files) => {
            for f in files {
                println!("{}", f.display());
            }
            Ok(())
        }
        Err(e @ (CertsError::Flag { .. } | CertsError::Exists(_))) => Err(Failure::bad_input(e)),
        Err(e) => Err(Failure::runtime(e)),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_tracing(match cli.command {
        Command::Run(_) => cellsar_error::COMMAND_LOG_FILTER,
        _ => cellsar_error::SERVICE_LOG_FILTER,
    });
    if let Command::PlanWorker(a) = &cli.command {
        return match pipeline::services::plan::worker::run_worker(a) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => Failure::from(e).report(),
        };
    }
    if let Err(e) = radar_sim::kernels::KernelSet::from_env() {
        return Failure::bad_input(anyhow::anyhow!(e)).report();
    }
    let stop = match pipeline::services::plan::stop_on_signals() {
        Ok(s) => s,
        Err(e) => return Failure::runtime(e).report(),
    };
    if !matches!(cli.command, Command::Run(_)) {
        pipeline::supervise::exit_with_launcher(&stop);
    }
    let r: Result<(), Failure> = match cli.command {
        Command::Run(args) => {
            return match launch::run(&args, stop) {
                Ok(Outcome::Complete) => ExitCode::SUCCESS,
                Ok(Outcome::MissedLandmark) => {
                    eprintln!("a landmark in view was not detected (see report.json)");
                    ExitCode::from(exit::MISSED_LANDMARK)
                }
                Ok(Outcome::Interrupted) => {
                    eprintln!("interrupted; children stopped");
                    ExitCode::from(exit::INTERRUPTED)
                }
                Err(e) => e.report(),
            }
        }
        Command::Planner(mut a) => {
            a.worker_exe = pipeline::services::plan::worker::own_executable();
            a.zenoh
                .to_config()
                .map_err(Failure::bad_input)
                .and_then(|_| pipeline::services::plan::serve(&a, &stop).map_err(Failure::from))
                .map(|r| tracing::info!(?r, "plan service stopped"))
        }
        // answered above
        Command::PlanWorker(_) => Ok(()),
        Command::Echo(a) => check_radar_service(&a.scene, &a.zenoh, &a.iox)
            .and_then(|()| pipeline::services::echo::run_echo(&a, &stop).map_err(Failure::from))
            .map(|r| tracing::info!(?r, "echo stopped")),
        Command::Process(a) => if a.window == 0 {
            Err(Failure::bad_input(anyhow::anyhow!(
                "--window 0: must be at least 1"
            )))
        } else {
            check_radar_service(&a.scene, &a.zenoh, &a.iox)
        }
        .and_then(|()| pipeline::services::process::run_processor(&a, &stop).map_err(Failure::from))
        .map(|r| tracing::info!(?r, "processor stopped")),
        Command::Bridge(a) => pipeline::services::bridge::run(&a, &stop).map(|_| ()),
        Command::Router(a) => roles::run_router(&a, &stop),
        Command::Certs(a) => make_certs(&a),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => e.report(),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    fn parse(args: &[&str]) -> Command {
        Cli::try_parse_from(std::iter::once("cellsar").chain(args.iter().copied()))
            .unwrap()
            .command
    }

    /// Every process of a mission must use the same --max-frame-bytes: the defaults agree
    /// (with `cellsar-bridge`'s, tested in the bridge crate against the same constant).
    #[test]
    fn max_frame_bytes_defaults_agree() {
        let want = bridge::frame::SERVICE_MAX_FRAME_BYTES;
        assert_eq!(pipeline::services::radar::DEFAULT_MAX_FRAME_BYTES, want);
        let got = [
            match parse(&["run", "m.toml", "--scene", "s.toml", "--out", "o"]) {
                Command::Run(a) => a.max_frame_bytes,
                c => panic!("{c:?}"),
            },
            match parse(&["echo", "--scene", "s.toml"]) {
                Command::Echo(a) => a.max_frame_bytes,
                c => panic!("{c:?}"),
            },
            match parse(&["process", "--scene", "s.toml"]) {
                Command::Process(a) => a.max_frame_bytes,
                c => panic!("{c:?}"),
            },
            match parse(&["bridge", "--service", "x"]) {
                Command::Bridge(a) => a.max_frame_bytes,
                c => panic!("{c:?}"),
            },
        ];
        assert_eq!(got, [want; 4]);
    }

    /// The seconds options are parsed once, by clap, into checked `Seconds` (the Duration the
    /// launcher uses and the number it passes on to a child), defaults included.
    #[test]
    fn float_seconds_options_are_durations_once_parsed() {
        let Command::Run(a) = parse(&[
            "run",
            "m.toml",
            "--scene",
            "s.toml",
            "--out",
            "o",
            "--timeout-s",
            "2.5",
            "--horizon-s",
            "30",
        ]) else {
            panic!("not run")
        };
        assert_eq!(
            a.timeout_s.map(|t| t.duration()),
            Some(std::time::Duration::from_millis(2500))
        );
        assert_eq!(a.horizon_s.map(|h| h.as_secs_f64()), Some(30.0));
        assert_eq!(
            a.plan_timeout_s.duration(),
            std::time::Duration::from_secs(900)
        );
        assert_eq!(a.resend_after_s.to_string(), "10");
        let Command::Bridge(b) = parse(&["bridge", "--service", "x"]) else {
            panic!("not bridge")
        };
        assert_eq!(
            b.stats_interval_s.duration(),
            std::time::Duration::from_secs(5)
        );
    }

    /// `cellsar bridge` is `cellsar-bridge`: the same flags and set-up
    /// (`pipeline::services::bridge::BridgeArgs`), not a subset of its own.
    #[test]
    fn bridge_role_takes_every_cellsar_bridge_flag() {
        let Command::Bridge(a) = parse(&[
            "bridge",
            "--service",
            "cellsar/m/echo@out",
            "--max-subscribers",
            "6",
            "--max-publishers",
            "3",
            "--subscriber-buffer",
            "4",
            "--no-verify-checksum",
            "--congestion",
            "drop",
            "--inbound-queue",
            "0",
            "--inbound-backpressure",
            "block",
        ]) else {
            panic!("not bridge")
        };
        let s = a.setup().unwrap();
        assert!(!s.config.verify_checksum);
        assert_eq!(s.config.inbound_queue, 0);
        assert_eq!(
            s.config.inbound_backpressure,
            bridge::iox::Backpressure::Block
        );
        let spec = &s.config.routes[0].service;
        assert_eq!(
            (
                spec.max_subscribers,
                spec.max_publishers,
                spec.subscriber_buffer
            ),
            (6, 3, 4)
        );
    }

    /// Seconds that are not a finite positive number are refused by clap, naming the option
    /// (exit code 2).
    #[test]
    fn float_seconds_options_are_checked_when_parsed() {
        let base = ["run", "m.toml", "--scene", "s.toml", "--out", "o"];
        for opt in [
            "--timeout-s",
            "--plan-timeout-s",
            "--resend-after-s",
            "--horizon-s",
        ] {
            for bad in ["nan", "-1", "0", "inf", "1e300"] {
                let arg = format!("{opt}={bad}");
                let e = Cli::try_parse_from(
                    std::iter::once("cellsar")
                        .chain(base.iter().copied())
                        .chain([arg.as_str()]),
                )
                .unwrap_err();
                assert_eq!(e.exit_code(), 2, "{arg}");
                assert!(e.to_string().contains(opt), "{arg}: {e}");
            }
        }
        let e = Cli::try_parse_from([
            "cellsar",
            "bridge",
            "--service",
            "x",
            "--stats-interval-s",
            "nan",
        ])
        .unwrap_err();
        assert!(e.to_string().contains("--stats-interval-s"), "{e}");
    }
}
