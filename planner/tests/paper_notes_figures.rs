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
//! walk-through ("Plan your own mission in ten minutes") is checked the same way, in
//! `user_guide_figures.rs`; the reading of figures is `figures/mod.rs`. Most figures
//! are of plans with the paper's dynamics (`--dynamics paper`, as `reproduce` plans); those of
//! the vehicle model (the default of `exact`) are named so in their test.
//!
//! `cargo test -p planner --test paper_notes_figures`: about 2 CPU-minutes in the debug build
//! (5 minutes on a loaded 2-core machine); `-- --include-ignored` adds five best-effort plans.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::OnceLock;

use planner::evaluate::ResolutionMode;
use planner::{plan, Dynamics, PlanOptions, PlanResult, Scheme};

mod figures;
use figures::*;

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
