//! Performance evidence for issue 2 ("Performance"): the default mission with the `exact` scheme,
//! one SCA iteration's cone program with and without pattern reuse, and the growth of the time per
//! iteration and of the whole plan with the number of slots T_w.
//!
//! Run with `cargo bench -p planner --bench plan` (7–10 minutes on 2 busy cores). Groups:
//! - `plan_default`: `planner::plan` with the default options (exact scheme, coarse start,
//!   over-relaxation, tolerance 1e-4) on the paper's default mission at 30 m and 200 m spacing;
//! - `default_mission_plan`: the same on `missions/default-30m.toml` as read from the file, no
//!   side runs (the figure to compare before and after a change of the planner's internals);
//! - `sca_iteration`: one exact SCA iteration (`ExactSubproblem::build` + `SocpSolver::solve`) at
//!   a feasible start, with the solver's pattern reused (`reuse: true`, values updated in place)
//!   or rebuilt every time (`reuse: false`), and the assembly alone (`build_only`);
//! - `sca_settings`: the same iteration (pattern reused) under variants of Clarabel's tolerances
//!   and iterative refinement, with the status, interior-point iterations and objective of each;
//! - `scaling_iteration` / `scaling_plan`: the default 30 m mission with slot lengths 2 … 0.0625 s
//!   (T_w = 150 … 4800): one SCA iteration at a feasible start, and the whole default plan.
//!
//! After the criterion groups a summary is printed: the per-phase split of the default plans
//! (start on the coarse grid vs iterations on the mission's grid, interior-point iterations), and
//! for the scaling groups the median time per T_w with the least-squares slope of log(time) on
//! log(T_w) (1 = linear growth; a dense interior-point method would show about 3.5).

use std::collections::BTreeMap;
use std::hint::black_box;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, SamplingMode};
use planner::evaluate::ResolutionMode;
use planner::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use planner::socp::{SocpSettings, SocpSolver};
use planner::{
    plan, plan_with_observer, IterationRecord, Mission, Observer, PlanOptions, Preset, Trajectory,
};

/// Slot lengths of the scaling groups, s (T_w = 300 s / δ = 150 … 4800).
const SLOT_LENGTHS_S: [f64; 6] = [2.0, 1.0, 0.5, 0.25, 0.125, 0.0625];

/// Landmark spacings of the default missions, m.
const SPACINGS_M: [f64; 2] = [30.0, 200.0];

/// Per-call seconds recorded by the timed routines, keyed by (group, T_w).
static SAMPLES: Mutex<BTreeMap<(String, usize), Vec<f64>>> = Mutex::new(BTreeMap::new());

/// Interior-point iterations of one solve per (label, T_w), recorded once per bench.
static IPM: Mutex<BTreeMap<(String, usize), u32>> = Mutex::new(BTreeMap::new());

/// Solver-settings diagnostic lines (status, IPM iterations, objective), one per variant.
static SETTINGS: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// Phase split of the default plans, one line each.
static PHASES: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// Unwraps a setup result of the benchmark harness (a failure here is a bug to report, so it
/// aborts the benchmark with the reason).
fn must<T, E: std::fmt::Display>(r: Result<T, E>, what: &str) -> T {
    match r {
        Ok(v) => v,
        Err(e) => panic!("benchmark setup failed: {what}: {e}"),
    }
}

fn record(group: &str, slots: usize, seconds: f64) {
    if let Ok(mut m) = SAMPLES.lock() {
        m.entry((group.to_string(), slots))
            .or_default()
            .push(seconds);
    }
}

/// The paper's default mission at `spacing_m`, with slot length `slot_s`.
fn mission(spacing_m: f64, slot_s: f64) -> Mission {
    let m = must(
        Mission::preset(Preset::Default, spacing_m),
        "default mission",
    );
    let mut p = m.params().clone();
    p.slot_s = slot_s;
    must(m.with_params(p), "default mission with a new slot length")
}

/// The feasible start of the plain SCA (`cellsar-planner plan --no-coarse --max-iterations 0`):
/// the guidance path made feasible on the coarse grid, interpolated and repaired on the fine one.
fn feasible_start(m: &Mission) -> Trajectory {
    let options = PlanOptions {
        max_iterations: 0,
        resolution: ResolutionMode::Paper,
        coarse: false,
        ..PlanOptions::default()
    };
    let r = must(plan(m, &options), "feasible start");
    assert!(
        r.evaluation.is_feasible(),
        "the start of {} is not feasible on the exact geometry",
        m.name()
    );
    r.trajectory
}

