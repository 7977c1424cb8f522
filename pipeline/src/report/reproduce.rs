//! `reproduce`: every figure and table of the paper's Section IV as CSV + SVG, and `REPORT.md`
//! with the headline numbers. Plans run in parallel (rayon) behind a progress bar.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::Value;

use super::plot::{line_plot, trajectory_plot, Series, TrackStyle};
use super::{circle_slots, create_dir, write_file, ReportError};
use planner::dmin::{expected_dmin_m, expected_dmin_monte_carlo_m, CdfForm};
use planner::evaluate::ResolutionMode;
use planner::geometry::range_resolution_paper_m;
use planner::landmarks::{LandmarksSpec, Preset};
use planner::mission::MissionFile;
use planner::params::ParamsOverride;
use planner::power::PowerModel;
use planner::Summary;
use planner::{plan, Mission, Params, PlanOptions, PlanResult, Scheme};

/// A figure or table of the paper's Section IV.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Figure {
    /// E\[d_min\] vs R.
    F4a,
    /// Convergence.
    F4b,
    /// Power vs speed.
    F4c,
    /// Energy per slot, default mission.
    F5,
    /// Trajectories, 30 m.
    F6,
    /// Trajectories, 200 m.
    F7,
    /// Staircase.
    F8,
    /// Square, H = 1000 and 1200 m.
    F9,
    /// Energy per slot, staircase and square.
    F10,
    /// Random spacing, 20 realisations.
    F11,
    /// Bandwidth 50 and 100 MHz.
    F12,
    /// Table III.
    T3,
}

impl Figure {
    /// All figures, in order.
    pub const ALL: [Figure; 12] = [
        Figure::F4a,
        Figure::F4b,
        Figure::F4c,
        Figure::F5,
        Figure::F6,
        Figure::F7,
        Figure::F8,
        Figure::F9,
        Figure::F10,
        Figure::F11,
        Figure::F12,
        Figure::T3,
    ];

    /// The short name used by `--only`.
    pub fn key(self) -> &'static str {
        match self {
            Figure::F4a => "4a",
            Figure::F4b => "4b",
            Figure::F4c => "4c",
            Figure::F5 => "5",
            Figure::F6 => "6",
            Figure::F7 => "7",
            Figure::F8 => "8",
            Figure::F9 => "9",
            Figure::F10 => "10",
            Figure::F11 => "11",
            Figure::F12 => "12",
            Figure::T3 => "t3",
        }
    }
}

/// The figures to produce.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FigureSet(BTreeSet<Figure>);

impl FigureSet {
    /// All figures.
    pub fn all() -> Self {
        Self(Figure::ALL.into_iter().collect())
    }

    /// Parses `--only` keys (empty = all); unknown keys are an error naming them.
    pub fn parse(keys: &[String]) -> Result<Self, String> {
        if keys.is_empty() {
            return Ok(Self::all());
        }
        let mut set = BTreeSet::new();
        for k in keys {
            let k = k.trim().to_ascii_lowercase();
            let f = Figure::ALL
                .into_iter()
                .find(|f| f.key() == k.trim_start_matches("fig"))
                .ok_or_else(|| {
                    format!(
                        "--only: unknown figure `{k}`; expected some of {}",
                        Figure::ALL.map(Figure::key).join(",")
                    )
                })?;
            set.insert(f);
        }
        Ok(Self(set))
    }

    /// Whether `f` is selected.
    pub fn has(&self, f: Figure) -> bool {
        self.0.contains(&f)
    }
}

/// One planning job.
#[derive(Debug, Clone)]
struct Job {
    key: String,
    mission: Mission,
    scheme: Scheme,
    resolution: ResolutionMode,
}

type Outcome = Result<PlanResult, String>;

fn mission_of(
    preset: Preset,
    spacing_m: f64,
    seed: u64,
    params: ParamsOverride,
) -> Result<Mission, ReportError> {
    let file = MissionFile {
        name: None,
        params,
        landmarks: LandmarksSpec {
            preset: Some(preset),
            spacing_m: Some(spacing_m),
            seed: Some(seed),
            ..Default::default()
        },
    };
    Mission::from_file_struct(&file).map_err(ReportError::from)
}

fn csv_write(path: &Path, header: &str, rows: &[Vec<f64>]) -> Result<(), ReportError> {
    let mut s = String::with_capacity(32 * rows.len() * 4 + header.len());
    s.push_str(header);
    s.push('\n');
    for r in rows {
        let line: Vec<String> = r.iter().map(|v| format!("{v}")).collect();
        s.push_str(&line.join(","));
        s.push('\n');
    }
    write_file(path, &s.replace("NaN", "nan"))
}

