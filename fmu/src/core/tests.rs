//! Unit tests of the model cores.

use super::*;

#[test]
fn slot_convention() {
    assert_eq!(slot_at(0.0, 0.5, 600), 1);
    assert_eq!(slot_at(0.25, 0.5, 600), 1);
    assert_eq!(slot_at(0.5, 0.5, 600), 1);
    assert_eq!(slot_at(0.5000001, 0.5, 600), 2);
    assert_eq!(slot_at(10.0, 0.5, 600), 20);
    assert_eq!(slot_at(1e9, 0.5, 600), 600);
    assert_eq!(slot_at_committed(0.0, 0.5, 600), 0);
    assert_eq!(slot_at_committed(0.1, 0.5, 600), 1);
    assert_eq!(slot_at_committed(10.0, 0.5, 600), 20);
    assert_eq!(slot_at_committed(1e9, 0.5, 600), 600);
}

#[test]
fn guid_is_stable_and_distinct() {
    let a = guid(&PLANNER_INFO, FmiVersion::Fmi2);
    assert_eq!(a, guid(&PLANNER_INFO, FmiVersion::Fmi2));
    assert_ne!(a, guid(&PLANNER_INFO, FmiVersion::Fmi3));
    assert_ne!(a, guid(&MOVER_INFO, FmiVersion::Fmi2));
    assert_eq!(a.len(), 38);
}

#[test]
fn start_values_are_spec_defaults() {
    let core = Core::new(ModelKind::Planner);
    let d = Params::default();
    for v in PLANNER_VARS
        .iter()
        .filter(|v| v.causality == crate::table::Causality::Parameter && v.ty == VarType::Real)
    {
        for i in 0..v.len {
            let got = core.get_real(v, i, 0.0).unwrap();
            if v.name == "start_velocity_mps" {
                // NaN: the mission's own, the library's default
                assert!(d.start_velocity_mps.is_none());
                assert!(got.is_nan(), "{got}");
                continue;
            }
            if v.name == "max_jerk_mps3" {
                // NaN: no jerk limit, the library's default
                assert!(d.max_jerk_mps3.is_none());
                assert!(got.is_nan(), "{got}");
                continue;
            }
            if v.name == "max_extra_energy_pct" {
                // NaN: no cap, the library's default
                assert!(planner::PlanOptions::default()
                    .max_extra_energy_pct
                    .is_none());
                assert!(got.is_nan(), "{got}");
                continue;
            }
            let want = match v.name {
                "start_m" => d.start_m[i],
                "bs_m" => d.bs_m[i],
                n => d.get_by_name(n).unwrap(),
            };
            assert_eq!(got, want, "{}", v.name);
        }
    }
}

fn run_of(pos_m: Vec<[f64; 2]>) -> Run {
    let mut p = Params::default();
    p.horizon_s = pos_m.len() as f64 * p.slot_s;
    let mission = Mission::new(
        "prop",
        p.clone(),
        &planner::LandmarksSpec {
            points: Some(vec![planner::LandmarkWindow {
                x_m: 0.0,
                y_m: 0.0,
                from_s: 0.0,
                to_s: p.horizon_s,
            }]),
            ..Default::default()
        },
    )
    .unwrap();
    let traj = Trajectory {
        slot_s: p.slot_s,
        start_m: p.start_m,
        pos_m,
    };
    Run {
        eval: evaluate(&mission, &traj),
        mission,
        source: PathBuf::new(),
        traj,
        replans: 0,
        solve_s: 0.0,
        moved: BTreeSet::new(),
        dynamics: planner::DEFAULT_DYNAMICS,
        altitudes_m: None,
        bound: None,
    }
}

