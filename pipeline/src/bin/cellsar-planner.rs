//! `cellsar-planner`: plan a mission, evaluate a trajectory, reproduce the paper, compute `E[d_min]`.
//!
//! Exit codes: 0 success, 1 internal failure (I/O, solver), 2 bad input (names the field, slot
//! or file), 3 the mission cannot be flown (names the first slot and the reason).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use pipeline::exit::{plan_failure, Failure};

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use pipeline::report::{self, reproduce};
use planner::dmin::{expected_dmin_m, expected_dmin_monte_carlo_m, CdfForm};
use planner::evaluate::{Dynamics, ResolutionMode};
use planner::Summary;
use planner::{
    evaluate, plan_with_observer, IterationRecord, Mission, Observer, PlanOptions, PlanResult,
    Scheme, Trajectory,
};

#[derive(Parser, Debug)]
#[command(
    name = "cellsar-planner",
    version,
    about = "Least-energy UAV trajectories for cellular-assisted bistatic SAR (Hu et al.), checked on the exact geometry"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Plan a mission and write trajectory.csv, summary.json, mission.toml and plots to --out.
    Plan {
        /// Mission file (TOML, or JSON with a .json extension).
        mission: PathBuf,
        /// exact (default): feasible on the exact geometry; paper: Algorithm 1 as printed;
        /// baseline: the paper's least-distance scheme; baseline-exact: least distance on the
        /// exact geometry.
        #[arg(long, default_value = "exact", value_parser = pipeline::args::enum_parser::<Scheme>())]
        scheme: Scheme,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Start from this trajectory (CSV with at least t_s,x_m,y_m; one row per slot, the
        /// start optional at t = 0).
        #[arg(long)]
        init: Option<PathBuf>,
        /// Largest number of SCA/BCD iterations.
        #[arg(long, default_value_t = 200)]
        max_iterations: usize,
        /// Stop when the relative change of the objective is below this.
        #[arg(long, default_value_t = 1e-4)]
        tolerance: f64,
        /// Skip the coarse first solve of the exact-geometry schemes.
        #[arg(long)]
        no_coarse: bool,
        /// Plain SCA for the exact scheme: always the proven centre-error bound, no
        /// over-relaxation (for comparisons with other implementations of the same scheme).
        #[arg(long)]
        plain_sca: bool,
        /// Resolution requirement of the exact-geometry schemes: general (the default for
        /// `exact`: the worst width of the 2-D resolution cell ≤ d_min in every landmark slot,
        /// or, where the geometry does not allow it, the plan with the least resolution
        /// shortfall and, at that shortfall, the least energy) or paper (the default for the
        /// comparison schemes: δ_r, δ_a ≤ d_min, the least-energy plan).
        #[arg(long, value_parser = pipeline::args::enum_parser::<ResolutionMode>())]
        resolution: Option<ResolutionMode>,
        #[command(flatten)]
        best_effort: BestEffortArgs,
        /// Vehicle model: vehicle (the default for the exact-geometry schemes: the velocity
        /// changes by at most the mission's max_accel_mps2 × δ from slot to slot, and by half
        /// that from its start_velocity_mps into the first slot; with the mission's
        /// max_jerk_mps3 the acceleration changes by at most that × δ from slot to slot; the
        /// mission's margins tighten the limits the plan is made for) or paper (the only model
        /// of paper and baseline: the velocity may jump).
        #[arg(long, value_parser = pipeline::args::enum_parser::<Dynamics>())]
        dynamics: Option<Dynamics>,
        /// Wall-time limit of the whole run, s: the iterations stop at the first check after it
        /// and the last accepted (feasible) iterate is written, with termination `time_limit`;
        /// a run still repairing its start then fails (exit 1).
        #[arg(long)]
        time_limit_s: Option<f64>,
        /// With --init: fail when the given path cannot be repaired, instead of planning from
        /// the built-in start (the default, noted as `init_replaced` in summary.json).
        #[arg(long)]
        no_init_fallback: bool,
    },
    /// The energy–resolution trade-off: the least-energy plan, the best-resolved plan within
    /// each cap on the extra energy, and the best-resolved plan; writes tradeoff.csv,
    /// tradeoff.svg and each point's plan directory (point_NN/) to --out.
    Tradeoff {
        /// Mission file (TOML, or JSON with a .json extension).
        mission: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Caps on the extra energy over the least-energy plan, % (comma-separated,
        /// ascending).
        #[arg(long, value_delimiter = ',', default_values_t = planner::tradeoff::DEFAULT_CAPS_PCT)]
        caps_pct: Vec<f64>,
    },
    /// Evaluate a trajectory of a mission on the exact geometry (true energy, violations).
    Evaluate {
        /// Mission file.
        mission: PathBuf,
        /// Trajectory CSV (t_s,x_m,y_m).
        #[arg(long)]
        trajectory: PathBuf,
    },
    /// Regenerate every figure and table of the paper's Section IV (CSV + SVG) and REPORT.md.
    Reproduce {
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Fewer random realisations (figure 11) for a fast check.
        #[arg(long)]
        quick: bool,
        /// Only these figures (comma-separated: 4a,4b,4c,5,6,7,8,9,10,11,12,t3); default all.
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
    },
    /// Serve plan requests over Zenoh (`cellsar/plan`), publish each plan on
    /// `cellsar/<mission>/plan`; stops on SIGINT/SIGTERM.
    Serve {
        #[command(flatten)]
        args: pipeline::services::plan::ServeArgs,
    },
    /// Plans one request for `serve` (its worker process; not for use by hand).
    #[command(name = "plan-worker", hide = true)]
    PlanWorker(pipeline::services::plan::worker::WorkerArgs),
    /// Expected least object distance `E[d_min]` in a disk: correct formula, as printed, Monte Carlo.
    Dmin {
        /// Disk radius R, m.
        #[arg(long)]
        radius_m: f64,
        /// Number of objects N.
        #[arg(long)]
        objects: u64,
        /// Monte Carlo trials.
        #[arg(long, default_value_t = 2000)]
        trials: u32,
        /// Monte Carlo seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

/// `println!` that stops quietly when stdout is closed (e.g. piped into `head`) instead of
/// panicking.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let mut stdout = std::io::stdout().lock();
        if let Err(e) = writeln!(stdout, $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
        }
    }};
}

