//! Every figure that docs/paper-notes.md quotes about a plan, tied to the run that makes it.
//!
//! Each test plans what the notes name (the same mission file, scheme, resolution and vehicle
//! model as the command the text gives) and reads the quoted figure out of the notes by the
//! text around it: a pattern in which `{}` stands for the figure and `#` for any other number.
//! The figure must agree with the plan to the digits it is quoted with (half a unit of its last
//! digit). A failure names the command and prints the value to write, so that a change of the
//! planner that moves a figure is a one-line change of the notes.
//!
//! The notes' timings are not figures of a plan: they live in BENCHMARKS.md. The user guide's
//! walk-through ("Plan your own mission in ten minutes") is checked the same way. Most figures
//! are of plans with the paper's dynamics (`--dynamics paper`, as `reproduce` plans); those of
//! the vehicle model (the default of `exact`) are named so in their test.
//!
//! `cargo test -p planner --test paper_notes_figures`: about 2 CPU-minutes in the debug build
//! (5 minutes on a loaded 2-core machine); `-- --include-ignored` adds five best-effort plans.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use planner::evaluate::ResolutionMode;
use planner::{plan, Dynamics, Mission, MissionFile, PlanOptions, PlanResult, Scheme};

const NOTES: &str = "docs/paper-notes.md";

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the workspace root")
        .to_path_buf()
}

const GUIDE: &str = "docs/user-guide.md";

/// The text of `doc` (NOTES or GUIDE) with every run of white space made one space: line
/// breaks are where the text wraps, and patterns are written with single spaces.
fn text_of(doc: &str) -> &'static str {
    static NOTES_TEXT: OnceLock<String> = OnceLock::new();
    static GUIDE_TEXT: OnceLock<String> = OnceLock::new();
    let cell = if doc == NOTES {
        &NOTES_TEXT
    } else {
        &GUIDE_TEXT
    };
    cell.get_or_init(|| {
        let text = std::fs::read_to_string(repo().join(doc)).expect(doc);
        text.split_whitespace().collect::<Vec<_>>().join(" ")
    })
}

fn mission(file: &str) -> Mission {
    Mission::from_path(&repo().join("missions").join(file)).expect(file)
}

/// `file` with its `[params]` changed by `edit`.
fn mission_with(file: &str, edit: impl FnOnce(&mut MissionFile)) -> Mission {
    let text = std::fs::read_to_string(repo().join("missions").join(file)).expect(file);
    let mut f = MissionFile::from_toml_str(&text).expect(file);
    edit(&mut f);
    Mission::from_file_struct(&f).expect(file)
}

/// The options of `cellsar-planner plan --scheme S --resolution R --dynamics D` (and of
/// `cellsar-planner reproduce`, which plans every scheme with the paper's dynamics).
fn options(scheme: Scheme, resolution: ResolutionMode, dynamics: Dynamics) -> PlanOptions {
    PlanOptions {
        scheme,
        resolution,
        dynamics,
        ..PlanOptions::default()
    }
}

fn run(m: &Mission, o: &PlanOptions) -> PlanResult {
    plan(m, o).unwrap_or_else(|e| panic!("{}: {e}", m.name()))
}

// ---------------------------------------------------------------------------------------------
// Reading a figure out of the text

/// A number as the notes write it: an optional minus sign, digits grouped by single spaces in
/// threes, an optional decimal part. Returns the number, its text and its length in bytes.
fn number_at(s: &str) -> Option<(f64, String, usize)> {
    let b = s.as_bytes();
    let mut i = 0;
    let mut text = String::new();
    if s.starts_with('−') {
        i += '−'.len_utf8();
        text.push('-');
    } else if s.starts_with('-') {
        i += 1;
        text.push('-');
    }
    let digits = |i: usize| b[i..].iter().take_while(|c| c.is_ascii_digit()).count();
    let n = digits(i);
    if n == 0 {
        return None;
    }
    text.push_str(&s[i..i + n]);
    i += n;
    // groups of three after a space, not followed by another digit
    while i + 4 <= b.len() && b[i] == b' ' && digits(i + 1) == 3 {
        text.push_str(&s[i + 1..i + 4]);
        i += 4;
    }
    if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
        let n = digits(i + 1);
        text.push_str(&s[i..i + 1 + n]);
        i += 1 + n;
    }
    Some((text.parse().ok()?, s[..i].to_string(), i))
}