proptest::proptest! {
    /// Outputs between slot ends: position linear, energy = previous slots + power × time in
    /// the slot (non-decreasing, continuous), slot values at slot ends equal `evaluate`.
    #[test]
    fn samples_interpolate_and_integrate(
        steps in proptest::collection::vec((-12.0f64..12.0, -12.0f64..12.0), 1..12),
        frac in 0.0f64..1.0,
    ) {
        let mut q = Params::default().start_m;
        let pos: Vec<[f64; 2]> = steps.iter().map(|(dx, dy)| { q = [q[0] + dx, q[1] + dy]; q }).collect();
        let run = run_of(pos);
        let d = run.mission.params().slot_s;
        let n = run.eval.slots.len();
        let mut last_energy = 0.0;
        for t in 1..=n {
            let at_end = run.sample(t as f64 * d);
            let s = &run.eval.slots[t - 1];
            proptest::prop_assert_eq!(at_end.pos_m, s.pos_m);
            proptest::prop_assert!((at_end.energy_j - s.energy_j).abs() <= 1e-9 * s.energy_j.max(1.0));
            proptest::prop_assert_eq!(at_end.in_view, s.in_view);
            let tau = (t as f64 - 1.0 + frac) * d;
            let mid = run.sample(tau);
            let a = run.traj.q(t - 1);
            let b = run.traj.q(t);
            for i in 0..2 {
                proptest::prop_assert!((mid.pos_m[i] - (a[i] + frac * (b[i] - a[i]))).abs() < 1e-9);
            }
            proptest::prop_assert!(mid.energy_j + 1e-9 >= last_energy);
            proptest::prop_assert!(mid.energy_j <= at_end.energy_j + 1e-9);
            proptest::prop_assert_eq!(mid.power_w, s.power_w);
            let off = planner::geometry::distance(&mid.centre_m.into(), &mid.pos_m.into());
            proptest::prop_assert!((off - run.mission.params().centre_offset_m()).abs() < 1e-9);
            last_energy = at_end.energy_j;
        }
    }
}

#[test]
fn default_mission_resource_parses() {
    let f = MissionFile::from_toml_str(DEFAULT_MISSION_TOML).unwrap();
    let m = Mission::from_file_struct(&f).unwrap();
    assert_eq!(m.slots(), 600);
    assert_eq!(m.target_m(21), Some([0.0, 30.0]));
}

/// Collects log messages.
#[derive(Default)]
pub(super) struct Collect(pub(super) std::cell::RefCell<Vec<(Status, String)>>);

impl Log for Collect {
    fn log(&self, _category: Category, status: Status, message: &str) {
        self.0.borrow_mut().push((status, message.to_string()));
    }
}

use crate::planning::tests::{short_mission, SHORT};