fn bad(e: impl Into<anyhow::Error>) -> Failure {
    Failure::bad_input(e)
}

/// An output directory must be a directory or not exist yet (bad input otherwise, before any
/// work is done).
fn check_out_dir(out: &std::path::Path) -> Result<(), Failure> {
    if out.exists() && !out.is_dir() {
        return Err(bad(anyhow::anyhow!(
            "--out {}: exists and is not a directory",
            out.display()
        )));
    }
    Ok(())
}

/// The best-effort options of `plan` under `--resolution general`.
#[derive(clap::Args, Debug)]
struct BestEffortArgs {
    /// Refuse a mission whose resolution cell cannot be held within d_min in every landmark
    /// slot (exit 3, naming the first slot) instead of planning the best effort.
    #[arg(long, conflicts_with = "max_extra_energy_pct")]
    strict_resolution: bool,
    /// The best-resolved plan within this many percent more energy than the least-energy
    /// (paper resolution) plan.
    #[arg(long)]
    max_extra_energy_pct: Option<f64>,
}

/// Shows iterations on a spinner (hidden when stderr is not a terminal).
struct Progress(ProgressBar);

impl Observer for Progress {
    fn on_phase(&mut self, phase: &str) {
        self.0.set_prefix(phase.to_string());
    }
    fn on_iteration(&mut self, r: &IterationRecord) {
        self.0.set_message(format!(
            "iteration {:>3}  objective {:>10.2}  true energy {:>10.2} J  {}",
            r.iteration,
            r.objective,
            r.true_energy_j,
            if r.accepted { "" } else { "(step rejected)" }
        ));
        self.0.tick();
    }
}

