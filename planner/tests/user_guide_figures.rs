//! The figures of the user guide's walk-through ("Plan your own mission in ten minutes"), tied
//! to the runs that make them, as `paper_notes_figures.rs` ties the paper notes' figures
//! (`figures/mod.rs` reads them out of the text).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use planner::{plan, Mission, MissionFile, PlanOptions};

mod figures;
use figures::*;

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