pub(super) fn var(table: &'static [Var], name: &str) -> &'static Var {
    table.iter().find(|v| v.name == name).unwrap()
}

/// A planner core for `mission` (TOML text), with `setup` applied before initialisation.
pub(super) fn planned(
    mission: &str,
    setup: impl FnOnce(&mut Core),
) -> (Core, tempfile::TempDir, Result<(), FmuError>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.toml");
    std::fs::write(&path, mission).unwrap();
    let mut core = Core::new(ModelKind::Planner);
    core.set_string(var(PLANNER_VARS, "mission_file"), path.to_str().unwrap())
        .unwrap();
    setup(&mut core);
    let r = core.initialize(None, &Collect::default());
    (core, dir, r)
}

pub(super) fn set_input(core: &mut Core, x: f64, y: f64) {
    core.set_real(var(PLANNER_VARS, "landmark_x_in_m"), 0, x)
        .unwrap();
    core.set_real(var(PLANNER_VARS, "landmark_y_in_m"), 0, y)
        .unwrap();
}

fn landmarks(core: &Core) -> Vec<[f64; 2]> {
    let Core::Planner(c) = core else {
        panic!("not a planner")
    };
    let run = c.run.as_ref().unwrap();
    run.mission
        .schedule()
        .landmarks
        .iter()
        .map(|w| w.pos_m())
        .collect()
}

#[test]
fn numbers_in_messages_are_short() {
    assert_eq!(Num(-1e308).to_string(), "-1e308");
    assert_eq!(Num(1e-12).to_string(), "1e-12");
    assert_eq!(Num(0.0001).to_string(), "0.0001");
    assert_eq!(Num(0.5).to_string(), "0.5");
    assert_eq!(Num(300.0).to_string(), "300");
    assert_eq!(Num(1e15).to_string(), "1e15");
    assert_eq!(Num(f64::NAN).to_string(), "NaN");
    assert_eq!(Num(f64::NEG_INFINITY).to_string(), "-inf");
    assert_eq!(format!("{:.3}", Num(1.23456)), "1.235");
    assert_eq!(format!("{:.2}", Num(123456789e10)), "1.23e18");
}

#[test]
fn one_array_element_keeps_the_files_other_element() {
    let mission = SHORT.replace(
        "horizon_s = 20",
        "horizon_s = 20\nstart_m = [-1100.0, -450.0]\nbs_m = [10.0, 20.0]",
    );
    // FMI 2 sets start_m[2] and bs_m[1] alone; bs_m[2] is written back at its start value
    let (core, _dir, r) = planned(&mission, |c| {
        c.set_real(var(PLANNER_VARS, "start_m"), 1, -460.0).unwrap();
        c.set_real(var(PLANNER_VARS, "bs_m"), 0, 11.0).unwrap();
        c.set_real(var(PLANNER_VARS, "bs_m"), 1, Params::default().bs_m[1])
            .unwrap();
    });
    r.unwrap();
    let get = |name, i| core.get_real(var(PLANNER_VARS, name), i, 0.0).unwrap();
    assert_eq!([get("start_m", 0), get("start_m", 1)], [-1100.0, -460.0]);
    assert_eq!([get("bs_m", 0), get("bs_m", 1)], [11.0, 20.0]);
    assert_eq!([get("x_m", 0), get("y_m", 0)], [-1100.0, -460.0]);
}

#[test]
fn move_out_of_reach_warns_and_counts_slots_out_of_view() {
    let (mut core, _dir, r) = planned(SHORT, |_| {});
    r.unwrap();
    let out_of_view = |c: &Core| c.get_int(var(PLANNER_VARS, "slots_out_of_view")).unwrap();
    assert_eq!(out_of_view(&core), 0);
    set_input(&mut core, 9e4, 0.0);
    let log = Collect::default();
    let report = core.step(2.5, 0.5, &log).unwrap();
    let warning = report
        .warning
        .expect("a re-plan that drops a window must warn");
    assert!(
        warning.contains("landmark 0") && warning.contains("slots 6..20"),
        "{warning}"
    );
    assert!(log
        .0
        .borrow()
        .iter()
        .any(|(s, m)| *s == Status::Warning && *m == warning));
    // every slot of window 0 misses the moved landmark, window 1 is planned as usual
    assert_eq!(out_of_view(&core), 20);
    assert!(!core.get_bool(var(PLANNER_VARS, "in_view"), 5.0).unwrap());
    assert!(core.get_bool(var(PLANNER_VARS, "in_view"), 15.0).unwrap());
}

#[test]
fn input_at_a_window_boundary_moves_the_window_that_ends_there() {
    let (mut core, _dir, r) = planned(SHORT, |_| {});
    r.unwrap();
    // at t = 10 s the outputs show slot 20, window 0 (0, 10] s: the input moves that one
    let lx = var(PLANNER_VARS, "landmark_x_m");
    assert_eq!(core.get_real(lx, 0, 10.0).unwrap(), 0.0);
    assert_eq!(
        core.get_real(var(PLANNER_VARS, "landmark_y_m"), 0, 10.0)
            .unwrap(),
        0.0
    );
    set_input(&mut core, 40.0, 0.0);
    let report = core.step(10.0, 0.5, &Collect::default()).unwrap();
    assert_eq!(landmarks(&core), vec![[40.0, 0.0], [0.0, 30.0]]);
    // window 0 has no slot left: nothing re-planned, and the step says so
    assert!(report.warning.unwrap().contains("no slot left"));
    assert_eq!(core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(), 0);
    // the initial plan is the library's default (the general cell as a best effort)
    let resolution = var(PLANNER_VARS, "plan_resolution");
    assert_eq!(core.get_int(resolution).unwrap(), 1);
    // in the middle of window 1 the same input moves window 1 and re-plans
    core.step(10.5, 0.5, &Collect::default()).unwrap();
    assert_eq!(landmarks(&core), vec![[40.0, 0.0], [40.0, 0.0]]);
    assert_eq!(core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(), 1);
    // a re-plan is for the paper's resolution (the least-energy plan), and says so
    assert_eq!(core.get_int(resolution).unwrap(), 0);
    assert_eq!(current_window(&short_mission(), 10.0), Some(0));
}

#[test]
fn bad_landmark_inputs_are_refused() {
    let (mut core, _dir, r) = planned(SHORT, |_| {});
    r.unwrap();
    let x = var(PLANNER_VARS, "landmark_x_in_m");
    let e = core.set_real(x, 0, f64::INFINITY).unwrap_err();
    assert!(
        e.message.contains("`landmark_x_in_m` = inf"),
        "{}",
        e.message
    );
    assert!(core.get_real(x, 0, 0.0).unwrap().is_nan());
    // one coordinate NaN, the other finite: refused at the step, nothing changes
    core.set_real(x, 0, 40.0).unwrap();
    let e = core.step(2.5, 0.5, &Collect::default()).unwrap_err();
    assert!(
        e.message.contains("landmark_x_in_m") && e.message.contains("landmark_y_in_m"),
        "{}",
        e.message
    );
    assert_eq!(landmarks(&core), vec![[0.0, 0.0], [0.0, 30.0]]);
}

#[test]
fn bad_mover_values_are_refused() {
    let mut core = Core::new(ModelKind::Mover);
    let hold = var(MOVER_VARS, "hold_s");
    let e = core.set_real(hold, 0, -1.0).unwrap_err();
    assert!(e.message.contains("`hold_s` = -1"), "{}", e.message);
    assert_eq!(core.get_real(hold, 0, 0.0).unwrap(), 0.0);
    let e = core
        .set_real(var(MOVER_VARS, "landmark_y_m"), 0, f64::INFINITY)
        .unwrap_err();
    assert!(e.message.contains("landmark_y_m"), "{}", e.message);
    core.set_real(var(MOVER_VARS, "landmark_x_m"), 0, f64::NAN)
        .unwrap();
    assert!(core.step(0.0, 0.5, &Collect::default()).is_err());
}

#[test]
fn too_many_slots_are_refused_before_planning() {
    let started = std::time::Instant::now();
    let (_core, _dir, r) = planned(SHORT, |c| {
        c.set_real(var(PLANNER_VARS, "slot_s"), 0, 1e-4).unwrap();
    });
    let e = r.unwrap_err();
    assert!(
        e.message
            .contains("`horizon_s` = 20 s and `slot_s` = 0.0001 s give 200000 slots"),
        "{}",
        e.message
    );
    assert!(started.elapsed().as_secs_f64() < 5.0);
}

#[test]
fn mission_file_size_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.toml");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(MAX_MISSION_FILE_BYTES + 1).unwrap();
    let e = read_mission_text(&big).unwrap_err();
    assert!(
        e.message.contains("big.toml") && e.message.contains("limit"),
        "{e}"
    );
    // a device reports length 0: the bounded read still stops
    let e = read_mission_text(Path::new("/dev/zero")).unwrap_err();
    assert!(
        e.message.contains("/dev/zero") && e.message.contains("limit"),
        "{e}"
    );
    let ok = dir.path().join("ok.toml");
    std::fs::write(&ok, "a = 1").unwrap();
    assert_eq!(read_mission_text(&ok).unwrap(), "a = 1");
    let e = read_mission_text(&dir.path().join("none.toml")).unwrap_err();
    assert!(e.message.contains("none.toml"), "{e}");
}