enum Token<'a> {
    Text(&'a str),
    Figure,
    Other,
}

fn tokens(pattern: &str) -> Vec<Token<'_>> {
    let mut out = Vec::new();
    let mut rest = pattern;
    while !rest.is_empty() {
        let next = [rest.find("{}"), rest.find('#')]
            .into_iter()
            .flatten()
            .min()
            .unwrap_or(rest.len());
        if next > 0 {
            out.push(Token::Text(&rest[..next]));
            rest = &rest[next..];
        } else if let Some(r) = rest.strip_prefix("{}") {
            out.push(Token::Figure);
            rest = r;
        } else {
            out.push(Token::Other);
            rest = &rest[1..];
        }
    }
    out
}

/// The figure `pattern` marks in `text`, where the pattern matches at `start`.
fn match_at(text: &str, start: usize, pattern: &[Token]) -> Option<(f64, String)> {
    // a figure at the start of a pattern is a whole number, not the tail of one
    if start > 0
        && text[..start].ends_with(|c: char| c.is_ascii_digit())
        && !matches!(pattern.first(), Some(Token::Text(_)))
    {
        return None;
    }
    let mut at = start;
    let mut figure = None;
    for t in pattern {
        match t {
            Token::Text(s) => {
                if !text[at..].starts_with(s) {
                    return None;
                }
                at += s.len();
            }
            Token::Figure | Token::Other => {
                let (v, shown, n) = number_at(&text[at..])?;
                if matches!(t, Token::Figure) {
                    figure = Some((v, shown));
                }
                at += n;
            }
        }
    }
    figure
}

/// The figure the notes quote where `pattern` matches (exactly once): its value and its text.
fn quoted(pattern: &str) -> Result<(f64, String), String> {
    quoted_in(NOTES, pattern)
}

/// The figure `doc` quotes where `pattern` matches (exactly once).
fn quoted_in(doc: &str, pattern: &str) -> Result<(f64, String), String> {
    let text = text_of(doc);
    let toks = tokens(pattern);
    let hits: Vec<_> = text
        .char_indices()
        .filter_map(|(i, _)| match_at(text, i, &toks))
        .collect();
    match hits.as_slice() {
        [one] => Ok(one.clone()),
        [] => Err(format!(
            "{doc}: no text matches `{pattern}` (its figure was moved or reworded: update \
             this test's pattern)"
        )),
        many => Err(format!(
            "{doc}: `{pattern}` matches {} times; make it unique",
            many.len()
        )),
    }
}