fn spinner() -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    pb.set_style(
        ProgressStyle::with_template("{spinner} {prefix:>7} {msg} [{elapsed}]")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    pb
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Plan {
            mission,
            scheme,
            out,
            init,
            max_iterations,
            tolerance,
            no_coarse,
            plain_sca,
            resolution,
            best_effort,
            dynamics,
            time_limit_s,
            no_init_fallback,
        } => {
            let m = Mission::from_path(&mission).map_err(bad)?;
            check_out_dir(&out)?;
            let p = m.params();
            let init = match init {
                Some(path) => Some(
                    Trajectory::from_csv_path(&path, p.slot_s, m.slots(), p.start_m, p.altitude_m)
                        .map_err(bad)?,
                ),
                None => None,
            };
            let resolution = resolution.unwrap_or(scheme.default_resolution());
            let options = PlanOptions {
                scheme,
                max_iterations,
                tolerance,
                init,
                coarse: !no_coarse,
                over_relaxation: !plain_sca,
                resolution,
                min_kappa_scale: if plain_sca {
                    1.0
                } else {
                    PlanOptions::default().min_kappa_scale
                },
                time_limit_s,
                replace_unrepairable_init: !no_init_fallback,
                strict_resolution: best_effort.strict_resolution,
                max_extra_energy_pct: best_effort.max_extra_energy_pct,
                dynamics: dynamics.unwrap_or(scheme.default_dynamics()),
                // a free-altitude mission's plan directory carries its altitudes (z_m)
                altitude_profile: true,
                ..PlanOptions::default()
            };
            if !scheme.supports(options.dynamics) {
                return Err(bad(anyhow::anyhow!(
                    "--dynamics {} applies to --scheme exact and baseline-exact only, not to {scheme}",
                    options.dynamics
                )));
            }
            pipeline::args::check_best_effort_flags(&options).map_err(bad)?;
            let pb = spinner();
            let result = plan_with_observer(&m, &options, &mut Progress(pb.clone()));
            pb.finish_and_clear();
            let result = match result {
                Ok(result) => result,
                // no plan meets every constraint: write the best one found, marked infeasible
                // (summary.json's `feasible` is false; its violations say where), then fail
                Err(planner::PlanError::NotFound(nf)) => {
                    if let Some(best) = &nf.best {
                        let files = report::write_plan_dir(&out, &m, best)
                            .with_context(|| format!("writing {}", out.display()))?;
                        print_plan(&m, best, &files);
                        out!("the plan written is the best found and is infeasible");
                    }
                    return Err(plan_failure(planner::PlanError::NotFound(nf)));
                }
                Err(e) => return Err(plan_failure(e)),
            };
            let files = report::write_plan_dir(&out, &m, &result)
                .with_context(|| format!("writing {}", out.display()))?;
            print_plan(&m, &result, &files);
            Ok(())
        }
        Command::Tradeoff {
            mission,
            out,
            caps_pct,
        } => tradeoff_command(&mission, &out, &caps_pct),
        Command::Evaluate {
            mission,
            trajectory,
        } => {
            let m = Mission::from_path(&mission).map_err(bad)?;
            let p = m.params();
            let ev = if p.altitude == planner::AltitudeMode::Free {
                // a free-altitude plan's z_m column: each slot at its own altitude
                let (tr, z) = Trajectory::from_csv_path_with_altitudes(
                    &trajectory,
                    p.slot_s,
                    m.slots(),
                    p.start_m,
                    p.altitude_m,
                )
                .map_err(bad)?;
                planner::evaluate::evaluate_with_altitudes(&m, &tr, &z).map_err(bad)?
            } else {
                let tr = Trajectory::from_csv_path(
                    &trajectory,
                    p.slot_s,
                    m.slots(),
                    p.start_m,
                    p.altitude_m,
                )
                .map_err(bad)?;
                evaluate(&m, &tr)
            };
            let json = serde_json::json!({
                "energy_j": ev.energy_j,
                "feasible": ev.is_feasible(),
                "violations": ev.violations,
                "min_speed_mps": ev.min_speed_mps,
                "max_speed_mps": ev.max_speed_mps,
                "length_m": ev.length_m,
                "slots_out_of_view": ev.slots_out_of_view,
                "slots_unresolved_general": ev.slots_unresolved,
                "slots_blind": ev.slots_blind,
            });
            out!(
                "{}",
                serde_json::to_string_pretty(&json).context("encoding the evaluation")?
            );
            Ok(())
        }
        Command::Reproduce { out, quick, only } => {
            let figures =
                reproduce::FigureSet::parse(&only).map_err(|e| bad(anyhow::anyhow!(e)))?;
            check_out_dir(&out)?;
            let report = reproduce::reproduce(&out, quick, &figures)
                .with_context(|| format!("reproducing into {}", out.display()))?;
            out!("wrote {}", report.display());
            Ok(())
        }
        Command::Serve { mut args } => {
            args.worker_exe = pipeline::services::plan::worker::own_executable();
            let stop = pipeline::services::plan::stop_on_signals().map_err(Failure::runtime)?;
            let report = pipeline::services::plan::serve(&args, &stop).map_err(Failure::from)?;
            tracing::info!(?report, "plan service stopped");
            Ok(())
        }
        Command::PlanWorker(a) => {
            pipeline::services::plan::worker::run_worker(&a).map_err(Failure::from)
        }
        Command::Dmin {
            radius_m,
            objects,
            trials,
            seed,
        } => dmin_command(radius_m, objects, trials, seed),
    }
}

