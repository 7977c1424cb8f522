//! SNR at the landmarks, fixed against free altitude: plans a mission at its fixed altitude and
//! with `altitude = "free"` within each pair of bounds given (the `exact` scheme with the
//! altitude profile, as `planner/examples/free_altitude.rs` and `cellsar-radar-sim closed-loop`
//! plan it), and prints per plan its true energy, altitude range, feasibility, unresolved
//! landmark windows (median longest chord over d_min) and slots, and the expected SNR of each landmark at its aperture from the radar's link
//! budget (`radar_sim::run::landmark_snrs`: the closed loop's apertures, looks and pulses at the
//! flown altitudes, `Processor::expected_snr_db` per look, the mean over looks as the closed
//! loop reports it), min / mean over the landmark apertures in view, with the mean over them of
//! the UAV antenna's gain towards the landmark (dB off its peak) and of the slant range.
//!
//! `cargo run --release -p radar-sim --example landmark_snr -- MISSION.toml [LO-HI ...]
//! [paper] [apertures] [--scene SCENE.toml]`
//!
//! `LO-HI`: altitude bounds in m, e.g. `600-1200` (default: the mission's own, for a mission
//! with `altitude = "free"`); `paper`: the least-energy plans, the paper's resolution (default:
//! the default options, the general resolution as a best effort); `apertures`: each aperture's
//! row too; `--scene`: the scene (default `radar-sim/scenes/default.toml`).

use std::path::{Path, PathBuf};

use planner::evaluate::ResolutionMode;
use planner::shortfall::ResolutionShortfall;
use planner::{AltitudeMode, Mission, PlanOptions, PlanResult};
use radar_sim::config::SceneFile;
use radar_sim::run::{landmark_snrs, LandmarkSnr, SnrSummary};

type Error = Box<dyn std::error::Error>;

/// The command line.
struct Args {
    mission: PathBuf,
    bounds_m: Vec<(f64, f64)>,
    paper: bool,
    apertures: bool,
    scene: PathBuf,
}

fn parse_args() -> Result<Args, Error> {
    let usage =
        "usage: landmark_snr MISSION.toml [LO-HI ...] [paper] [apertures] [--scene SCENE.toml]";
    let mut it = std::env::args().skip(1);
    let mission = PathBuf::from(it.next().ok_or(usage)?);
    let mut args = Args {
        mission,
        bounds_m: Vec::new(),
        paper: false,
        apertures: false,
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/default.toml"),
    };
    while let Some(a) = it.next() {
        match a.as_str() {
            "paper" => args.paper = true,
            "apertures" => args.apertures = true,
            "--scene" => args.scene = PathBuf::from(it.next().ok_or("--scene needs a file")?),
            bounds => {
                let (lo, hi) = bounds
                    .split_once('-')
                    .ok_or_else(|| format!("{bounds}: not LO-HI (altitude bounds, m); {usage}"))?;
                args.bounds_m.push((
                    lo.parse().map_err(|e| format!("{bounds}: {e}"))?,
                    hi.parse().map_err(|e| format!("{bounds}: {e}"))?,
                ));
            }
        }
    }
    Ok(args)
}

/// `mission` with its altitude fixed at `altitude_m` (its bounds dropped).
fn fixed(mission: &Mission) -> Result<Mission, Error> {
    let mut p = mission.params().clone();
    p.altitude = AltitudeMode::Fixed;
    p.min_altitude_m = None;
    p.max_altitude_m = None;
    Ok(mission.with_params(p)?)
}

/// `mission` with a free altitude within `lo`–`hi` m.
fn free(mission: &Mission, (lo, hi): (f64, f64)) -> Result<Mission, Error> {
    let mut p = mission.params().clone();
    p.altitude = AltitudeMode::Free;
    p.min_altitude_m = Some(lo);
    p.max_altitude_m = Some(hi);
    Ok(mission.with_params(p)?)
}