#[test]
fn plan_options_start_at_the_library_defaults() {
    let core = Core::new(ModelKind::Planner);
    let d = planner::PlanOptions {
        // a free-altitude mission gets its altitudes (output `z_m`), as from cellsar-planner plan
        altitude_profile: true,
        ..Default::default()
    };
    assert_eq!(
        core.get_string(var(PLANNER_VARS, "resolution")).unwrap(),
        d.resolution.name()
    );
    assert_eq!(
        core.get_bool(var(PLANNER_VARS, "strict_resolution"), 0.0)
            .unwrap(),
        d.strict_resolution
    );
    let Core::Planner(c) = &core else {
        panic!("not a planner")
    };
    assert_eq!(c.initial.plan_options(), d);
}

#[test]
fn the_initial_plan_uses_the_resolution_parameter() {
    let mission = short_mission();
    for (name, code) in [("paper", 0), ("general", 1)] {
        let (core, _dir, r) = planned(SHORT, |c| {
            c.set_string(var(PLANNER_VARS, "resolution"), name).unwrap();
        });
        r.unwrap();
        assert_eq!(
            core.get_int(var(PLANNER_VARS, "plan_resolution")).unwrap(),
            code
        );
        let options = planner::PlanOptions {
            resolution: name.parse().unwrap(),
            ..Default::default()
        };
        let want = planning::plan_with(&mission, None, &options).unwrap();
        let Core::Planner(c) = &core else {
            panic!("not a planner")
        };
        assert_eq!(c.run.as_ref().unwrap().traj, want.trajectory, "{name}");
    }
}

