//! `cellsar-radar-sim`: simulate what the UAV records along a planned track, process it into
//! SAR images and detections, or run the whole loop from a mission file.
//!
//! Exit codes (as `cellsar-planner`): 0 success; 2 bad input (a missing or malformed file, an
//! invalid scene, a bad option, a run above the IQ limits); 3 the mission cannot be flown (the
//! planner proves it infeasible, `closed-loop`); 4 `closed-loop` missed a landmark in view;
//! 1 a runtime failure (a write, a numerical or service failure).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use pipeline::exit::{plan_failure, radar_failure, Failure};
use std::time::Instant;

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use pipeline::args::IqLimitArgs;
use radar_sim::config::SceneFile;
use radar_sim::limits::{IqLimits, DEFAULT_MAX_APERTURE_GIB};
use radar_sim::pipeline::RadarSetup;
use radar_sim::run;

const EXIT_CODES: &str = "Exit codes: 0 success; 2 bad input (missing or malformed file, \
invalid scene, bad option, a run above --max-iq-gib / --max-aperture-gib); 3 the mission cannot \
be flown (closed-loop: the planner proves it infeasible); 4 closed-loop: a landmark in view was \
not detected; 1 runtime failure (writing the output, a numerical or service failure).";

#[derive(Parser)]
#[command(
    name = "cellsar-radar-sim",
    version,
    about = "Bistatic OFDM SAR simulator and processor for cellsar",
    after_help = EXIT_CODES
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Plan directory (mission.toml + trajectory.csv) + scene → raw IQ (NPY), truth, pulses.
    Simulate {
        /// The planner's output directory.
        #[arg(long)]
        plan: PathBuf,
        /// Scene file (TOML), required (e.g. radar-sim/scenes/default.toml).
        #[arg(long)]
        scene: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Limits on the run's IQ, checked before anything is simulated.
        #[command(flatten)]
        limits: IqLimitArgs,
    },
    /// Recording → cancellation, images (PNG, NPY), detections.csv/.json, metrics.json.
    Process {
        /// A directory written by `simulate`.
        #[arg(long = "in")]
        input: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Refuse a recording in which one aperture (its IQ, plus its look images with
        /// `processing.save_complex`) would take more than this many GiB of memory.
        #[arg(long, value_name = "GIB", default_value_t = DEFAULT_MAX_APERTURE_GIB)]
        max_aperture_gib: f64,
    },
    /// Mission → plan → echoes → processing → scoring, with a short report.
    ClosedLoop {
        /// Mission file (TOML or JSON).
        mission: PathBuf,
        /// Scene file (TOML), required (e.g. radar-sim/scenes/default.toml).
        #[arg(long)]
        scene: PathBuf,
        /// Output directory (plan/, recording/, processed/, report.json).
        #[arg(long)]
        out: PathBuf,
        /// Keep only the landmark windows that end within this horizon, s (default: the whole
        /// mission).
        #[arg(long, value_name = "S")]
        horizon_s: Option<f64>,
        /// Limits on the run's IQ, checked before planning.
        #[command(flatten)]
        limits: IqLimitArgs,
        /// The resolution requirement of the plan: `general` (the default: the worst width of
        /// the true bistatic cell ≤ d_min in every landmark slot, or the best effort where the
        /// geometry does not allow it) or `paper` (the paper's δ_r, δ_a ≤ d_min, the
        /// least-energy plan); see the top-level docs/user-guide.md, "Resolution".
        #[arg(long, default_value_t = planner::DEFAULT_RESOLUTION, value_parser = pipeline::args::enum_parser::<planner::evaluate::ResolutionMode>())]
        resolution: planner::evaluate::ResolutionMode,
        /// Under `general`: refuse a mission whose cell cannot be held within d_min in every
        /// landmark slot (exit 3) instead of planning the best effort.
        #[arg(long)]
        strict_resolution: bool,
        /// The plan's vehicle model: `vehicle` (the default: the acceleration limit of the
        /// mission's `max_accel_mps2` between slots) or `paper` (the velocity may jump); as
        /// `cellsar run --dynamics`.
        #[arg(long, default_value_t = planner::Scheme::Exact.default_dynamics(), value_parser = pipeline::args::enum_parser::<planner::Dynamics>())]
        dynamics: planner::Dynamics,
    },
    /// Resolution report: measured −3 dB region of a point response vs the predicted cell at
    /// several bistatic angles (one near blind) and bandwidths → RESOLUTION.md, JSON, SVGs.
    Resolution {
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Bandwidths, MHz (comma-separated). At 30 MHz the range and along-track widths are
        /// comparable: there the cell's longest chord is furthest from its parallelogram's sides.
        #[arg(long, value_delimiter = ',', default_values_t = [30.0, 50.0, 100.0, 150.0])]
        bandwidths_mhz: Vec<f64>,
    },
    /// Service: synthesise the apertures processors ask for along each plan heard on Zenoh and
    /// publish them as IQ frames on iceoryx2 (`cellsar/<mission>/echo`); stops on SIGINT/SIGTERM.
    Echo {
        #[command(flatten)]
        args: pipeline::services::echo::EchoArgs,
    },
    /// Service: pull each planned mission's apertures from the echo (iceoryx2, or Zenoh via
    /// cellsar-bridge), process them and publish detections, images and metrics on Zenoh.
    ProcessService {
        #[command(flatten)]
        args: pipeline::services::process::ProcessArgs,
    },
}