/// Prints a plan's summary lines and the files written.
fn print_plan(m: &Mission, result: &PlanResult, files: &[PathBuf]) {
    let s = Summary::new(m, result);
    out!(
        "{}: scheme {}, true energy {:.1} J ({}), own objective {}, {} iterations ({}), {:.3} s",
        m.name(),
        s.scheme,
        s.energy_j,
        match (s.lower_bound_j, s.bound_gap_pct) {
            (Some(b), Some(gap)) => format!("lower bound {b:.1} J, gap {gap:.2} %"),
            _ => format!(
                "{:+.2}% vs floor {:.1} J",
                100.0 * s.energy_over_floor,
                s.floor_energy_j
            ),
        },
        own_objective(&s),
        s.iterations,
        s.termination,
        s.solve_seconds
    );
    out!(
        "exact geometry: feasible {}, sensing violation {:.3} m ({} slots out of view), azimuth speed shortfall {:.3} m/s, speeds {:.2}..{:.2} m/s",
        s.feasible,
        s.max_sensing_violation_m,
        s.slots_out_of_view,
        s.max_azimuth_speed_violation_mps,
        s.min_speed_mps,
        s.max_speed_mps
    );
    if let Some(line) = shortfall_line(&s) {
        out!("{line}");
    }
    if let Some(line) = report::vehicle_limits_line(&s) {
        out!("vehicle limits: {line}");
    }
    if let Some(reason) = &result.init_replaced {
        out!(
            "note: the --init path could not be made feasible ({reason}); planned from the built-in start instead"
        );
    }
    for f in files {
        out!("wrote {}", f.display());
    }
}

/// The optimiser's own objective for the summary line: in m for a distance scheme; in J for an
/// energy scheme, saying for a best effort that it includes the resolution penalty (which is
/// why it exceeds the true energy; `summary.json`'s `objective_j`).
fn own_objective(s: &Summary) -> String {
    match (s.objective_j, s.objective_m) {
        (Some(j), _) if s.best_effort.is_some() => format!(
            "{j:.1} J (energy model + {} J/m × resolution deficit)",
            planner::driver::DEFAULT_RESOLUTION_WEIGHT_J_PER_M
        ),
        (Some(j), _) => format!("{j:.1} J"),
        (None, Some(m)) => format!("{m:.1} m"),
        (None, None) => String::new(),
    }
}

/// `cellsar-planner tradeoff`.
fn tradeoff_command(mission: &Path, out: &Path, caps_pct: &[f64]) -> Result<(), Failure> {
    let m = Mission::from_path(mission).map_err(bad)?;
    check_out_dir(out)?;
    if caps_pct.windows(2).any(|w| w[1] < w[0]) {
        return Err(bad(anyhow::anyhow!("--caps-pct must be ascending")));
    }
    // a free-altitude mission's points are free plans (each point_NN/ with its altitudes)
    let options = PlanOptions {
        altitude_profile: true,
        ..PlanOptions::default()
    };
    let pb = spinner();
    let points = planner::tradeoff::tradeoff_with_observer(
        &m,
        &options,
        caps_pct,
        &mut Progress(pb.clone()),
    )
    .map_err(plan_failure)?;
    pb.finish_and_clear();
    report::tradeoff::write_tradeoff_dir(out, &m, &points)
        .with_context(|| format!("writing {}", out.display()))?;
    out!("point  cap/%  energy/J  extra/%  unresolved windows  slots  excess width/m");
    for (i, p) in points.iter().enumerate() {
        out!(
            "{i:>5}  {:>5}  {:>8.1}  {:>7.2}  {:>18}  {:>5}  {:>14.0}",
            p.cap_pct.map_or("none".to_string(), |c| format!("{c}")),
            p.plan.evaluation.energy_j,
            p.extra_energy_pct,
            p.shortfall.unresolved_windows,
            p.shortfall.unresolved_slots,
            p.shortfall.total_excess_width_m
        );
    }
    out!("wrote {}", out.display());
    Ok(())
}