/// The start of `missions/default-30m-far-start.toml`: the default mission's start moved to the
/// far end of the heading arc that keeps the general bistatic resolution cell within d_min
/// (README, "Resolution"), m.
pub const FAR_START_M: [f64; 2] = [342.0, 940.0];

const SCHEMES: [Scheme; 4] = [
    Scheme::Exact,
    Scheme::Paper,
    Scheme::Baseline,
    Scheme::BaselineExact,
];

/// The resolution requirement a plan key names (`…/exact-general` plans keep the general
/// cell, every other the paper's).
fn resolution_of_key(key: &str) -> ResolutionMode {
    if key.ends_with("/exact-general") {
        ResolutionMode::General
    } else {
        ResolutionMode::Paper
    }
}

/// One row of `plans.json`: the plan's key in the report (`plan`: the group, e.g. `random-7`
/// or `bandwidth-50`, and `/` the scheme, as in the report's table), its resolution
/// requirement, then either the plan's [`Summary`] fields or `error` for a plan that failed.
fn plan_row(key: &str, resolution: ResolutionMode, outcome: Result<&Summary, &String>) -> Value {
    let mut row = serde_json::Map::new();
    row.insert("plan".into(), Value::from(key));
    row.insert("resolution".into(), Value::from(resolution.name()));
    match outcome {
        Ok(s) => {
            if let Ok(Value::Object(fields)) = serde_json::to_value(s) {
                row.extend(fields);
            }
        }
        Err(e) => {
            let scheme = key.rsplit_once('/').map_or("", |(_, l)| l);
            let scheme = scheme.strip_suffix("-general").unwrap_or(scheme);
            row.insert("scheme".into(), Value::from(scheme));
            row.insert("error".into(), Value::from(e.as_str()));
        }
    }
    Value::Object(row)
}