/// One exact SCA iteration: assemble the subproblem around `start` and solve it.
fn sca_iteration(m: &Mission, start: &Trajectory, solver: &mut SocpSolver) -> (f64, u32) {
    let sub = ExactSubproblem::build(m, start, ExactObjective::Energy, &ExactTuning::default());
    let sol = must(solver.solve(&sub.builder), "exact subproblem");
    (sub.physical_objective(sol.objective), sol.iterations)
}

/// Records when the planner enters its fine-grid iterations and what each iteration costs.
#[derive(Default)]
struct PhaseClock {
    started: Option<Instant>,
    solve_at_s: Option<f64>,
    records: Vec<IterationRecord>,
}

impl Observer for PhaseClock {
    fn on_phase(&mut self, phase: &str) {
        if phase == "solve" {
            self.solve_at_s = self.started.map(|t| t.elapsed().as_secs_f64());
        }
    }
    fn on_iteration(&mut self, r: &IterationRecord) {
        self.records.push(r.clone());
    }
}

fn phase_split(m: &Mission) -> String {
    let mut clock = PhaseClock {
        started: Some(Instant::now()),
        ..PhaseClock::default()
    };
    let r = must(
        plan_with_observer(m, &PlanOptions::least_energy(), &mut clock),
        "default plan",
    );
    let total = r.solve_seconds;
    let start_s = clock.solve_at_s.unwrap_or(f64::NAN);
    let fine: f64 = clock.records.iter().map(|x| x.seconds).sum();
    let ipm: Vec<String> = clock
        .records
        .iter()
        .map(|x| x.ipm_iterations.to_string())
        .collect();
    format!(
        "| {} | {} | {:.3} | {:.3} | {} | {:.3} | [{}] | {:.1} | {} |",
        m.name(),
        m.slots(),
        total,
        start_s,
        clock.records.len(),
        fine,
        ipm.join(", "),
        r.evaluation.energy_j,
        r.evaluation.is_feasible()
    )
}

fn plan_default(c: &mut Criterion) {
    let mut g = c.benchmark_group("plan_default");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(10))
        .sampling_mode(SamplingMode::Flat);
    for spacing in SPACINGS_M {
        let m = mission(spacing, 0.5);
        let mut split_done = false;
        g.bench_function(BenchmarkId::new("exact", format!("{spacing}m")), |b| {
            if !split_done {
                split_done = true;
                let line = phase_split(&m);
                if let Ok(mut p) = PHASES.lock() {
                    p.push(line);
                }
            }
            b.iter(|| {
                must(
                    plan(black_box(&m), &PlanOptions::least_energy()),
                    "default plan",
                )
            })
        });
    }
    g.finish();
}

/// `planner::plan` with the default options on `missions/default-30m.toml` (the file the README's
/// main job plans): the figure to compare before and after a change of the planner's internals.
fn default_mission_plan(c: &mut Criterion) {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../missions/default-30m.toml");
    let m = must(Mission::from_path(&path), "missions/default-30m.toml");
    let mut g = c.benchmark_group("default_mission_plan");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(10))
        .sampling_mode(SamplingMode::Flat);
    g.bench_function("default-30m", |b| {
        b.iter(|| {
            must(
                plan(black_box(&m), &PlanOptions::least_energy()),
                "default plan",
            )
        })
    });
    g.finish();
}

fn sca_reuse(c: &mut Criterion) {
    let mut g = c.benchmark_group("sca_iteration");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(3));
    for spacing in SPACINGS_M {
        let m = mission(spacing, 0.5);
        let mut start: Option<Trajectory> = None;
        let mut warm: Option<SocpSolver> = None;
        g.bench_function(BenchmarkId::new("reuse", format!("{spacing}m")), |b| {
            let s = start.get_or_insert_with(|| feasible_start(&m));
            let solver = warm.get_or_insert_with(|| {
                let mut solver = SocpSolver::new(SocpSettings {
                    reuse: true,
                    ..SocpSettings::exact_geometry()
                });
                // the first solve builds the pattern; timed calls only update values in place
                let (_, ipm) = sca_iteration(&m, s, &mut solver);
                if let Ok(mut t) = IPM.lock() {
                    t.insert((format!("default {spacing} m"), m.slots()), ipm);
                }
                solver
            });
            b.iter(|| sca_iteration(&m, s, solver))
        });
        g.bench_function(BenchmarkId::new("rebuild", format!("{spacing}m")), |b| {
            let s = start.get_or_insert_with(|| feasible_start(&m));
            let mut solver = SocpSolver::new(SocpSettings {
                reuse: false,
                ..SocpSettings::exact_geometry()
            });
            b.iter(|| sca_iteration(&m, s, &mut solver))
        });
        g.bench_function(BenchmarkId::new("build_only", format!("{spacing}m")), |b| {
            let s = start.get_or_insert_with(|| feasible_start(&m));
            b.iter(|| {
                ExactSubproblem::build(
                    &m,
                    black_box(s),
                    ExactObjective::Energy,
                    &ExactTuning::default(),
                )
            })
        });
    }
    g.finish();
}

