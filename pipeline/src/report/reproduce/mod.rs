//! `reproduce`: every figure and table of the paper's Section IV as CSV + SVG, and `REPORT.md`
//! with the headline numbers. Plans run in parallel (rayon) behind a progress bar.

mod figures;

use planner::summary::CsvNum;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::Value;

use super::{create_dir, write_file, ReportError};
use planner::evaluate::ResolutionMode;
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

/// Every plan by key (`group/scheme`), with its mission.
type Results = BTreeMap<String, (Mission, Outcome)>;

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

/// Writes a table of numbers as CSV: the header, then each row, numbers as
/// [`planner::summary::CsvNum`] prints them.
pub(crate) fn csv_write<H: AsRef<str>>(
    path: &Path,
    header: &[H],
    rows: &[Vec<f64>],
) -> Result<(), ReportError> {
    let encode = |e: csv::Error| ReportError::Encode {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let mut w = csv::Writer::from_writer(Vec::with_capacity(32 * rows.len() * 4));
    w.write_record(header.iter().map(|h| h.as_ref()))
        .map_err(encode)?;
    for r in rows {
        w.write_record(r.iter().map(|v| CsvNum(*v).to_string()))
            .map_err(encode)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| encode(csv::Error::from(e.into_error())))?;
    // headers and numbers are ASCII, so nothing is replaced
    write_file(path, &String::from_utf8_lossy(&bytes))
}

/// The start of `missions/default-30m-far-start.toml`: the default mission's start moved to the
/// far end of the heading arc that keeps the general bistatic resolution cell within d_min
/// (docs/user-guide.md, "Resolution: paper or general"), m.
pub const FAR_START_M: [f64; 2] = [342.0, 940.0];

pub(crate) const SCHEMES: [Scheme; 4] = [
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

/// The plans every selected figure needs; each group also gets an `exact` plan under the
/// general resolution cell (its energy cost, erratum 12 (docs/paper-notes.md)).
fn plan_jobs(figs: &FigureSet, realisations: u64) -> Result<Vec<Job>, ReportError> {
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
        // the energy cost of the general 2-D resolution cell (erratum 12 (docs/paper-notes.md))
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
    Ok(jobs)
}

/// Runs the plans in parallel behind a progress bar.
fn run_jobs(jobs: &[Job]) -> Results {
    let pb = ProgressBar::new(jobs.len() as u64);
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} plans [{elapsed}<{eta}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let results: Mutex<BTreeMap<String, (Mission, Outcome)>> = Mutex::new(BTreeMap::new());
    jobs.par_iter().for_each(|job| {
        // the paper's vehicle model for every scheme, as the paper's figures
        let options = PlanOptions {
            scheme: job.scheme,
            resolution: job.resolution,
            dynamics: planner::Dynamics::Paper,
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
    results.into_inner().unwrap_or_default()
}

/// The table of every plan for `REPORT.md`, and `plans.json`.
fn plans_table(out: &Path, results: &Results) -> Result<String, ReportError> {
    let get =
        |key: &str| -> Option<&PlanResult> { results.get(key).and_then(|(_, o)| o.as_ref().ok()) };
    let mut table = String::new();
    let _ = writeln!(
    table,
    "| plan | scheme | true energy (J) | own objective | saving vs baseline | saving vs baseline-exact | feasible | sensing viol. (m) | azimuth speed short. (m/s) | unresolved / blind slots (general cell) | iterations | time (s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
);
    let mut summary_rows = Vec::new();
    for (key, (mission, outcome)) in results {
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
    Ok(table)
}

/// The headline numbers, the cost of the general resolution cell and the power model.
fn headline(report: &mut String, results: &Results, model: &PowerModel) {
    let get =
        |key: &str| -> Option<&PlanResult> { results.get(key).and_then(|(_, o)| o.as_ref().ok()) };
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
        "\n### The general resolution cell (errata 11–12 (docs/paper-notes.md))\n"
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
                "- {g}: `exact` with the paper's resolution leaves {} of its landmark slots unresolved ({} blind) under the general cell; with `--resolution general` {} ({} blind), at {:.0} J ({:+.1}% energy).",
                x.evaluation.slots_unresolved,
                x.evaluation.slots_blind,
                gen.evaluation.slots_unresolved,
                gen.evaluation.slots_blind,
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
    let (v_star, p_star) = model.min_power(50.0);
    let (v_me, _) = model.min_energy_per_metre(50.0);
    let _ = writeln!(
    report,
    "- Power model (Table II): least power {p_star:.2} W at {v_star:.2} m/s (the paper's text says ≈ 35 m/s, erratum 4 (docs/paper-notes.md)), least energy per metre at {v_me:.2} m/s, hover {:.1} W; floor T·P(V*) = {:.0} J for T = 300 s.\n",
    model.hover_w(),
    300.0 * p_star
);
}

/// Runs the selected figures into `out`; returns the path of `REPORT.md`.
pub fn reproduce(out: &Path, quick: bool, figs: &FigureSet) -> Result<PathBuf, ReportError> {
    create_dir(out)?;
    let started = Instant::now();
    let realisations: u64 = if quick { 3 } else { 20 };
    let jobs = plan_jobs(figs, realisations)?;
    let results = run_jobs(&jobs);
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
    let table = plans_table(out, &results)?;
    let model = PowerModel::new(&Params::default());
    headline(&mut report, &results, &model);
    let mut run = figures::FigureRun {
        out,
        quick,
        realisations,
        results: &results,
        model,
        report,
        produced: Vec::new(),
    };
    for (figure, draw) in figures::FIGURES {
        if figs.has(figure) {
            draw(&mut run)?;
        }
    }
    let (mut report, produced) = (run.report, run.produced);

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
        let options = planner::PlanOptions {
            resolution: ResolutionMode::Paper,
            ..Default::default()
        };
        let r = planner::plan(&m, &options).unwrap();
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