/// `value` written with `decimals` decimals, grouped in threes by spaces when `grouped`.
fn shown(value: f64, decimals: usize, grouped: bool) -> String {
    let s = format!("{:.*}", decimals, value.abs());
    let (int, frac) = s.split_once('.').map_or((s.as_str(), ""), |(i, f)| (i, f));
    let mut out = String::new();
    for (k, c) in int.chars().enumerate() {
        if grouped && k > 0 && (int.len() - k) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    if !frac.is_empty() {
        out.push('.');
        out.push_str(frac);
    }
    if value < 0.0 && out.chars().any(|c| c != '0' && c != '.' && c != ' ') {
        out.insert(0, '−');
    }
    out
}

/// Checks the figures of one run: each `(pattern, value)` against the notes. `command` is
/// what makes the run, for the message.
fn check(command: &str, figures: &[(&str, f64)]) {
    check_in(NOTES, command, figures);
}

/// [`check`] against `doc`.
fn check_in(doc: &str, command: &str, figures: &[(&str, f64)]) {
    let mut failures = Vec::new();
    for &(pattern, value) in figures {
        match quoted_in(doc, pattern) {
            Err(e) => failures.push(e),
            Ok((q, text)) => {
                let decimals = text.split_once('.').map_or(0, |(_, f)| f.len());
                let half_unit = 0.5 * 10f64.powi(-(decimals as i32));
                if (value - q).abs() > half_unit * (1.0 + 1e-9) {
                    failures.push(format!(
                        "{doc} quotes {text} at `{pattern}`; `{command}` gives {value}: \
                         write {}",
                        shown(value, decimals, text.contains(' '))
                    ));
                }
            }
        }
    }
    for f in &failures {
        eprintln!("{f}");
    }
    assert!(
        failures.is_empty(),
        "{} figure(s) differ from the run:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

fn pct_saving(e: f64, against: f64) -> f64 {
    100.0 * (1.0 - e / against)
}

// ---------------------------------------------------------------------------------------------
// The runs

struct Group {
    exact: PlanResult,
    paper: PlanResult,
    baseline: PlanResult,
    baseline_exact: PlanResult,
}

/// The four schemes on a default mission as `reproduce` plans them: the paper's resolution and
/// the paper's dynamics.
fn group(file: &str) -> Group {
    let m = mission(file);
    let o = |s| options(s, ResolutionMode::Paper, Dynamics::Paper);
    Group {
        exact: run(&m, &o(Scheme::Exact)),
        paper: run(&m, &o(Scheme::Paper)),
        baseline: run(&m, &o(Scheme::Baseline)),
        baseline_exact: run(&m, &o(Scheme::BaselineExact)),
    }
}

fn default_30() -> &'static Group {
    static G: OnceLock<Group> = OnceLock::new();
    G.get_or_init(|| group("default-30m.toml"))
}

fn default_200() -> &'static Group {
    static G: OnceLock<Group> = OnceLock::new();
    G.get_or_init(|| group("default-200m.toml"))
}

fn largest_miss_m(r: &PlanResult) -> f64 {
    r.evaluation.violations.sensing_m
}

#[test]
fn spacing_table_and_erratum_3() {
    let cmd = "cellsar-planner plan missions/default-30m.toml --scheme S --resolution paper --dynamics paper";
    let g = default_30();
    check(
        cmd,
        &[
            (
                "| 30 m spacing | {} J (the floor) |",
                g.exact.evaluation.energy_j,
            ),
            (
                "| 30 m spacing | # J (the floor) | {} J / # J |",
                g.paper.evaluation.energy_j,
            ),
            (
                "| 30 m spacing | # J (the floor) | # J / {} J |",
                g.paper.objective,
            ),
            ("at 30 m spacing its objective is {} J", g.paper.objective),
            (
                "at 30 m spacing its objective is # J, its true energy {} J",
                g.paper.evaluation.energy_j,
            ),
            (
                "its true energy # J, and {} of 600 slots are out of view",
                g.paper.evaluation.slots_out_of_view as f64,
            ),
            ("(largest miss {} m); at 200 m", largest_miss_m(&g.paper)),
        ],
    );
    let cmd = "cellsar-planner plan missions/default-200m.toml --scheme S --resolution paper --dynamics paper";
    let g = default_200();
    check(
        cmd,
        &[
            (
                "| 200 m spacing | {} J (floor + # %) |",
                g.exact.evaluation.energy_j,
            ),
            (
                "| 200 m spacing | # J (floor + # %) | {} J / # J |",
                g.paper.evaluation.energy_j,
            ),
            (
                "| 200 m spacing | # J (floor + # %) | # J / {} J |",
                g.paper.objective,
            ),
            ("at 200 m, {} J against", g.paper.objective),
            ("at 200 m, # J against {} J", g.paper.evaluation.energy_j),
            (
                "at 200 m, # J against # J, {} slots out of view",
                g.paper.evaluation.slots_out_of_view as f64,
            ),
            (
                "slots out of view (largest miss {} m). Only",
                largest_miss_m(&g.paper),
            ),
        ],
    );
}

#[test]
fn baseline_savings_table() {
    for (file, row, g) in [
        ("default-30m.toml", "| 30 m |", default_30()),
        ("default-200m.toml", "| 200 m |", default_200()),
    ] {
        let cmd = format!(
            "cellsar-planner plan missions/{file} --scheme S --resolution paper --dynamics paper"
        );
        let (e, p, b, be) = (
            g.exact.evaluation.energy_j,
            g.paper.evaluation.energy_j,
            g.baseline.evaluation.energy_j,
            g.baseline_exact.evaluation.energy_j,
        );
        let pats: Vec<(String, f64)> = vec![
            (format!("{row} {{}} J (# slots out of view) |"), b),
            (
                format!("{row} # J ({{}} slots out of view) |"),
                g.baseline.evaluation.slots_out_of_view as f64,
            ),
            (format!("{row} # J (# slots out of view) | {{}} J |"), be),
            (
                format!("{row} # J (# slots out of view) | # J | {{}} % / # % |"),
                pct_saving(e, b),
            ),
            (
                format!("{row} # J (# slots out of view) | # J | # % / {{}} % |"),
                pct_saving(e, be),
            ),
            (
                format!("{row} # J (# slots out of view) | # J | # % / # % | {{}} % |"),
                pct_saving(p, b),
            ),
        ];
        let figs: Vec<(&str, f64)> = pats.iter().map(|(s, v)| (s.as_str(), *v)).collect();
        check(&cmd, &figs);
    }
}

#[test]
fn square_loop_at_two_altitudes() {
    let e = |h: f64| {
        let m = mission_with("square-h1200.toml", |f| f.params.altitude_m = Some(h));
        run(
            &m,
            &options(Scheme::Exact, ResolutionMode::Paper, Dynamics::Paper),
        )
        .evaluation
        .energy_j
    };
    let (low, high) = (e(1000.0), e(1200.0));
    check(
        "cellsar-planner plan missions/square-h1200.toml --resolution paper --dynamics paper \
         (and with altitude_m = 1000)",
        &[
            ("at the floor of a 600 s mission, {} J; at 1200 m", low),
            ("at 1200 m it costs {} J, # % more", high),
            (
                "at 1200 m it costs # J, {} % more",
                100.0 * (high / low - 1.0),
            ),
        ],
    );
}

/// Fig. 11: every one of the 20 random realisations at the floor.
#[test]
fn random_realisations_reach_the_floor() {
    let energies: Vec<f64> = (0..20)
        .map(|seed| {
            let m = mission_with("default-30m.toml", |f| {
                f.landmarks.preset = Some(planner::Preset::Random);
                f.landmarks.spacing_m = Some(100.0);
                f.landmarks.seed = Some(seed);
            });
            run(
                &m,
                &options(Scheme::Exact, ResolutionMode::Paper, Dynamics::Paper),
            )
            .evaluation
            .energy_j
        })
        .collect();
    let pattern = "every realisation reaches the floor (mean {} J)";
    let figures: Vec<(&str, f64)> = energies.iter().map(|&e| (pattern, e)).collect();
    check(
        "cellsar-planner reproduce --only 11 (preset random, spacing 100 m, seeds 0-19, \
         --resolution paper --dynamics paper)",
        &figures,
    );
}

/// The general cell along the least-energy plan of the default 30 m mission (erratum 11 and
/// "Other claims").
#[test]
fn general_cell_along_the_least_energy_plan() {
    let ev = &default_30().exact.evaluation;
    let mut ratio: Vec<f64> = ev
        .slots
        .iter()
        .map(|s| s.range_resolution_general_m / s.range_resolution_paper_m)
        .collect();
    ratio.sort_by(f64::total_cmp);
    check(
        "cellsar-planner plan missions/default-30m.toml --resolution paper --dynamics paper",
        &[
            ("the general value is {}–# times the paper's", ratio[0]),
            (
                "the general value is #–{} times the paper's",
                ratio[ratio.len() - 1],
            ),
            (
                "times the paper's, {} times at the median",
                ratio[ratio.len() / 2],
            ),
            (
                "default 30 m `exact` plan, {} of the 600 landmark slots",
                ev.slots_unresolved as f64,
            ),
            (
                "of the 600 landmark slots have a resolution cell wider than $d_{\\min}$, {} of \
                 them in blind geometry",
                ev.slots_blind as f64,
            ),
        ],
    );
}

/// Erratum 12: no strict general plan of the default mission is found (exit 5, or a certified
/// refusal); the best effort from the far start resolves every slot.
#[test]
fn general_plans_of_erratum_12() {
    let m = mission("default-30m.toml");
    let refused_at = |d| {
        let o = PlanOptions {
            strict_resolution: true,
            ..options(Scheme::Exact, ResolutionMode::General, d)
        };
        match plan(&m, &o) {
            Err(planner::PlanError::Infeasible(i)) => i.slot as f64,
            Err(planner::PlanError::NotFound(i)) => i.slot as f64,
            other => panic!(
                "a strict general plan of the default mission: {:?}",
                other.map(|r| r.evaluation.energy_j)
            ),
        }
    };
    check(
        "cellsar-planner plan missions/default-30m.toml --strict-resolution [--dynamics paper]",
        &[
            (
                "impossible) naming slot {} under the default vehicle limits",
                refused_at(Dynamics::Vehicle),
            ),
            (
                "and slot {} with `--dynamics paper`",
                refused_at(Dynamics::Paper),
            ),
        ],
    );
    let far = mission("default-30m-far-start.toml");
    let best = |d| run(&far, &options(Scheme::Exact, ResolutionMode::General, d));
    let least = |d| run(&far, &options(Scheme::Exact, ResolutionMode::Paper, d));
    let (bv, bp) = (best(Dynamics::Vehicle), best(Dynamics::Paper));
    let (lv, lp) = (least(Dynamics::Vehicle), least(Dynamics::Paper));
    assert_eq!(bv.evaluation.slots_unresolved, 0, "vehicle best effort");
    assert_eq!(bp.evaluation.slots_unresolved, 0, "paper-model best effort");
    let pct = |b: &PlanResult, l: &PlanResult| {
        100.0 * (b.evaluation.energy_j / l.evaluation.energy_j - 1.0)
    };
    check(
        "cellsar-planner plan missions/default-30m-far-start.toml [--resolution paper] \
         [--dynamics paper]",
        &[
            (
                "resolves every slot at {} J, # % above the",
                bv.evaluation.energy_j,
            ),
            ("resolves every slot at # J, {} % above the", pct(&bv, &lv)),
            (
                "% above the {} J that the paper's criterion needs from the same start",
                lv.evaluation.energy_j,
            ),
            (
                "and at {} J, # %, under the paper's model",
                bp.evaluation.energy_j,
            ),
            ("and at # J, {} %, under the paper's model", pct(&bp, &lp)),
        ],
    );
}

/// `exact` started from the `paper` and the `baseline-exact` plans of the 200 m mission
/// returns to the energy of its own start.
#[test]
fn exact_from_other_starts_at_200_m() {
    let g = default_200();
    let m = mission("default-200m.toml");
    let from = |init: &PlanResult| {
        let o = PlanOptions {
            init: Some(init.trajectory.clone()),
            ..options(Scheme::Exact, ResolutionMode::Paper, Dynamics::Paper)
        };
        run(&m, &o).evaluation.energy_j
    };
    let own = g.exact.evaluation.energy_j;
    let gap = (from(&g.paper) - own)
        .abs()
        .max((from(&g.baseline_exact) - own).abs());
    let (within, text) = quoted("`exact` returns to the same energy within {} J").unwrap();
    assert!(
        gap <= within,
        "{NOTES} says `exact` from the `paper` and `baseline-exact` plans returns to its energy \
         within {text} J; `cellsar-planner plan missions/default-200m.toml --dynamics paper \
         --resolution paper --init CSV` lands {gap:.2} J away"
    );
}

/// Erratum 5: what altitude can buy (the `exact` scheme's default vehicle model).
#[test]
fn altitude_of_erratum_5() {
    use planner::evaluate::evaluate_with_altitudes;
    let fixed = |file: &str| run(&mission(file), &PlanOptions::least_energy());
    let (f30, f200) = (fixed("default-30m.toml"), fixed("default-200m.toml"));
    let m = mission("default-30m.toml");
    let p = m.params();
    let floor =
        m.slots() as f64 * p.slot_s * planner::PowerModel::new(p).min_power(p.max_speed_mps).1;
    let (within, text) = quoted("is at that floor to {} J").unwrap();
    assert!(
        (f30.evaluation.energy_j - floor).abs() <= within,
        "{NOTES}: the least-energy plan of the default 30 m mission is at the floor to {text} J; \
         `cellsar-planner plan missions/default-30m.toml --resolution paper` gives {} J against \
         {floor} J",
        f30.evaluation.energy_j
    );
    // the 30 m plan's track, descending at the mission's descent limit to 900 m
    let mut free = p.clone();
    free.altitude = planner::AltitudeMode::Free;
    free.min_altitude_m = Some(900.0);
    free.max_altitude_m = Some(free.altitude_m);
    let fm = m.with_params(free).unwrap();
    let step = fm.params().max_descent_mps * fm.params().slot_s;
    let profile: Vec<f64> = (1..=fm.slots())
        .map(|t| (fm.params().altitude_m - step * t as f64).max(900.0))
        .collect();
    let descended = evaluate_with_altitudes(&fm, &f30.trajectory, &profile).unwrap();
    let (j30, j200) = (
        free_plan("default-30m.toml", true),
        free_plan("default-200m.toml", true),
    );
    let (lo30, hi30) = altitude_range(&j30);
    let (lo200, hi200) = altitude_range(&j200);
    let (e30, e200) = (f30.evaluation.energy_j, f200.evaluation.energy_j);
    let (g30, g200) = (j30.evaluation.energy_j, j200.evaluation.energy_j);
    check(
        "cargo run --release -p planner --example free_altitude -- MISSION.toml 600 1200 paper \
         (and altitude_profiles)",
        &[
            (
                "no plan at any altitudes costs less than $T\\min_VP(V)$ = {} J",
                floor,
            ),
            (
                "that of the 200 m mission is {} J, # J (# %) above it",
                e200,
            ),
            (
                "that of the 200 m mission is # J, {} J (# %) above it",
                e200 - floor,
            ),
            (
                "that of the 200 m mission is # J, # J ({} %) above it",
                100.0 * (e200 / floor - 1.0),
            ),
            (
                "descending at 1 m/s to 900 m leaves {} of the 30 m mission's landmark slots",
                descended.slots_out_of_view as f64,
            ),
            ("| default 30 m, paper | {} J |", e30),
            ("| default 30 m, paper | # J | {} J |", g30),
            ("| default 30 m, paper | # J | # J | {}–# m |", lo30),
            ("| default 30 m, paper | # J | # J | #–{} m |", hi30),
            ("| default 200 m, paper | {} J |", e200),
            ("| default 200 m, paper | # J | {} J (", g200),
            (
                "| default 200 m, paper | # J | # J ({} J, # %) |",
                g200 - e200,
            ),
            (
                "| default 200 m, paper | # J | # J (# J, {} %) |",
                100.0 * (g200 / e200 - 1.0),
            ),
            (
                "| default 200 m, paper | # J | # J (# J, # %) | {}–# m |",
                lo200,
            ),
            (
                "| default 200 m, paper | # J | # J (# J, # %) | #–{} m |",
                hi200,
            ),
            (
                "the 200 m mission's gains {} J of the # J to the floor",
                e200 - g200,
            ),
            (
                "the 200 m mission's gains # J of the {} J to the floor",
                e200 - floor,
            ),
            ("to the floor by descending to {} m", lo200),
        ],
    );
}

/// `exact` of `file` with its altitude free within 600–1200 m, for the paper's resolution
/// (`paper`) or the best effort, as `free_altitude` plans it.
fn free_plan(file: &str, paper: bool) -> PlanResult {
    let m = mission_with(file, |f| {
        f.params.altitude = Some(planner::AltitudeMode::Free);
        f.params.min_altitude_m = Some(600.0);
        f.params.max_altitude_m = Some(1200.0);
    });
    let o = PlanOptions {
        altitude_profile: true,
        resolution: if paper {
            ResolutionMode::Paper
        } else {
            ResolutionMode::General
        },
        ..PlanOptions::default()
    };
    run(&m, &o)
}

fn altitude_range(r: &PlanResult) -> (f64, f64) {
    let z = r.evaluation.slots.iter().map(|s| s.z_m);
    (
        z.clone().fold(f64::INFINITY, f64::min),
        z.fold(f64::NEG_INFINITY, f64::max),
    )
}

/// The best efforts the notes quote: erratum 5's table (fixed and free altitude, vehicle
/// dynamics) and the acceleration the paper's model asks for (The schemes).
#[test]
#[ignore = "five best-effort plans, several minutes in a debug build: run with --ignored (or --release)"]
fn best_efforts() {
    let fixed = |file: &str| run(&mission(file), &PlanOptions::default());
    let (f30, f200) = (fixed("default-30m.toml"), fixed("default-200m.toml"));
    let (j30, j200) = (
        free_plan("default-30m.toml", false),
        free_plan("default-200m.toml", false),
    );
    let (lo30, hi30) = altitude_range(&j30);
    let (lo200, hi200) = altitude_range(&j200);
    assert!(
        (j200.evaluation.energy_j - f200.evaluation.energy_j).abs() < 0.05 && lo200 == hi200,
        "{NOTES}: the free best effort of the 200 m mission is the fixed plan (\"unchanged\", \
         1000 m); it is {} J within {lo200}–{hi200} m",
        j200.evaluation.energy_j
    );
    let row30 = "| default 30 m, general (best effort) |";
    let row200 = "| default 200 m, general (best effort) |";
    let p30 = format!("{row30} {{}} J, # slots unresolved |");
    let s30 = format!("{row30} # J, {{}} slots unresolved |");
    let q30 = format!("{row30} # J, # slots unresolved | {{}} J, # unresolved");
    let t30 = format!("{row30} # J, # slots unresolved | # J, {{}} unresolved");
    let l30 = "(less deficit in all) | {}–# m |";
    let h30 = "(less deficit in all) | #–{} m |";
    let p200 = format!("{row200} {{}} J, # slots unresolved |");
    let s200 = format!("{row200} # J, {{}} slots unresolved |");
    let h200 = format!("{row200} # J, # slots unresolved | unchanged | {{}} m |");
    check(
        "cargo run --release -p planner --example free_altitude -- MISSION.toml 600 1200",
        &[
            (&p30, f30.evaluation.energy_j),
            (&s30, f30.evaluation.slots_unresolved as f64),
            (&q30, j30.evaluation.energy_j),
            (&t30, j30.evaluation.slots_unresolved as f64),
            (l30, lo30),
            (h30, hi30),
            (&p200, f200.evaluation.energy_j),
            (&s200, f200.evaluation.slots_unresolved as f64),
            (&h200, hi200),
        ],
    );
    let paper = run(
        &mission("default-30m.toml"),
        &options(Scheme::Exact, ResolutionMode::General, Dynamics::Paper),
    );
    let peak = paper.evaluation.max_accel_mps2;
    check(
        "cellsar-planner plan missions/default-30m.toml --dynamics paper",
        &[
            ("best effort peaks at about {} m/s²", peak),
            ("m/s², {} g)", peak / 9.80665),
        ],
    );
}

/// The user guide's "Plan your own mission in ten minutes": the mission it saves as
/// `corner.toml` (read out of the guide), planned as each step says. These are plans for the
/// vehicle (the default of `exact`).
#[test]
fn user_guide_street_corner() {
    let guide = std::fs::read_to_string(repo().join(GUIDE)).expect(GUIDE);
    let toml = guide
        .split_once("Save as `corner.toml`:")
        .and_then(|(_, rest)| rest.split_once("```toml\n"))
        .and_then(|(_, rest)| rest.split_once("```"))
        .map(|(toml, _)| toml)
        .expect("the user guide's corner.toml");
    let file = MissionFile::from_toml_str(toml).expect("corner.toml");
    let m = Mission::from_file_struct(&file).unwrap();
    let best = run(&m, &PlanOptions::default());
    let least = run(&m, &PlanOptions::least_energy());
    let (b, l) = (&best.evaluation, &least.evaluation);
    let gap_pct = |r: &planner::PlanResult| {
        r.bound
            .expect("every plan carries its bound")
            .gap_pct(r.evaluation.energy_j)
    };
    let windows = |e: &planner::Evaluation| {
        planner::shortfall::ResolutionShortfall::new(&m, e).unresolved_windows as f64
    };
    let strict = PlanOptions {
        strict_resolution: true,
        ..PlanOptions::default()
    };
    let refused_at = match plan(&m, &strict) {
        Err(planner::PlanError::NotFound(i)) => i.slot as f64,
        other => panic!(
            "a strict general plan of corner.toml: {:?}",
            other.map(|r| r.evaluation.energy_j)
        ),
    };
    let mut east = file.clone();
    east.params.start_m = Some([1000.0, 0.0]);
    let east = run(
        &Mission::from_file_struct(&east).unwrap(),
        &PlanOptions::default(),
    );
    let largest = |e: &planner::Evaluation| {
        e.slots
            .iter()
            .filter(|s| s.landmark_m.is_some())
            .map(|s| s.worst_width_m)
            .fold(0.0, f64::max)
    };
    let extra = 100.0 * (b.energy_j / l.energy_j - 1.0);
    let own = "own objective # J (energy model";
    let b1 = format!(
        "street corner: scheme exact, true energy {{}} J (lower bound # J, gap # %), {own}"
    );
    let b2 = format!(
        "street corner: scheme exact, true energy # J (lower bound # J, gap {{}} %), {own}"
    );
    check_in(
        GUIDE,
        "cellsar-planner plan corner.toml [--resolution paper | --strict-resolution] (start_m \
         [1000, 0] for step 4)",
        &[
            (&b1, b.energy_j),
            (&b2, gap_pct(&best)),
            ("own objective {} J (energy model", best.objective),
            ("resolution deficit), {} iterations", best.iterations as f64),
            ("speeds #..{} m/s resolution (best effort)", b.max_speed_mps),
            ("resolution (best effort): {} of # windows", windows(b)),
            (
                "resolution (best effort): # of # windows and {} landmark slots",
                b.slots_unresolved as f64,
            ),
            ("the least-energy plan: {} windows, # slots", windows(l)),
            (
                "the least-energy plan: # windows, {} slots at",
                l.slots_unresolved as f64,
            ),
            ("(this plan +{}%)", extra),
            ("in {} of the 5 windows, all but", 5.0 - windows(b)),
            (
                "windows, all but {} of its 100 slots",
                b.slots_unresolved as f64,
            ),
            ("for {} % more energy than the least-energy plan", extra),
            ("'slots_unresolved_general': {},", b.slots_unresolved as f64),
            ("'slots_blind': {},", b.slots_blind as f64),
            ("'max_worst_width_m': {}...", largest(b)),
            ("true energy {} J (lower bound # J, gap # %), own objective # J, # iterations (converged)", l.energy_j),
            ("true energy # J (lower bound # J, gap {} %), own objective # J, # iterations (converged)", gap_pct(&least)),
            (
                "own objective {} J, # iterations (converged)",
                least.objective,
            ),
            (
                "own objective # J, {} iterations (converged)",
                least.iterations as f64,
            ),
            (
                "but {} of its 100 landmark slots",
                l.slots_unresolved as f64,
            ),
            (
                "have a cell wider than $d_{\\min}$, {} of them blind",
                l.slots_blind as f64,
            ),
            ("finds no plan (exit 5, naming slot {}, t =", refused_at),
            ("the plan costs the floor, {} J", east.evaluation.energy_j),
            ("its largest worst width is {} m", largest(&east.evaluation)),
        ],
    );
    assert_eq!(
        east.evaluation.slots_unresolved, 0,
        "step 4: every slot resolved"
    );
}