fn bar(len: u64, what: &str) -> ProgressBar {
    let b = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} ({eta})") {
        b.set_style(style.progress_chars("=> "));
    }
    b.set_message(what.to_string());
    b
}

fn bad(e: impl Into<anyhow::Error>) -> Failure {
    Failure::bad_input(e)
}

type Result<T, E = Failure> = std::result::Result<T, E>;

/// A plan directory's mission and trajectory, with the altitude per slot (the `z_m` column)
/// when the mission has `altitude = "free"`.
type Flight = (planner::Mission, planner::Trajectory, Option<Vec<f64>>);

fn read_flight(plan: &Path) -> anyhow::Result<Flight> {
    let mission = planner::Mission::from_path(&plan.join("mission.toml"))?;
    if mission.params().altitude != planner::AltitudeMode::Free {
        let (mission, traj) = pipeline::report::read_plan_dir(plan)?;
        return Ok((mission, traj, None));
    }
    let p = mission.params();
    let (traj, altitudes_m) = planner::Trajectory::from_csv_path_with_altitudes(
        &plan.join("trajectory.csv"),
        p.slot_s,
        mission.slots(),
        p.start_m,
        p.altitude_m,
    )?;
    Ok((mission, traj, Some(altitudes_m)))
}

fn simulate(plan: &Path, scene: &Path, out: &Path, limits: &IqLimits) -> Result<()> {
    let (mission, traj, altitudes_m) = read_flight(plan)
        .with_context(|| format!("reading plan directory {}", plan.display()))
        .map_err(bad)?;
    let scene = SceneFile::from_path(scene).map_err(radar_failure)?;
    let b = bar(1, "simulate");
    let t = Instant::now();
    let meta = run::simulate_profile_limited(
        &mission,
        &traj,
        altitudes_m.as_deref(),
        &scene,
        out,
        limits,
        &mut |d, n| {
            b.set_length(n);
            b.set_position(d);
        },
    );
    b.finish();
    let meta = meta.map_err(radar_failure)?;
    for w in &meta.warnings {
        tracing::warn!("{w}");
    }
    println!(
        "simulated {} apertures ({} pulses × {} samples) in {:.1} s into {}",
        meta.apertures.len(),
        meta.apertures
            .iter()
            .map(|a| a.aperture.pulses())
            .sum::<usize>(),
        meta.samples_per_pulse,
        t.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}

fn process(input: &Path, out: &Path, limits: &IqLimits) -> Result<run::Metrics> {
    let b = bar(1, "process");
    let t = Instant::now();
    let m = run::process_limited(
        input,
        out,
        limits,
        &mut |d, n| {
            b.set_length(n);
            b.set_position(d);
        },
        &mut pipeline::report::image_svg::write_aperture_view,
    );
    b.finish();
    let m = m.map_err(radar_failure)?;
    println!(
        "processed in {:.1} s: {}",
        t.elapsed().as_secs_f64(),
        m.detection_summary()
    );
    println!("canceller: {}", m.canceller_summary());
    if let Some(line) = m.resolution_summary() {
        println!("{line}");
    }
    Ok(m)
}

fn closed_loop(
    mission: &Path,
    scene: &Path,
    out: &Path,
    horizon: Option<f64>,
    limits: &IqLimits,
    plan_options: &planner::PlanOptions,
) -> Result<bool> {
    let mut m = planner::Mission::from_path(mission).map_err(bad)?;
    if let Some(h) = horizon {
        m = run::shorten(&m, h)
            .with_context(|| format!("--horizon-s {h}"))
            .map_err(bad)?;
    }
    let scene_file = SceneFile::from_path(scene).map_err(radar_failure)?;
    // everything the run will make is known from the windows and the scene: refuse before
    // planning
    let setup = RadarSetup::new(m.params(), &scene_file).map_err(radar_failure)?;
    radar_sim::limits::check_mission(&setup, &m, limits).map_err(radar_failure)?;
    // a free mission is planned with its altitude profile and flown at it
    let plan_options = planner::PlanOptions {
        altitude_profile: m.params().altitude == planner::AltitudeMode::Free,
        ..plan_options.clone()
    };
    let t = Instant::now();
    let result = planner::plan(&m, &plan_options)
        .map_err(|e| plan_failure(e).context(format!("planning {}", mission.display())))?;

    println!(
        "planned {} slots in {:.1} s: energy {:.0} J, feasible {}",
        m.slots(),
        t.elapsed().as_secs_f64(),
        result.evaluation.energy_j,
        result.is_feasible()
    );
    let plan_dir = out.join("plan");
    pipeline::report::write_plan_dir(&plan_dir, &m, &result)
        .with_context(|| format!("writing {}", plan_dir.display()))?;
    let rec = out.join("recording");
    // the plan just written: a failure to read it back is a runtime failure
    let (m2, traj, altitudes_m) =
        read_flight(&plan_dir).with_context(|| format!("reading back {}", plan_dir.display()))?;
    let b = bar(1, "simulate");
    let sim = run::simulate_profile_limited(
        &m2,
        &traj,
        altitudes_m.as_deref(),
        &scene_file,
        &rec,
        limits,
        &mut |d, n| {
            b.set_length(n);
            b.set_position(d);
        },
    );
    b.finish();
    sim.map_err(radar_failure)?;
    let metrics = process(&rec, &out.join("processed"), limits)?;
    let report = run::loop_report(&m2, &result.evaluation, metrics);
    radar_sim::io::write_json(&out.join("report.json"), &report).map_err(anyhow::Error::new)?;
    println!("aperture landmark  in-view  detected  SNR/dB");
    for r in &report.rows {
        println!(
            "{:>8} {:>8} {:>8.2} {:>9} {:>7.1}",
            r.aperture,
            r.landmark.map(|l| l.to_string()).unwrap_or_default(),
            r.in_view_fraction,
            r.detected_label(),
            r.snr_db.unwrap_or(f64::NAN)
        );
    }
    println!(
        "every landmark in view detected: {}",
        if report.landmarks_scored == 0 {
            "not scored (no landmark is a truth object of the scene)"
        } else if report.all_in_view_detected {
            "yes"
        } else {
            "NO"
        }
    );
    Ok(report.all_in_view_detected)
}

fn resolution(out: &Path, bandwidths_mhz: &[f64]) -> Result<()> {
    if let Some(b) = bandwidths_mhz
        .iter()
        .find(|b| !(b.is_finite() && **b > 0.0))
    {
        return Err(bad(anyhow::anyhow!(
            "--bandwidths-mhz: {b} is not a positive bandwidth"
        )));
    }
    let cases = radar_sim::psf::default_cases();
    let b = bar((bandwidths_mhz.len() * cases.len()) as u64, "resolution");
    let hz: Vec<f64> = bandwidths_mhz.iter().map(|m| m * 1e6).collect();
    let rows =
        pipeline::report::resolution::write_resolution_report(out, &hz, &cases, &mut |d, _| {
            b.set_position(d)
        })
        .map_err(radar_failure)?;
    b.finish();
    for r in &rows {
        let c = &r.cell;
        println!(
            "B {:>3.0} MHz  β {:5.1}°  ψ {:5.1}°  range {:.3} ({:.3})  along {:.3} ({:.3})  cross {:.2} ({:.2})  iso-range {:.2} ({:.2}) m   {}",
            c.bandwidth_hz / 1e6, c.bistatic_angle_deg, c.psi_deg, c.range_width_m,
            c.range_width_pred_m, c.along_track_width_m, c.along_track_width_pred_m,
            c.cross_track_width_m, c.cross_track_width_pred_m, c.iso_range_width_m,
            c.iso_range_width_pred_m, r.case.label
        );
    }
    println!("wrote {}", out.join("RESOLUTION.md").display());
    Ok(())
}

fn main() -> ExitCode {
    match run_cli() {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

/// The log level when `RUST_LOG` is not set: `info` for the long-running services (they say
/// that they are ready, wait for their router, stop, with their counters, as
/// `cellsar-planner serve`, `cellsar process` and `cellsar-bridge` do), `warn` for the
/// one-shot commands.
fn default_log_filter(cmd: &Cmd) -> &'static str {
    match cmd {
        Cmd::Echo { .. } | Cmd::ProcessService { .. } => cellsar_error::SERVICE_LOG_FILTER,
        _ => cellsar_error::COMMAND_LOG_FILTER,
    }
}

fn run_cli() -> Result<()> {
    let cli = Cli::parse();
    cellsar_error::init_logging(default_log_filter(&cli.cmd));
    bridge::iox::init_iceoryx_logging();
    radar_sim::kernels::KernelSet::from_env()
        .map_err(|e| Failure::bad_input(anyhow::anyhow!(e)))?;
    match cli.cmd {
        Cmd::Simulate {
            plan,
            scene,
            out,
            limits,
        } => simulate(
            &plan,
            &scene,
            &out,
            &limits.limits().map_err(radar_failure)?,
        ),
        Cmd::Process {
            input,
            out,
            max_aperture_gib,
        } => {
            let limits =
                IqLimits::from_gib(radar_sim::limits::DEFAULT_MAX_IQ_GIB, max_aperture_gib)
                    .map_err(radar_failure)?;
            process(&input, &out, &limits).map(|_| ())
        }
        Cmd::ClosedLoop {
            mission,
            scene,
            out,
            horizon_s,
            limits,
            resolution,
            strict_resolution,
            dynamics,
        } => {
            let plan_options = planner::PlanOptions {
                resolution,
                strict_resolution,
                dynamics,
                ..Default::default()
            };
            pipeline::args::check_best_effort_flags(&plan_options).map_err(bad)?;
            if !closed_loop(
                &mission,
                &scene,
                &out,
                horizon_s,
                &limits.limits().map_err(radar_failure)?,
                &plan_options,
            )? {
                return Err(Failure::missed_landmark(anyhow::anyhow!(
                    "a landmark in view was not detected (see report.json)"
                )));
            }
            Ok(())
        }
        Cmd::Resolution {
            out,
            bandwidths_mhz,
        } => resolution(&out, &bandwidths_mhz),
        Cmd::Echo { args } => {
            let stop = pipeline::services::plan::stop_on_signals().map_err(anyhow::Error::new)?;
            let report = pipeline::services::echo::run_echo(&args, &stop)?;
            tracing::info!(?report, "echo stopped");
            Ok(())
        }
        Cmd::ProcessService { args } => {
            let stop = pipeline::services::plan::stop_on_signals().map_err(anyhow::Error::new)?;
            let report = pipeline::services::process::run_processor(&args, &stop)?;
            tracing::info!(?report, "processor stopped");
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The services log at info by default (so that they show that they run, like
    /// `cellsar process` and `cellsar-bridge`); the one-shot commands stay at warn.
    #[test]
    fn services_log_at_info_and_commands_at_warn() {
        let level = |args: &[&str]| {
            default_log_filter(
                &Cli::try_parse_from(
                    std::iter::once("cellsar-radar-sim").chain(args.iter().copied()),
                )
                .unwrap()
                .cmd,
            )
        };
        {
            assert_eq!(
                level(&["echo", "--scene", "s.toml"]),
                cellsar_error::SERVICE_LOG_FILTER
            );
            assert_eq!(
                level(&["process-service", "--scene", "s.toml"]),
                cellsar_error::SERVICE_LOG_FILTER
            );
        }
        assert_eq!(
            level(&["simulate", "--plan", "p", "--scene", "s", "--out", "o"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
        assert_eq!(
            level(&["process", "--in", "i", "--out", "o"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
        assert_eq!(
            level(&["closed-loop", "m.toml", "--scene", "s", "--out", "o"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
        assert_eq!(
            level(&["resolution", "--out", "o"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
    }
}