/// Variants of the cone-program settings tried on the first SCA subproblem: Clarabel's
/// tolerances and iterative refinement (where the interior-point time goes).
fn settings_variants() -> Vec<(&'static str, SocpSettings)> {
    let d = SocpSettings::default();
    vec![
        ("default (tol 1e-8, refine <= 10)", d),
        (
            "exact_geometry (tol 1e-8, no refinement; the exact scheme's)",
            SocpSettings::exact_geometry(),
        ),
        (
            "tol 1e-6",
            SocpSettings {
                tol_feas: 1e-6,
                tol_gap_rel: 1e-6,
                ..d
            },
        ),
        (
            "refine <= 2",
            SocpSettings {
                refine_max_iter: 2,
                ..d
            },
        ),
        (
            "tol 1e-6, refine <= 2",
            SocpSettings {
                tol_feas: 1e-6,
                tol_gap_rel: 1e-6,
                refine_max_iter: 2,
                ..d
            },
        ),
    ]
}

fn sca_settings(c: &mut Criterion) {
    let mut g = c.benchmark_group("sca_settings");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(3))
        .sampling_mode(SamplingMode::Flat);
    for spacing in SPACINGS_M {
        let m = mission(spacing, 0.5);
        let mut start: Option<Trajectory> = None;
        let mut reference: Option<f64> = None;
        for (k, (label, settings)) in settings_variants().into_iter().enumerate() {
            let mut warm: Option<SocpSolver> = None;
            g.bench_function(BenchmarkId::new(format!("v{k}"), format!("{spacing}m")), |b| {
                let s = start.get_or_insert_with(|| feasible_start(&m));
                let solver = warm.get_or_insert_with(|| {
                    let mut solver = SocpSolver::new(settings);
                    let sub = ExactSubproblem::build(
                        &m,
                        s,
                        ExactObjective::Energy,
                        &ExactTuning::default(),
                    );
                    let line = match solver.solve(&sub.builder) {
                        Ok(sol) => {
                            let obj = sub.physical_objective(sol.objective);
                            let r = *reference.get_or_insert(obj);
                            format!(
                                "| {spacing} m | v{k}: {label} | {:?} | {} | {:.3e} | {:.6} | {:.1e} |",
                                sol.status,
                                sol.iterations,
                                sol.violation,
                                obj,
                                (obj - r).abs() / r
                            )
                        }
                        Err(e) => format!("| {spacing} m | v{k}: {label} | error: {e} | | | | |"),
                    };
                    if let Ok(mut l) = SETTINGS.lock() {
                        l.push(line);
                    }
                    solver
                });
                b.iter(|| {
                    let sub = ExactSubproblem::build(
                        &m,
                        s,
                        ExactObjective::Energy,
                        &ExactTuning::default(),
                    );
                    black_box(solver.solve(&sub.builder).ok())
                })
            });
        }
    }
    g.finish();
}