/// Plans `mission` (with the altitude profile when it is free) and evaluates its landmarks' SNR.
fn case(
    mission: &Mission,
    options: &PlanOptions,
    scene: &SceneFile,
) -> Result<(PlanResult, Vec<LandmarkSnr>), Error> {
    let options = PlanOptions {
        altitude_profile: mission.params().altitude == AltitudeMode::Free,
        ..options.clone()
    };
    let plan = planner::plan(mission, &options)?;
    let snr = landmark_snrs(
        mission,
        &plan.trajectory,
        plan.altitudes_m.as_deref(),
        &plan.evaluation,
        scene,
    )?;
    Ok((plan, snr))
}

fn row(label: &str, mission: &Mission, plan: &PlanResult, snr: &[LandmarkSnr]) {
    let start = plan.evaluation.start_altitude_m;
    let (lo, hi) = plan
        .altitudes_m
        .as_deref()
        .unwrap_or(&[start])
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let s = SnrSummary::of(snr);
    let short = ResolutionShortfall::new(mission, &plan.evaluation);
    println!(
        "{label:<11} {:>10.1} {:>6.0}-{:<6.0} {:>8} {:>5}/{:<5} {:>8} {:>7.2}/{:<6.2} {:>8.2} {:>9.1}",
        plan.evaluation.energy_j,
        lo,
        hi,
        plan.is_feasible(),
        short.unresolved_windows,
        plan.evaluation.slots_unresolved,
        s.apertures_in_view,
        s.min_db,
        s.mean_db,
        s.mean_gain_db,
        s.mean_slant_range_m
    );
}

fn aperture_rows(label: &str, snr: &[LandmarkSnr]) {
    println!(
        "  {label}: aperture landmark in_view altitude_m range_m gain_db snr_db (looks min/max)"
    );
    for r in snr {
        let (lo, hi) = r
            .look_snr_db
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        println!(
            "  {:>8} {:>8} {:>7.2} {:>10.1} {:>7.1} {:>7.2} {:>6.2} ({lo:.2}/{hi:.2})",
            r.aperture,
            r.landmark,
            r.in_view_fraction,
            r.mean_altitude_m,
            r.mean_slant_range_m,
            r.gain_db,
            r.snr_db
        );
    }
}

fn main() -> Result<(), Error> {
    let args = parse_args()?;
    let mission = Mission::from_path(&args.mission)?;
    let scene = SceneFile::from_path(&args.scene)?;
    let mut options = PlanOptions::default();
    if args.paper {
        options.resolution = ResolutionMode::Paper;
    }
    let mut bounds = args.bounds_m.clone();
    if bounds.is_empty() {
        let p = mission.params();
        match (p.altitude, p.min_altitude_m, p.max_altitude_m) {
            (AltitudeMode::Free, Some(lo), Some(hi)) => bounds.push((lo, hi)),
            _ => return Err("a fixed mission needs altitude bounds LO-HI to compare".into()),
        }
    }
    println!(
        "{} ({} resolution), scene {}",
        mission.name(),
        options.resolution,
        args.scene.display()
    );
    println!(
        "plan          energy_j  altitude_m  feasible unres w/slots in_view snr_db min/mean  gain_db  range_m"
    );
    let at_fixed = fixed(&mission)?;
    let (plan, snr) = case(&at_fixed, &options, &scene)?;
    row("fixed", &at_fixed, &plan, &snr);
    let mut details = vec![("fixed".to_string(), snr)];
    for b in bounds {
        let label = format!("{:.0}-{:.0}", b.0, b.1);
        let free_mission = free(&mission, b)?;
        let (plan, snr) = case(&free_mission, &options, &scene)?;
        row(&label, &free_mission, &plan, &snr);
        details.push((label, snr));
    }
    if args.apertures {
        for (label, snr) in &details {
            aperture_rows(label, snr);
        }
    }
    Ok(())
}