/// `cellsar-planner dmin`.
fn dmin_command(radius_m: f64, objects: u64, trials: u32, seed: u64) -> Result<(), Failure> {
    let correct = expected_dmin_m(radius_m, objects, CdfForm::Correct).map_err(bad)?;
    // the as-printed formula may not converge for very large N: say so, do not fail
    let printed = match expected_dmin_m(radius_m, objects, CdfForm::AsPrinted) {
        Ok(v) => Ok(v),
        Err(e @ planner::dmin::DminError::Quadrature { .. }) => Err(e),
        Err(e) => return Err(bad(e)),
    };
    let (mc, se) = expected_dmin_monte_carlo_m(radius_m, objects, trials, seed).map_err(bad)?;
    out!("R = {radius_m} m, N = {objects}");
    out!("E[d_min] correct formula : {correct:.3} m");
    match printed {
        Ok(v) => {
            out!("E[d_min] as printed      : {v:.3} m  (the paper's eq. lacks a factor l)")
        }
        Err(e) => out!("E[d_min] as printed      : not computed ({e})"),
    }
    if trials > 1 {
        out!("E[d_min] Monte Carlo     : {mc:.3} ± {se:.3} m  ({trials} trials)");
    } else {
        out!("E[d_min] Monte Carlo     : {mc:.3} m  (1 trial: no standard error)");
    }
    Ok(())
}

/// One line on the resolution of a plan made for the general resolution as a best effort.
fn shortfall_line(s: &Summary) -> Option<String> {
    let (b, r) = (s.best_effort.as_ref()?, s.resolution_shortfall.as_ref()?);
    let unresolved: Vec<String> = r
        .windows
        .iter()
        .filter(|w| w.unresolved)
        .map(|w| format!("{} ({:.0} m)", w.landmark, w.median_worst_width_m))
        .collect();
    Some(format!(
        "resolution (best effort): {} of {} windows and {} landmark slots with a cell wider than d_min = {} m{}; the least-energy plan{}: {} windows, {} slots at {:.1} J (this plan {:+.2}%)",
        r.unresolved_windows,
        r.windows.len(),
        r.unresolved_slots,
        r.d_min_m,
        if unresolved.is_empty() {
            String::new()
        } else {
            format!(" (landmark, median cell: {})", unresolved.join(", "))
        },
        report::least_energy_basis_note(s),
        b.least_energy_shortfall.unresolved_windows,
        b.least_energy_shortfall.unresolved_slots,
        b.least_energy_j,
        s.extra_energy_pct.unwrap_or(f64::NAN)
    ))
}

/// The log level when `RUST_LOG` is not set: `info` for the long-running service (it says
/// that it is ready, waits for its router, stops, with its counters, as `cellsar planner`,
/// `cellsar-radar-sim echo|process-service` and `cellsar-bridge` do), `warn` for the one-shot
/// commands.
fn default_log_filter(command: &Command) -> &'static str {
    match command {
        Command::Serve { .. } | Command::PlanWorker(_) => cellsar_error::SERVICE_LOG_FILTER,
        _ => cellsar_error::COMMAND_LOG_FILTER,
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    cellsar_error::init_logging(default_log_filter(&cli.command));
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// `serve` logs at info by default (so that it shows that it runs, like the other
    /// services); the one-shot commands stay at warn.
    #[test]
    fn services_log_at_info_and_commands_at_warn() {
        let level = |args: &[&str]| {
            default_log_filter(
                &Cli::try_parse_from(
                    std::iter::once("cellsar-planner").chain(args.iter().copied()),
                )
                .unwrap()
                .command,
            )
        };
        assert_eq!(level(&["serve"]), cellsar_error::SERVICE_LOG_FILTER);
        assert_eq!(
            level(&["plan", "m.toml", "--out", "o"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
        assert_eq!(
            level(&["evaluate", "m.toml", "--trajectory", "t.csv"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
        assert_eq!(
            level(&["reproduce", "--out", "o"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
        assert_eq!(
            level(&["dmin", "--radius-m", "5000", "--objects", "10"]),
            cellsar_error::COMMAND_LOG_FILTER
        );
    }
}