fn scaling(c: &mut Criterion) {
    let mut g = c.benchmark_group("scaling_iteration");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(2))
        .sampling_mode(SamplingMode::Flat);
    let missions: Vec<Mission> = SLOT_LENGTHS_S.iter().map(|&d| mission(30.0, d)).collect();
    for m in &missions {
        let n = m.slots();
        let mut start: Option<Trajectory> = None;
        let mut warm: Option<SocpSolver> = None;
        g.bench_with_input(BenchmarkId::from_parameter(n), m, |b, m| {
            let s = start.get_or_insert_with(|| feasible_start(m));
            let solver = warm.get_or_insert_with(|| {
                let mut solver = SocpSolver::new(SocpSettings::exact_geometry());
                let (_, ipm) = sca_iteration(m, s, &mut solver);
                if let Ok(mut t) = IPM.lock() {
                    t.insert(("scaling".to_string(), n), ipm);
                }
                solver
            });
            b.iter_custom(|iters| {
                let t0 = Instant::now();
                for _ in 0..iters {
                    black_box(sca_iteration(m, s, solver));
                }
                let d = t0.elapsed();
                record(
                    "scaling_iteration",
                    n,
                    d.as_secs_f64() / iters.max(1) as f64,
                );
                d
            })
        });
    }
    g.finish();

    let mut g = c.benchmark_group("scaling_plan");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(5))
        .sampling_mode(SamplingMode::Flat);
    for m in &missions {
        let n = m.slots();
        g.bench_with_input(BenchmarkId::from_parameter(n), m, |b, m| {
            b.iter_custom(|iters| {
                let t0 = Instant::now();
                for _ in 0..iters {
                    black_box(must(plan(m, &PlanOptions::least_energy()), "scaling plan"));
                }
                let d = t0.elapsed();
                record("scaling_plan", n, d.as_secs_f64() / iters.max(1) as f64);
                d
            })
        });
    }
    g.finish();
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// Least-squares slope of log(y) on log(x).
fn loglog_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let lx: Vec<f64> = points.iter().map(|p| p.0.ln()).collect();
    let ly: Vec<f64> = points.iter().map(|p| p.1.ln()).collect();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

fn summary() {
    if let Ok(p) = PHASES.lock() {
        if !p.is_empty() {
            println!("\nPhase split of the default plan (one run each):");
            println!("| mission | T_w | total s | start (coarse grid) s | fine iterations | fine s | IPM iterations per fine iteration | energy J | feasible |");
            println!("|---|---|---|---|---|---|---|---|---|");
            for line in p.iter() {
                println!("{line}");
            }
        }
    }
    if let Ok(l) = SETTINGS.lock() {
        if !l.is_empty() {
            println!("\nFirst SCA subproblem at the feasible start under solver-settings variants (times: sca_settings/vK above):");
            println!("| mission | variant | status | IPM iterations | cone violation | objective J | rel. diff to v0 |");
            println!("|---|---|---|---|---|---|---|");
            for line in l.iter() {
                println!("{line}");
            }
        }
    }
    let samples = match SAMPLES.lock() {
        Ok(s) => s.clone(),
        Err(_) => return,
    };
    let ipm = IPM.lock().map(|t| t.clone()).unwrap_or_default();
    if !ipm.is_empty() {
        println!("\nInterior-point iterations of the first SCA subproblem at the feasible start:");
        for ((label, n), k) in &ipm {
            println!("  {label:<16} T_w = {n:>5}: {k}");
        }
    }
    for group in ["scaling_iteration", "scaling_plan"] {
        let points: Vec<(f64, f64)> = samples
            .iter()
            .filter(|((g, _), _)| g == group)
            .map(|((_, n), v)| (*n as f64, median(v)))
            .collect();
        if points.len() < 2 {
            continue;
        }
        // interior-point iterations of the timed subproblem (the same one every call)
        let ipm_of = |n: f64| {
            (group == "scaling_iteration")
                .then(|| ipm.get(&("scaling".to_string(), n as usize)).copied())
                .flatten()
        };
        println!("\n{group}: median seconds per call vs T_w");
        println!(
            "| T_w | seconds | µs per slot | local slope | IPM iterations | ms per IPM iteration |"
        );
        println!("|---|---|---|---|---|---|");
        let mut per_ipm = Vec::new();
        for (i, &(n, t)) in points.iter().enumerate() {
            let local = if i == 0 {
                "".to_string()
            } else {
                format!("{:.2}", loglog_slope(&points[i - 1..=i]))
            };
            let (k, ms) = match ipm_of(n) {
                Some(k) if k > 0 => {
                    per_ipm.push((n, t / f64::from(k)));
                    (k.to_string(), format!("{:.2}", 1e3 * t / f64::from(k)))
                }
                _ => (String::new(), String::new()),
            };
            println!(
                "| {n} | {t:.4} | {:.1} | {local} | {k} | {ms} |",
                1e6 * t / n
            );
        }
        println!(
            "fitted exponent (log-log least squares over T_w = {}..{}): {:.2}",
            points[0].0,
            points[points.len() - 1].0,
            loglog_slope(&points)
        );
        if per_ipm.len() == points.len() {
            println!(
                "fitted exponent of the time per interior-point iteration: {:.2}",
                loglog_slope(&per_ipm)
            );
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    plan_default(&mut c);
    default_mission_plan(&mut c);
    sca_reuse(&mut c);
    sca_settings(&mut c);
    scaling(&mut c);
    c.final_summary();
    summary();
}
