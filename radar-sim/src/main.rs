//! `cellsar-radar-sim`: simulate what the UAV records along a planned track, process it into
//! SAR images and detections, or run the whole loop from a mission file.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use radar_sim::config::SceneFile;
use radar_sim::run;

#[derive(Parser)]
#[command(
    name = "cellsar-radar-sim",
    version,
    about = "Bistatic OFDM SAR simulator and processor for cellsar"
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
        /// Scene file (TOML).
        #[arg(long)]
        scene: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Recording → cancellation, images (PNG, NPY), detections.csv/.json, metrics.json.
    Process {
        /// A directory written by `simulate`.
        #[arg(long = "in")]
        input: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Mission → plan → echoes → processing → scoring, with a short report.
    ClosedLoop {
        /// Mission file (TOML or JSON).
        mission: PathBuf,
        /// Scene file (TOML).
        #[arg(long)]
        scene: PathBuf,
        /// Output directory (plan/, recording/, processed/, report.json).
        #[arg(long)]
        out: PathBuf,
        /// Keep only the landmark windows that end within this horizon, s.
        #[arg(long)]
        horizon_s: Option<f64>,
    },
    /// Resolution report: measured −3 dB region of a point response vs the predicted cell at
    /// several bistatic angles (one near blind) and bandwidths → RESOLUTION.md, JSON, SVGs.
    Resolution {
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Bandwidths, MHz (comma-separated).
        #[arg(long, value_delimiter = ',', default_values_t = [50.0, 100.0, 150.0])]
        bandwidths_mhz: Vec<f64>,
    },
    /// Service: synthesise the apertures processors ask for along each plan heard on Zenoh and
    /// publish them as IQ frames on iceoryx2 (`cellsar/<mission>/echo`); stops on SIGINT/SIGTERM.
    #[cfg(feature = "service")]
    Echo {
        #[command(flatten)]
        args: radar_sim::service::EchoArgs,
    },
    /// Service: pull each planned mission's apertures from the echo (iceoryx2, or Zenoh via
    /// cellsar-bridge), process them and publish detections, images and metrics on Zenoh.
    #[cfg(feature = "service")]
    ProcessService {
        #[command(flatten)]
        args: radar_sim::service::ProcessArgs,
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

fn simulate(plan: &Path, scene: &Path, out: &Path) -> Result<()> {
    let (mission, traj) = planner::report::read_plan_dir(plan)
        .with_context(|| format!("reading plan directory {}", plan.display()))?;
    let scene = SceneFile::from_path(scene)?;
    let b = bar(1, "simulate");
    let t = Instant::now();
    let meta = run::simulate(&mission, &traj, &scene, out, &mut |d, n| {
        b.set_length(n);
        b.set_position(d);
    })?;
    b.finish();
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

fn process(input: &Path, out: &Path) -> Result<run::Metrics> {
    let b = bar(1, "process");
    let t = Instant::now();
    let m = run::process(input, out, &mut |d, n| {
        b.set_length(n);
        b.set_position(d);
    })?;
    b.finish();
    println!(
        "processed in {:.1} s: Pd {:.3} ({} objects ≥ 13 dB), {} false alarms (design {:.2}), mean error {:.2} m, DP reduction {:.1} dB, residual {:.2} dB over noise",
        t.elapsed().as_secs_f64(),
        m.pd,
        m.strong_objects,
        m.false_alarms,
        m.design_false_alarms,
        m.mean_position_error_m,
        m.dpi_reduction_db,
        m.residual_to_noise_db
    );
    if let (Some(r), Some(a)) = (&m.range_resolution_m, &m.azimuth_resolution_m) {
        println!(
            "resolution: range {:.3} m (general {:.3}, paper {:.3}), azimuth {:.3} m (general {:.3}, paper {:.3})",
            r.measured_m, r.predicted_general_m, r.paper_m, a.measured_m, a.predicted_general_m, a.paper_m
        );
    }
    Ok(m)
}

fn closed_loop(mission: &Path, scene: &Path, out: &Path, horizon: Option<f64>) -> Result<bool> {
    let mut m = planner::Mission::from_path(mission)?;
    if let Some(h) = horizon {
        m = run::shorten(&m, h)?;
    }
    let scene_file = SceneFile::from_path(scene)?;
    let t = Instant::now();
    let result = planner::plan(&m, &planner::PlanOptions::default())
        .map_err(|e| anyhow::anyhow!("planning {}: {e}", mission.display()))?;
    println!(
        "planned {} slots in {:.1} s: energy {:.0} J, feasible {}",
        m.slots(),
        t.elapsed().as_secs_f64(),
        result.evaluation.energy_j,
        result.evaluation.is_feasible()
    );
    let plan_dir = out.join("plan");
    planner::report::write_plan_dir(&plan_dir, &m, &result)?;
    let rec = out.join("recording");
    let (m2, traj) = planner::report::read_plan_dir(&plan_dir)?;
    let b = bar(1, "simulate");
    run::simulate(&m2, &traj, &scene_file, &rec, &mut |d, n| {
        b.set_length(n);
        b.set_position(d);
    })?;
    b.finish();
    let metrics = process(&rec, &out.join("processed"))?;
    let report = run::loop_report(&m2, &result.evaluation, metrics);
    radar_sim::io::write_json(&out.join("report.json"), &report)?;
    println!("aperture landmark  in-view  detected  SNR/dB");
    for r in &report.rows {
        println!(
            "{:>8} {:>8} {:>8.2} {:>9} {:>7.1}",
            r.aperture,
            r.landmark.map(|l| l.to_string()).unwrap_or_default(),
            r.in_view_fraction,
            r.detected,
            r.snr_db.unwrap_or(f64::NAN)
        );
    }
    println!(
        "every landmark in view detected: {}",
        if report.all_in_view_detected {
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
        bail!("--bandwidths-mhz: {b} is not a positive bandwidth");
    }
    let cases = radar_sim::psf::default_cases();
    let b = bar((bandwidths_mhz.len() * cases.len()) as u64, "resolution");
    let hz: Vec<f64> = bandwidths_mhz.iter().map(|m| m * 1e6).collect();
    let rows = radar_sim::psf::write_report(out, &hz, &cases, &mut |d, _| b.set_position(d))?;
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

fn main() -> std::process::ExitCode {
    match run_cli() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", planner::error_chain(e.as_ref()));
            std::process::ExitCode::FAILURE
        }
    }
}

fn run_cli() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    #[cfg(feature = "service")]
    bridge::iox::init_iceoryx_logging();
    match Cli::parse().cmd {
        Cmd::Simulate { plan, scene, out } => simulate(&plan, &scene, &out),
        Cmd::Process { input, out } => process(&input, &out).map(|_| ()),
        Cmd::ClosedLoop {
            mission,
            scene,
            out,
            horizon_s,
        } => {
            if !closed_loop(&mission, &scene, &out, horizon_s)? {
                bail!("a landmark in view was not detected (see report.json)");
            }
            Ok(())
        }
        Cmd::Resolution {
            out,
            bandwidths_mhz,
        } => resolution(&out, &bandwidths_mhz),
        #[cfg(feature = "service")]
        Cmd::Echo { args } => {
            let stop = planner::service::stop_on_signals()?;
            let report = radar_sim::service::run_echo(&args, &stop)?;
            tracing::info!(?report, "echo stopped");
            Ok(())
        }
        #[cfg(feature = "service")]
        Cmd::ProcessService { args } => {
            let stop = planner::service::stop_on_signals()?;
            let report = radar_sim::service::run_processor(&args, &stop)?;
            tracing::info!(?report, "processor stopped");
            Ok(())
        }
    }
}