/// Runs the selected figures into `out`; returns the path of `REPORT.md`.
pub fn reproduce(out: &Path, quick: bool, figs: &FigureSet) -> Result<PathBuf, ReportError> {
    create_dir(out)?;
    let started = Instant::now();
    let realisations: u64 = if quick { 3 } else { 20 };

    // ---- the plans every selected figure needs
    let mut jobs: Vec<Job> = Vec::new();
    let mut add = |key: String, mission: &Mission, schemes: &[Scheme]| {
        for &s in schemes {
            jobs.push(Job {
                key: format!("{key}/{}", s.name()),
                mission: mission.clone(),
                scheme: s,
                resolution: ResolutionMode::Paper,
            });
        }
        // the energy cost of the general 2-D resolution cell (SPEC.md §4 item 12)
        jobs.push(Job {
            key: format!("{key}/exact-general"),
            mission: mission.clone(),
            scheme: Scheme::Exact,
            resolution: ResolutionMode::General,
        });
    };
    let default = |s: f64| mission_of(Preset::Default, s, 0, ParamsOverride::default());
    if [Figure::F4b, Figure::F5, Figure::F6, Figure::F7]
        .iter()
        .any(|f| figs.has(*f))
    {
        for s in [30.0, 200.0] {
            add(format!("default-{s}"), &default(s)?, &SCHEMES);
        }
        // the default mission from the far end of the heading arc that keeps the general cell
        // narrow (missions/default-30m-far-start.toml): there a general-resolution plan exists
        let far = mission_of(
            Preset::Default,
            30.0,
            0,
            ParamsOverride {
                start_m: Some(FAR_START_M),
                ..Default::default()
            },
        )?;
        add("default-30-far-start".into(), &far, &[Scheme::Exact]);
    }
    if figs.has(Figure::F8) || figs.has(Figure::F10) {
        let m = mission_of(Preset::Staircase, 30.0, 0, ParamsOverride::default())?;
        add("staircase-30".into(), &m, &SCHEMES);
    }
    if figs.has(Figure::F9) || figs.has(Figure::F10) {
        for h in [1000.0, 1200.0] {
            let m = mission_of(
                Preset::Square,
                100.0,
                0,
                ParamsOverride {
                    altitude_m: Some(h),
                    ..Default::default()
                },
            )?;
            add(format!("square-100-h{h}"), &m, &SCHEMES);
        }
    }
    if figs.has(Figure::F11) {
        for seed in 0..realisations {
            let m = mission_of(Preset::Random, 100.0, seed, ParamsOverride::default())?;
            add(format!("random-{seed}"), &m, &SCHEMES);
        }
    }
    if figs.has(Figure::F12) {
        for b in [50e6, 100e6] {
            let m = mission_of(
                Preset::Default,
                200.0,
                0,
                ParamsOverride {
                    bandwidth_hz: Some(b),
                    ..Default::default()
                },
            )?;
            add(format!("bandwidth-{}", b / 1e6), &m, &SCHEMES);
        }
    }

    // ---- run them
    let pb = ProgressBar::new(jobs.len() as u64);
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} plans [{elapsed}<{eta}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let results: Mutex<BTreeMap<String, (Mission, Outcome)>> = Mutex::new(BTreeMap::new());
    jobs.par_iter().for_each(|job| {
        let options = PlanOptions {
            scheme: job.scheme,
            resolution: job.resolution,
            ..PlanOptions::default()
        };
        let outcome = plan(&job.mission, &options).map_err(|e| e.to_string());
        if let Err(e) = &outcome {
            tracing::warn!(job = %job.key, error = %e, "plan failed");
        }
        pb.set_message(job.key.clone());
        pb.inc(1);
        if let Ok(mut map) = results.lock() {
            map.insert(job.key.clone(), (job.mission.clone(), outcome));
        }
    });
    pb.finish_and_clear();
    let results = results.into_inner().unwrap_or_default();
    let get =
        |key: &str| -> Option<&PlanResult> { results.get(key).and_then(|(_, o)| o.as_ref().ok()) };

    let mut report = String::new();
    let _ = writeln!(
        report,
        "# cellsar — reproduction of Hu et al., Section IV\n"
    );
    let _ = writeln!(
        report,
        "Generated by `cellsar-planner reproduce{}`. Every energy below is the **true** energy of the \
         trajectory on the exact geometry (true speed, heading and sensing centre); the optimiser's own \
         objective is shown beside it. Schemes: `exact` (ours, feasible on the exact geometry), `paper` \
         (Algorithm 1 as printed), `baseline` (the paper's least-distance scheme as printed), \
         `baseline-exact` (least distance on the exact geometry).\n",
        if quick { " --quick" } else { "" }
    );

    // ---- tables of all plans
    let mut table = String::new();
    let _ = writeln!(
        table,
        "| plan | scheme | true energy (J) | own objective | saving vs baseline | saving vs baseline-exact | feasible | sensing viol. (m) | azimuth speed short. (m/s) | unresolved / blind slots (general cell) | iterations | time (s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    let mut summary_rows = Vec::new();
    for (key, (mission, outcome)) in &results {
        let (group, _) = key.rsplit_once('/').unwrap_or((key.as_str(), ""));
        match outcome {
            Ok(r) => {
                let s = Summary::new(mission, r);
                let base = get(&format!("{group}/baseline")).map(|b| b.evaluation.energy_j);
                let base_x = get(&format!("{group}/baseline-exact")).map(|b| b.evaluation.energy_j);
                let saving = |b: Option<f64>| {
                    b.map_or("–".to_string(), |b| {
                        format!("{:.1}%", 100.0 * (1.0 - s.energy_j / b))
                    })
                };
                let own = s
                    .objective_j
                    .map(|v| format!("{v:.0} J"))
                    .or(s.objective_m.map(|v| format!("{v:.0} m")))
                    .unwrap_or_default();
                let label = match r.resolution {
                    ResolutionMode::General => format!("{} (general cell)", s.scheme),
                    ResolutionMode::Paper => s.scheme.to_string(),
                };
                let _ = writeln!(
                    table,
                    "| {group} | {label} | {:.0} | {own} | {} | {} | {} | {:.2} | {:.3} | {} / {} | {} | {:.2} |",
                    s.energy_j,
                    saving(base),
                    saving(base_x),
                    if s.feasible { "yes" } else { "**no**" },
                    s.max_sensing_violation_m,
                    s.max_azimuth_speed_violation_mps,
                    s.slots_unresolved_general,
                    s.slots_blind,
                    s.iterations,
                    s.solve_seconds
                );
                summary_rows.push(plan_row(key, r.resolution, Ok(&s)));
            }
            Err(e) => {
                let label = key.rsplit_once('/').map_or(key.as_str(), |(_, l)| l);
                let _ = writeln!(
                    table,
                    "| {group} | {label} | failed: {e} | | | | | | | | | |"
                );
                summary_rows.push(plan_row(key, resolution_of_key(key), Err(e)));
            }
        }
    }
    let json = serde_json::to_string_pretty(&summary_rows).map_err(|e| ReportError::Encode {
        path: out.join("plans.json").display().to_string(),
        message: e.to_string(),
    })?;
    write_file(&out.join("plans.json"), &json)?;

    // ---- headline
    let _ = writeln!(report, "## Headline\n");
    for s in [30.0, 200.0] {
        let g = format!("default-{s}");
        if let (Some(x), Some(p), Some(b), Some(bx)) = (
            get(&format!("{g}/exact")),
            get(&format!("{g}/paper")),
            get(&format!("{g}/baseline")),
            get(&format!("{g}/baseline-exact")),
        ) {
            let e = |r: &PlanResult| r.evaluation.energy_j;
            let _ = writeln!(
                report,
                "- default mission, {s} m spacing: `exact` {:.0} J ({} iterations, {:.2} s), `paper` {:.0} J true / {:.0} J own objective ({} slots out of view), `baseline` {:.0} J, `baseline-exact` {:.0} J. Saving of `exact` vs `baseline`: {:.1}%, vs `baseline-exact`: {:.1}%; of `paper` vs `baseline`: {:.1}% (the paper reports 55% at 30 m).",
                e(x), x.iterations, x.solve_seconds, e(p), p.objective, p.evaluation.slots_out_of_view,
                e(b), e(bx),
                100.0 * (1.0 - e(x) / e(b)), 100.0 * (1.0 - e(x) / e(bx)), 100.0 * (1.0 - e(p) / e(b))
            );
        }
    }
    let _ = writeln!(
        report,
        "\n### The general resolution cell (SPEC.md §4 items 11–12)\n"
    );
    let mut groups: Vec<&str> = results
        .keys()
        .filter_map(|k| k.rsplit_once('/').map(|(g, _)| g))
        .collect();
    groups.dedup();
    for g in groups {
        let paper_res = get(&format!("{g}/exact"));
        match (paper_res, results.get(&format!("{g}/exact-general"))) {
            (Some(x), Some((_, Ok(gen)))) => {
                let _ = writeln!(
                    report,
                    "- {g}: `exact` with the paper's resolution leaves {} of its landmark slots unresolved ({} blind) under the general cell; with `--resolution general` none, at {:.0} J ({:+.1}% energy).",
                    x.evaluation.slots_unresolved,
                    x.evaluation.slots_blind,
                    gen.evaluation.energy_j,
                    100.0 * (gen.evaluation.energy_j / x.evaluation.energy_j - 1.0)
                );
            }
            (Some(x), Some((_, Err(e)))) => {
                let _ = writeln!(
                    report,
                    "- {g}: `exact` with the paper's resolution leaves {} landmark slots unresolved ({} blind) under the general cell; `--resolution general` found no plan: {e}",
                    x.evaluation.slots_unresolved,
                    x.evaluation.slots_blind
                );
            }
            _ => {}
        }
    }
    let _ = writeln!(report);
    let model = PowerModel::new(&Params::default());
    let (v_star, p_star) = model.min_power(50.0);
    let (v_me, _) = model.min_energy_per_metre(50.0);
    let _ = writeln!(
        report,
        "- Power model (Table II): least power {p_star:.2} W at {v_star:.2} m/s (the paper's text says ≈ 35 m/s, SPEC.md §4 item 4), least energy per metre at {v_me:.2} m/s, hover {:.1} W; floor T·P(V*) = {:.0} J for T = 300 s.\n",
        model.hover_w(),
        300.0 * p_star
    );

    // ---- figures
    let fig_dir = |name: &str| -> Result<PathBuf, ReportError> {
        let d = out.join(name);
        create_dir(&d)?;
        Ok(d)
    };
    let mut produced: Vec<String> = Vec::new();

    if figs.has(Figure::F4a) {
        let d = fig_dir("fig4a")?;
        let mut rows = Vec::new();
        let mut series = Vec::new();
        let radii: Vec<f64> = (2..=20).map(|k| k as f64 * 500.0).collect();
        let trials = if quick { 200 } else { 1000 };
        for n in [800u64, 1000, 1200] {
            let mut c = Vec::new();
            let mut pr = Vec::new();
            let mut mc = Vec::new();
            for &r in &radii {
                let vc = expected_dmin_m(r, n, CdfForm::Correct).unwrap_or(f64::NAN);
                let vp = expected_dmin_m(r, n, CdfForm::AsPrinted).unwrap_or(f64::NAN);
                let (vm, se) = expected_dmin_monte_carlo_m(r, n, trials, n ^ (r as u64))
                    .unwrap_or((f64::NAN, f64::NAN));
                rows.push(vec![n as f64, r, vc, vp, vm, se]);
                c.push((r, vc));
                pr.push((r, vp));
                mc.push((r, vm));
            }
            // one colour per N; the style tells the formula
            let colour = Some(series.len() / 3);
            series.push(Series {
                colour,
                ..Series::line(format!("N={n} correct"), c)
            });
            series.push(Series {
                name: format!("N={n} as printed"),
                points: pr,
                markers: false,
                dashed: true,
                colour,
            });
            series.push(Series {
                name: format!("N={n} Monte Carlo"),
                points: mc,
                markers: true,
                dashed: false,
                colour,
            });
        }
        csv_write(
            &d.join("dmin.csv"),
            "objects,radius_m,correct_m,as_printed_m,monte_carlo_m,monte_carlo_se_m",
            &rows,
        )?;
        line_plot(
            &d.join("dmin.svg"),
            "Fig. 4(a): E[d_min] vs R",
            "R (m)",
            "E[d_min] (m)",
            &series,
        )?;
        let at = |form| expected_dmin_m(5000.0, 1000, form).unwrap_or(f64::NAN);
        let _ = writeln!(
            report,
            "## Fig. 4(a) — E[d_min]\n\nAt R = 5000 m, N = 1000: the formula as printed gives {:.1} m (the paper's \"≈ 20 m\"); the correct CDF gives {:.1} m, confirmed by Monte Carlo (`fig4a/dmin.csv`). d_min = 20 m is kept as the requirement (SPEC.md §4 item 1).\n",
            at(CdfForm::AsPrinted),
            at(CdfForm::Correct)
        );
        produced.push("fig4a/dmin.svg".into());
    }

    if figs.has(Figure::F4b) {
        let d = fig_dir("fig4b")?;
        let mut series = Vec::new();
        let mut rows = Vec::new();
        for s in [30.0, 200.0] {
            for scheme in [Scheme::Paper, Scheme::Exact] {
                if let Some(r) = get(&format!("default-{s}/{}", scheme.name())) {
                    for (i, (o, e)) in r
                        .objective_history
                        .iter()
                        .zip(&r.true_energy_history)
                        .enumerate()
                    {
                        rows.push(vec![
                            s,
                            if scheme == Scheme::Paper { 0.0 } else { 1.0 },
                            (i + 1) as f64,
                            *o,
                            *e,
                        ]);
                    }
                    let colour = Some(series.len() / 2);
                    series.push(Series {
                        colour,
                        name: format!("{scheme} {s} m: own objective"),
                        points: r
                            .objective_history
                            .iter()
                            .enumerate()
                            .map(|(i, v)| ((i + 1) as f64, *v))
                            .collect(),
                        markers: true,
                        dashed: false,
                    });
                    series.push(Series {
                        name: format!("{scheme} {s} m: true energy"),
                        points: r
                            .true_energy_history
                            .iter()
                            .enumerate()
                            .map(|(i, v)| ((i + 1) as f64, *v))
                            .collect(),
                        markers: false,
                        dashed: true,
                        colour,
                    });
                }
            }
        }
        csv_write(
            &d.join("convergence.csv"),
            "spacing_m,scheme_is_exact,iteration,objective_j,true_energy_j",
            &rows,
        )?;
        line_plot(
            &d.join("convergence.svg"),
            "Fig. 4(b): convergence (default mission)",
            "iteration",
            "own objective (solid) / true energy (dashed), J",
            &series,
        )?;
        let _ = writeln!(
            report,
            "## Fig. 4(b) — convergence\n\n`paper`'s own objective (p41) and the true energy of its iterates differ: the relaxations of SPEC.md §4 item 3 let the objective fall below what the trajectory really costs. `exact` iterates are feasible and their true energy decreases monotonically (`fig4b/convergence.csv`).\n"
        );
        produced.push("fig4b/convergence.svg".into());
    }

    if figs.has(Figure::F4c) {
        let d = fig_dir("fig4c")?;
        let pts: Vec<(f64, f64)> = (0..=700)
            .map(|k| {
                let v = k as f64 * 0.1;
                (v, model.power_w(v))
            })
            .collect();
        let rows: Vec<Vec<f64>> = pts
            .iter()
            .map(|(v, p)| {
                vec![
                    *v,
                    *p,
                    model.blade_w(*v),
                    model.induced_w(*v),
                    model.parasite_w(*v),
                ]
            })
            .collect();
        csv_write(
            &d.join("power.csv"),
            "speed_mps,power_w,blade_w,induced_w,parasite_w",
            &rows,
        )?;
        line_plot(
            &d.join("power.svg"),
            &format!("Fig. 4(c): propulsion power (least {p_star:.1} W at {v_star:.1} m/s)"),
            "speed (m/s)",
            "power (W)",
            &[
                Series::line("total P(V)", pts.clone()),
                Series::line("blade", rows.iter().map(|r| (r[0], r[2])).collect()),
                Series::line("induced", rows.iter().map(|r| (r[0], r[3])).collect()),
                Series::line("parasite", rows.iter().map(|r| (r[0], r[4])).collect()),
            ],
        )?;
        produced.push("fig4c/power.svg".into());
    }

    let energy_series = |group: &str, schemes: &[Scheme]| -> Vec<Series> {
        schemes
            .iter()
            .filter_map(|s| {
                get(&format!("{group}/{}", s.name())).map(|r| {
                    Series::line(
                        format!("{group} {s} ({:.0} J)", r.evaluation.energy_j),
                        r.evaluation
                            .slots
                            .iter()
                            .map(|e| (e.t_s, e.slot_energy_j))
                            .collect(),
                    )
                })
            })
            .collect()
    };
    let energy_csv = |path: &Path, groups: &[&str]| -> Result<(), ReportError> {
        let mut rows = Vec::new();
        let mut header = String::from("t_s");
        let mut cols: Vec<&PlanResult> = Vec::new();
        for g in groups {
            for s in SCHEMES {
                if let Some(r) = get(&format!("{g}/{}", s.name())) {
                    let _ = write!(header, ",{g}_{}_j", s.name());
                    cols.push(r);
                }
            }
        }
        let n = cols
            .iter()
            .map(|r| r.evaluation.slots.len())
            .max()
            .unwrap_or(0);
        for t in 0..n {
            let mut row = vec![cols
                .iter()
                .find_map(|r| r.evaluation.slots.get(t).map(|e| e.t_s))
                .unwrap_or(f64::NAN)];
            row.extend(cols.iter().map(|r| {
                r.evaluation
                    .slots
                    .get(t)
                    .map_or(f64::NAN, |e| e.slot_energy_j)
            }));
            rows.push(row);
        }
        csv_write(path, &header, &rows)
    };

    if figs.has(Figure::F5) {
        let d = fig_dir("fig5")?;
        for s in ["30", "200"] {
            let g = format!("default-{s}");
            energy_csv(&d.join(format!("energy-{s}m.csv")), &[g.as_str()])?;
            line_plot(
                &d.join(format!("energy-{s}m.svg")),
                &format!("Fig. 5: energy per slot, {s} m spacing"),
                "t (s)",
                "energy per slot (J)",
                &energy_series(&g, &SCHEMES),
            )?;
            produced.push(format!("fig5/energy-{s}m.svg"));
        }
    }

    let traj_fig = |dir: &Path,
                    file: &str,
                    title: &str,
                    group: &str,
                    schemes: &[Scheme]|
     -> Result<(), ReportError> {
        let Some((mission, _)) = results.get(&format!("{group}/{}", schemes[0].name())) else {
            return Ok(());
        };
        let circles = circle_slots(mission.slots(), 5);
        let tracks: Vec<TrackStyle<'_>> = schemes
            .iter()
            .filter_map(|s| {
                get(&format!("{group}/{}", s.name())).map(|r| TrackStyle {
                    name: s.name(),
                    traj: &r.trajectory,
                    circle_slots: &circles,
                    dashed: matches!(s, Scheme::Baseline | Scheme::BaselineExact),
                })
            })
            .collect();
        trajectory_plot(&dir.join(file), title, mission, &tracks)?;
        for s in schemes {
            if let Some(r) = get(&format!("{group}/{}", s.name())) {
                write_file(
                    &dir.join(format!("{group}-{}.csv", s.name())),
                    &planner::summary::trajectory_csv(r),
                )?;
            }
        }
        Ok(())
    };

    for (fig, s, name) in [(Figure::F6, "30", "fig6"), (Figure::F7, "200", "fig7")] {
        if figs.has(fig) {
            let d = fig_dir(name)?;
            let g = format!("default-{s}");
            traj_fig(
                &d,
                "trajectory-proposed.svg",
                &format!(
                    "Fig. {}: trajectories, {s} m spacing (proposed)",
                    &name[3..]
                ),
                &g,
                &[Scheme::Exact, Scheme::Paper],
            )?;
            traj_fig(
                &d,
                "trajectory-baseline.svg",
                &format!(
                    "Fig. {}: trajectories, {s} m spacing (baselines)",
                    &name[3..]
                ),
                &g,
                &[Scheme::Baseline, Scheme::BaselineExact],
            )?;
            produced.push(format!("{name}/trajectory-proposed.svg"));
            produced.push(format!("{name}/trajectory-baseline.svg"));
        }
    }
    if figs.has(Figure::F8) {
        let d = fig_dir("fig8")?;
        traj_fig(
            &d,
            "trajectory.svg",
            "Fig. 8: staircase, 30 m, T = 600 s",
            "staircase-30",
            &[Scheme::Exact, Scheme::Paper],
        )?;
        produced.push("fig8/trajectory.svg".into());
    }
    if figs.has(Figure::F9) {
        let d = fig_dir("fig9")?;
        traj_fig(
            &d,
            "trajectory-h1000.svg",
            "Fig. 9(a): square, 100 m, H = 1000 m",
            "square-100-h1000",
            &[Scheme::Exact, Scheme::Paper],
        )?;
        traj_fig(
            &d,
            "trajectory-h1200.svg",
            "Fig. 9(b): square, 100 m, H = 1200 m (with baselines)",
            "square-100-h1200",
            &[
                Scheme::Exact,
                Scheme::Paper,
                Scheme::Baseline,
                Scheme::BaselineExact,
            ],
        )?;
        produced.push("fig9/trajectory-h1000.svg".into());
        produced.push("fig9/trajectory-h1200.svg".into());
    }
    if figs.has(Figure::F10) {
        let d = fig_dir("fig10")?;
        let groups = ["staircase-30", "square-100-h1000", "square-100-h1200"];
        energy_csv(&d.join("energy.csv"), &groups)?;
        let mut series = energy_series("staircase-30", &[Scheme::Exact, Scheme::Paper]);
        series.extend(energy_series(
            "square-100-h1000",
            &[Scheme::Exact, Scheme::Paper],
        ));
        series.extend(energy_series(
            "square-100-h1200",
            &[Scheme::Exact, Scheme::Paper, Scheme::Baseline],
        ));
        line_plot(
            &d.join("energy.svg"),
            "Fig. 10: energy per slot, staircase and square (T = 600 s)",
            "t (s)",
            "energy per slot (J)",
            &series,
        )?;
        produced.push("fig10/energy.svg".into());
    }
    if figs.has(Figure::F11) {
        let d = fig_dir("fig11")?;
        let mut series = Vec::new();
        let mut rows: Vec<Vec<f64>> = Vec::new();
        let mut header = String::from("t_s");
        let mut line = String::new();
        for s in SCHEMES {
            let runs: Vec<&PlanResult> = (0..realisations)
                .filter_map(|k| get(&format!("random-{k}/{}", s.name())))
                .collect();
            if runs.is_empty() {
                continue;
            }
            let n = runs[0].evaluation.slots.len();
            let avg: Vec<(f64, f64)> = (0..n)
                .map(|t| {
                    let e = runs
                        .iter()
                        .filter_map(|r| r.evaluation.slots.get(t))
                        .map(|e| e.slot_energy_j)
                        .sum::<f64>()
                        / runs.len() as f64;
                    (runs[0].evaluation.slots[t].t_s, e)
                })
                .collect();
            let total = runs.iter().map(|r| r.evaluation.energy_j).sum::<f64>() / runs.len() as f64;
            let feasible = runs.iter().filter(|r| r.evaluation.is_feasible()).count();
            let _ = write!(
                line,
                "`{s}` {total:.0} J ({feasible}/{} feasible); ",
                runs.len()
            );
            let _ = write!(header, ",{}_mean_j", s.name());
            if rows.is_empty() {
                rows = avg.iter().map(|(t, _)| vec![*t]).collect();
            }
            for (row, (_, e)) in rows.iter_mut().zip(&avg) {
                row.push(*e);
            }
            series.push(Series::line(format!("{s} (mean {total:.0} J)"), avg));
        }
        csv_write(&d.join("energy-mean.csv"), &header, &rows)?;
        line_plot(
            &d.join("energy-mean.svg"),
            &format!("Fig. 11: mean energy per slot, random spacing ({realisations} realisations)"),
            "t (s)",
            "energy per slot (J)",
            &series,
        )?;
        traj_fig(
            &d,
            "trajectory-realisation0.svg",
            "Fig. 11: random spacing, realisation 0",
            "random-0",
            &SCHEMES,
        )?;
        let _ = writeln!(report, "## Fig. 11 — random spacing\n\nMean true energy over {realisations} realisations: {line}\n");
        produced.push("fig11/energy-mean.svg".into());
        produced.push("fig11/trajectory-realisation0.svg".into());
    }
    if figs.has(Figure::F12) {
        let d = fig_dir("fig12")?;
        for b in ["50", "100"] {
            traj_fig(
                &d,
                &format!("trajectory-{b}mhz.svg"),
                &format!("Fig. 12: B = {b} MHz, 200 m spacing"),
                &format!("bandwidth-{b}"),
                &SCHEMES,
            )?;
            produced.push(format!("fig12/trajectory-{b}mhz.svg"));
        }
        let _ = writeln!(report, "## Fig. 12 — bandwidth\n");
        let d_min = Params::default().d_min_m;
        let reference = get("default-200/exact");
        for b in ["50", "100"] {
            let Some(x) = get(&format!("bandwidth-{b}/exact")) else {
                continue;
            };
            // the paper's range resolution over the landmark slots of the plan
            let worst_paper_m = x
                .evaluation
                .slots
                .iter()
                .filter(|s| s.landmark_m.is_some())
                .map(|s| s.range_resolution_paper_m)
                .fold(0.0, f64::max);
            let same = reference.map(|r| {
                r.trajectory
                    .pos_m
                    .iter()
                    .zip(&x.trajectory.pos_m)
                    .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
                    .fold(0.0, f64::max)
            });
            let _ = writeln!(
                report,
                "- B = {b} MHz: `exact` {:.0} J; the paper's range resolution δ_r along the plan is at most {worst_paper_m:.2} m ≤ d_min = {d_min} m{}; under the general cell {} landmark slots are unresolved ({} blind).",
                x.evaluation.energy_j,
                same.map_or(String::new(), |d| format!(
                    "; the track differs from the 150 MHz one (Fig. 7) by at most {d:.3} m"
                )),
                x.evaluation.slots_unresolved,
                x.evaluation.slots_blind
            );
        }
        let _ = writeln!(
            report,
            "\nWith the paper's resolution model the bandwidth only enters through the range constraint, which is vacuous at 50–150 MHz with the defaults (SPEC.md §4 item 2: its right side c/(B d_min) − sin η is negative), so every scheme flies the same track at every bandwidth and Fig. 12's trajectories repeat Fig. 7's (the paper finds \"similar patterns\" to its Fig. 6). The bandwidth does matter for the true (general) bistatic cell: see \"The general resolution cell\" above and README \"Resolution\" (`--resolution general`).\n"
        );
    }
    if figs.has(Figure::T3) {
        let d = fig_dir("table3")?;
        let mut p = Params::default();
        let dist = 3f64.sqrt() * p.bs_height_m;
        let point = [p.bs_m[0] + dist, p.bs_m[1]];
        let mut rows = Vec::new();
        let _ = writeln!(report, "## Table III — range resolution at θ_t = π/3\n\n| B (MHz) | δ_r (m), ours | δ_r (m), paper |\n|---|---|---|");
        for (b, paper) in [(50e6, 3.81), (100e6, 1.91), (150e6, 1.27), (200e6, 0.95)] {
            p.bandwidth_hz = b;
            let v = range_resolution_paper_m(&p, point);
            rows.push(vec![b / 1e6, v, paper]);
            let _ = writeln!(report, "| {} | {v:.2} | {paper} |", b / 1e6);
        }
        let _ = writeln!(report, "\nThese use the paper's formula, valid only when the BS→point and UAV→point ground directions coincide (SPEC.md §4 item 11). The general value along each plan is in the `range_resolution_general_m` column of every trajectory CSV.\n");
        csv_write(
            &d.join("table3.csv"),
            "bandwidth_mhz,range_resolution_m,paper_m",
            &rows,
        )?;
        produced.push("table3/table3.csv".into());
    }

    let _ = writeln!(report, "## All plans\n\n{table}");
    let _ = writeln!(
        report,
        "\nFigures: {}\n",
        produced
            .iter()
            .map(|p| format!("`{p}`"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        report,
        "Total time {:.1} s on this machine.",
        started.elapsed().as_secs_f64()
    );
    let path = out.join("REPORT.md");
    write_file(&path, &report)?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::{plan_row, resolution_of_key, FAR_START_M};
    use planner::evaluate::ResolutionMode;

    /// Each row of plans.json names its plan (group and scheme) and its resolution, and a
    /// failed plan keeps its error instead of being left out.
    #[test]
    fn plans_json_rows_name_their_plan_and_keep_failures() {
        let key = "random-7/exact-general";
        assert_eq!(resolution_of_key(key), ResolutionMode::General);
        assert_eq!(resolution_of_key("random-7/exact"), ResolutionMode::Paper);
        let e = "mission cannot be flown: slot 3".to_string();
        let row = plan_row(key, resolution_of_key(key), Err(&e));
        assert_eq!(row["plan"], key);
        assert_eq!(row["resolution"], "general");
        assert_eq!(row["scheme"], "exact");
        assert_eq!(row["error"], e.as_str());
        let m = planner::Mission::from_file_struct(&planner::MissionFile::from_toml_str(
            "name = \"short\"\n[params]\nhorizon_s = 20\n[landmarks]\npreset = \"default\"\nspacing_m = 30\n",
        ).unwrap())
        .unwrap();
        let r = planner::plan(&m, &planner::PlanOptions::default()).unwrap();
        let s = planner::Summary::new(&m, &r);
        let row = plan_row("default-30/exact", ResolutionMode::Paper, Ok(&s));
        assert_eq!(row["plan"], "default-30/exact");
        assert_eq!(row["resolution"], "paper");
        assert_eq!(row["scheme"], "exact");
        assert_eq!(row["energy_j"].as_f64(), Some(s.energy_j));
        assert!(row.get("error").is_none());
    }

    /// The report's far-start plan is the mission file the README points to.
    #[test]
    fn far_start_is_the_mission_files() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../missions/default-30m-far-start.toml");
        let m = planner::Mission::from_path(&path).unwrap();
        assert_eq!(m.params().start_m, FAR_START_M);
        let default = super::mission_of(
            planner::Preset::Default,
            30.0,
            0,
            planner::params::ParamsOverride::default(),
        )
        .unwrap();
        assert_eq!(m.schedule(), default.schedule());
    }
}