#[test]
fn bad_plan_option_values_are_refused_at_the_set() {
    let mut core = Core::new(ModelKind::Planner);
    let res = var(PLANNER_VARS, "resolution");
    let e = core.set_string(res, "exact").unwrap_err();
    assert!(
        e.message.contains("`resolution` = \"exact\"") && e.message.contains("paper, general"),
        "{}",
        e.message
    );
    assert_eq!(core.get_string(res).unwrap(), "general");
    let pct = var(PLANNER_VARS, "max_extra_energy_pct");
    for bad in [-1.0, f64::INFINITY, f64::NEG_INFINITY] {
        let e = core.set_real(pct, 0, bad).unwrap_err();
        // the library's message
        let lib = planner::PlanOptions {
            max_extra_energy_pct: Some(bad),
            ..Default::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(
            e.message.contains("`max_extra_energy_pct`") && e.message.contains(&lib),
            "{} / {lib}",
            e.message
        );
        assert!(core.get_real(pct, 0, 0.0).unwrap().is_nan());
    }
    core.set_real(pct, 0, 10.0).unwrap();
    assert_eq!(core.get_real(pct, 0, 0.0).unwrap(), 10.0);
    core.set_real(pct, 0, f64::NAN).unwrap();
    assert!(core.get_real(pct, 0, 0.0).unwrap().is_nan());
}

#[test]
fn best_effort_options_under_the_paper_resolution_are_refused_at_initialisation() {
    type Setup = fn(&mut Core);
    let cases: [(Setup, planner::PlanOptions); 2] = [
        (
            |c| {
                c.set_bool(var(PLANNER_VARS, "strict_resolution"), true)
                    .unwrap()
            },
            planner::PlanOptions {
                resolution: planner::evaluate::ResolutionMode::Paper,
                strict_resolution: true,
                ..Default::default()
            },
        ),
        (
            |c| {
                c.set_real(var(PLANNER_VARS, "max_extra_energy_pct"), 0, 10.0)
                    .unwrap()
            },
            planner::PlanOptions {
                resolution: planner::evaluate::ResolutionMode::Paper,
                max_extra_energy_pct: Some(10.0),
                ..Default::default()
            },
        ),
    ];
    for (setup, options) in cases {
        let started = std::time::Instant::now();
        let (core, _dir, r) = planned(SHORT, |c| {
            c.set_string(var(PLANNER_VARS, "resolution"), "paper")
                .unwrap();
            setup(c);
        });
        let lib = options.validate().unwrap_err().to_string();
        let e = r.unwrap_err();
        assert!(e.message.contains(&lib), "{} / {lib}", e.message);
        assert!(!core.is_ready());
        // refused before planning
        assert!(started.elapsed().as_secs_f64() < 5.0);
    }
}
