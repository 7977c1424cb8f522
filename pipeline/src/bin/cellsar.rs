//! `cellsar`: the pipeline launcher (`cellsar run`) and, as subcommands, every process it
//! starts (planner, echo, process, bridge, router).
//!
//! Exit codes: 0 done (and, for `run`, every landmark in view detected); 1 failure; 2 bad
//! input; 4 `run` completed but a landmark in view was missed; 130 interrupted.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use pipeline::launch::{self, Outcome, RunArgs};
use pipeline::roles::{self, BridgeArgs, RouterArgs};

#[derive(Parser, Debug)]
#[command(
    name = "cellsar",
    version,
    about = "cellsar pipeline: planner, echo simulator and processor as supervised processes over Zenoh and iceoryx2"
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
    Run(Box<RunArgs>),
    /// The plan service (as `cellsar-planner serve`).
    Planner(planner::service::ServeArgs),
    /// The echo simulator service (as `cellsar-radar-sim echo`).
    Echo(radar_sim::service::EchoArgs),
    /// The processor service (as `cellsar-radar-sim process-service`).
    Process(radar_sim::service::ProcessArgs),
    /// The iceoryx2 <-> Zenoh bridge (as `cellsar-bridge`).
    Bridge(BridgeArgs),
    /// A plain Zenoh router (what `zenohd` does without plugins).
    Router(RouterArgs),
}

fn init_tracing(default: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    bridge::iox::init_iceoryx_logging();
}

fn fail(e: anyhow::Error) -> ExitCode {
    eprintln!("error: {}", planner::error_chain(e.as_ref()));
    ExitCode::from(1)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_tracing(match cli.command {
        Command::Run(_) => "warn",
        _ => "info",
    });
    let stop = match planner::service::stop_on_signals() {
        Ok(s) => s,
        Err(e) => return fail(e.into()),
    };
    if !matches!(cli.command, Command::Run(_)) {
        pipeline::supervise::exit_with_launcher(&stop);
    }
    let r: anyhow::Result<()> = match cli.command {
        Command::Run(args) => {
            return match launch::run(&args, stop) {
                Ok(Outcome::Complete) => ExitCode::SUCCESS,
                Ok(Outcome::MissedLandmark) => {
                    eprintln!("a landmark in view was not detected (see report.json)");
                    ExitCode::from(4)
                }
                Ok(Outcome::Interrupted) => {
                    eprintln!("interrupted; children stopped");
                    ExitCode::from(130)
                }
                Err(e) => fail(e),
            }
        }
        Command::Planner(a) => planner::service::serve(&a, &stop)
            .map(|r| tracing::info!(?r, "plan service stopped"))
            .map_err(Into::into),
        Command::Echo(a) => radar_sim::service::run_echo(&a, &stop)
            .map(|r| tracing::info!(?r, "echo stopped"))
            .map_err(Into::into),
        Command::Process(a) => radar_sim::service::run_processor(&a, &stop)
            .map(|r| tracing::info!(?r, "processor stopped"))
            .map_err(Into::into),
        Command::Bridge(a) => roles::run_bridge(&a, &stop),
        Command::Router(a) => roles::run_router(&a, &stop),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}
