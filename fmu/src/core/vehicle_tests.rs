//! Unit tests of the vehicle limits through the FMU: the parameters `dynamics` and
//! `start_velocity_mps`, the outputs `commanded_accel_*`, and re-plans under the vehicle dynamics.

use super::tests::{planned, set_input, var, Collect};
use super::*;
use crate::planning::tests::{short_mission, SHORT};
use planner::evaluate::{Dynamics, ResolutionMode, ACCEL_TOL_REL};

fn run(core: &Core) -> &Run {
    let Core::Planner(c) = core else {
        panic!("not a planner")
    };
    c.run.as_ref().unwrap()
}

fn real(core: &Core, name: &str, elem: usize, tau_s: f64) -> f64 {
    core.get_real(var(PLANNER_VARS, name), elem, tau_s).unwrap()
}

/// A core planned on [`SHORT`] for the paper's resolution (the least-energy plan, fast) under
/// `dynamics`, with `setup` applied too.
fn planned_with(
    dynamics: Dynamics,
    setup: impl FnOnce(&mut Core),
) -> (Core, tempfile::TempDir, Result<(), FmuError>) {
    planned(SHORT, |c| {
        c.set_string(var(PLANNER_VARS, "resolution"), "paper")
            .unwrap();
        c.set_string(var(PLANNER_VARS, "dynamics"), dynamics.name())
            .unwrap();
        setup(c);
    })
}

/// The outputs `commanded_accel_*` at every communication point of a 0.1 s grid are the slot's
/// (v_t − v_{t−1})/δ, v_0 the start velocity in effect, computed here from the plan's
/// positions, and the magnitude is the evaluator's `accel_mps2`; returns the largest magnitude.
fn check_commanded_accel(core: &Core) -> f64 {
    let r = run(core);
    let p = r.mission.params();
    let v0 = [
        real(core, "start_velocity_mps", 0, 0.0),
        real(core, "start_velocity_mps", 1, 0.0),
    ];
    let velocity = |t: usize| {
        if t == 0 {
            return v0;
        }
        let (a, b) = (r.traj.q(t - 1), r.traj.q(t));
        [(b[0] - a[0]) / p.slot_s, (b[1] - a[1]) / p.slot_s]
    };
    let mut peak: f64 = 0.0;
    let steps = (p.horizon_s / 0.1).round() as usize;
    for i in 0..=steps {
        let tau = i as f64 * 0.1;
        let t = slot_at(tau, p.slot_s, r.mission.slots());
        let (a, b) = (velocity(t - 1), velocity(t));
        // into the first slot from the instantaneous start velocity: over half a slot
        let window = if t == 1 { 0.5 * p.slot_s } else { p.slot_s };
        let want = [(b[0] - a[0]) / window, (b[1] - a[1]) / window];
        let got = [
            real(core, "commanded_accel_x_mps2", 0, tau),
            real(core, "commanded_accel_y_mps2", 0, tau),
        ];
        for k in 0..2 {
            assert!(
                (got[k] - want[k]).abs() <= 1e-9,
                "t = {tau}: {got:?} / {want:?}"
            );
        }
        let abs = real(core, "commanded_accel_mps2", 0, tau);
        assert_eq!(abs, r.eval.slots[t - 1].accel_mps2, "t = {tau}");
        assert!((abs - got[0].hypot(got[1])).abs() <= 1e-9, "t = {tau}");
        peak = peak.max(abs);
    }
    assert_eq!(peak, r.eval.max_accel_mps2);
    peak
}

#[test]
fn dynamics_starts_at_the_library_default_and_refuses_other_names() {
    let mut core = Core::new(ModelKind::Planner);
    let dynamics = var(PLANNER_VARS, "dynamics");
    assert_eq!(
        core.get_string(dynamics).unwrap(),
        planner::DEFAULT_DYNAMICS.name()
    );
    assert_eq!(
        planner::PlanOptions::default().dynamics,
        planner::DEFAULT_DYNAMICS
    );
    let e = core.set_string(dynamics, "jerk").unwrap_err();
    assert!(
        e.message.contains("`dynamics` = \"jerk\"") && e.message.contains("paper, vehicle"),
        "{}",
        e.message
    );
    assert_eq!(
        core.get_string(dynamics).unwrap(),
        planner::DEFAULT_DYNAMICS.name()
    );
    for d in Dynamics::ALL {
        core.set_string(dynamics, d.name()).unwrap();
        assert_eq!(core.get_string(dynamics).unwrap(), d.name());
    }
}

/// [`SHORT`] with a start velocity stated in the file.
fn short_with_start_velocity(v: [f64; 2]) -> String {
    SHORT.replace(
        "horizon_s = 20",
        &format!(
            "horizon_s = 20\nstart_velocity_mps = [{:?}, {:?}]",
            v[0], v[1]
        ),
    )
}

#[test]
fn each_dynamics_plans_the_librarys_plan_and_reports_its_acceleration() {
    // a start velocity 10 degrees off the mission's rule (-8.50, 16.34) m/s: the paper's model
    // turns at once (20 m/s² into the first slot), the vehicle within the a_max δ/2 that the
    // first slot allows (15 degrees off, no plan is found: the turn needs more)
    let start = [-11.2, 14.6];
    let text = short_with_start_velocity(start);
    let mission = Mission::from_file_struct(&MissionFile::from_toml_str(&text).unwrap()).unwrap();
    let limit = mission.params().max_accel_mps2;
    let mut peaks = Vec::new();
    for dynamics in Dynamics::ALL {
        let (core, _dir, r) = planned_with(dynamics, |c| {
            for (i, x) in start.into_iter().enumerate() {
                c.set_real(var(PLANNER_VARS, "start_velocity_mps"), i, x)
                    .unwrap();
            }
        });
        r.unwrap();
        let options = planner::PlanOptions {
            resolution: ResolutionMode::Paper,
            dynamics,
            ..Default::default()
        };
        let want = planning::plan_with(&mission, None, &options).unwrap();
        assert_eq!(run(&core).traj, want.trajectory, "{dynamics}");
        assert_eq!(run(&core).dynamics, dynamics);
        let peak = check_commanded_accel(&core);
        if dynamics == Dynamics::Vehicle {
            assert!(peak <= limit * (1.0 + ACCEL_TOL_REL), "{peak} > {limit}");
        }
        peaks.push((dynamics, peak));
    }
    // the limit is what keeps the vehicle's plan within it: the paper's model exceeds it here
    let paper = peaks[0];
    assert_eq!(paper.0, Dynamics::Paper);
    assert!(paper.1 > 1.5 * limit, "{peaks:?}");
}

#[test]
fn start_velocity_is_the_missions_unless_set() {
    let rule = short_mission().start_velocity_mps();
    // not set: the mission's rule, read back after initialisation
    let (core, _dir, r) = planned_with(Dynamics::Vehicle, |c| {
        let v = var(PLANNER_VARS, "start_velocity_mps");
        assert!(c.get_real(v, 0, 0.0).unwrap().is_nan());
        assert!(c.get_real(v, 1, 0.0).unwrap().is_nan());
    });
    r.unwrap();
    let got = [
        real(&core, "start_velocity_mps", 0, 0.0),
        real(&core, "start_velocity_mps", 1, 0.0),
    ];
    assert_eq!(got, rule);
    // the mission file's value, and the FMI value over it
    let stated = short_with_start_velocity([-6.0, 12.0]);
    for (set, want) in [(None, [-6.0, 12.0]), (Some([-11.2, 14.6]), [-11.2, 14.6])] {
        let (core, _dir, r) = planned(&stated, |c| {
            c.set_string(var(PLANNER_VARS, "resolution"), "paper")
                .unwrap();
            c.set_string(var(PLANNER_VARS, "dynamics"), "vehicle")
                .unwrap();
            if let Some(v) = set {
                for (i, x) in v.into_iter().enumerate() {
                    c.set_real(var(PLANNER_VARS, "start_velocity_mps"), i, x)
                        .unwrap();
                }
            }
        });
        r.unwrap();
        let got = [
            real(&core, "start_velocity_mps", 0, 0.0),
            real(&core, "start_velocity_mps", 1, 0.0),
        ];
        assert_eq!(got, want);
        // the plan is the library's for that start velocity, and its first slot starts there
        let text = short_with_start_velocity(want);
        let mission =
            Mission::from_file_struct(&MissionFile::from_toml_str(&text).unwrap()).unwrap();
        let options = planner::PlanOptions {
            resolution: ResolutionMode::Paper,
            dynamics: Dynamics::Vehicle,
            ..Default::default()
        };
        let plan = planning::plan_with(&mission, None, &options).unwrap();
        assert_eq!(run(&core).traj, plan.trajectory);
        let limit = mission.params().max_accel_mps2;
        assert!(check_commanded_accel(&core) <= limit * (1.0 + ACCEL_TOL_REL));
    }
}

#[test]
fn bad_start_velocities_are_refused() {
    let v = var(PLANNER_VARS, "start_velocity_mps");
    let mut core = Core::new(ModelKind::Planner);
    let e = core.set_real(v, 1, f64::INFINITY).unwrap_err();
    assert!(
        e.message.contains("`start_velocity_mps[2]` = inf"),
        "{}",
        e.message
    );
    assert!(core.get_real(v, 1, 0.0).unwrap().is_nan());
    // one component only: refused at initialisation, naming the parameter
    let (core, _dir, r) = planned_with(Dynamics::Vehicle, |c| {
        c.set_real(v, 0, 5.0).unwrap();
    });
    let e = r.unwrap_err();
    assert!(
        e.message.contains("`start_velocity_mps` = (5, NaN)") && e.message.contains("both"),
        "{}",
        e.message
    );
    assert!(!core.is_ready());
    // faster than max_speed_mps: the library's check, naming the parameter
    let (_core, _dir, r) = planned_with(Dynamics::Vehicle, |c| {
        c.set_real(v, 0, 60.0).unwrap();
        c.set_real(v, 1, 0.0).unwrap();
    });
    let e = r.unwrap_err();
    assert!(
        e.message.contains("start_velocity_mps") && e.message.contains("max_speed_mps"),
        "{}",
        e.message
    );
}

#[test]
fn a_replan_under_the_vehicle_dynamics_continues_within_the_limit() {
    for dynamics in Dynamics::ALL {
        let (mut core, _dir, r) = planned_with(dynamics, |_| {});
        r.unwrap();
        let before = run(&core).traj.clone();
        let limit = run(&core).mission.params().max_accel_mps2;
        set_input(&mut core, 60.0, 40.0);
        core.step(2.5, 0.5, &Collect::default()).unwrap();
        assert_eq!(
            core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(),
            1,
            "{dynamics}"
        );
        let r = run(&core);
        assert_eq!(r.dynamics, dynamics);
        // the flown slots are kept, the rest re-planned
        assert_eq!(r.traj.pos_m[..5], before.pos_m[..5]);
        assert_ne!(r.traj.pos_m[5..], before.pos_m[5..]);
        let peak = check_commanded_accel(&core);
        if dynamics == Dynamics::Vehicle {
            assert!(
                peak <= limit * (1.0 + ACCEL_TOL_REL),
                "{peak} > {limit} after the re-plan"
            );
        }
    }
}

/// The accelerations (from the start velocity `v0`, over half a slot into the first slot) and
/// the jerks (from the second slot on: over 2δ/3 into the second, δ after) of `traj`, from its
/// positions.
fn accels_and_jerks(traj: &Trajectory, v0: [f64; 2], delta: f64) -> (Vec<f64>, Vec<f64>) {
    let velocity = |t: usize| {
        if t == 0 {
            return v0;
        }
        let (a, b) = (traj.q(t - 1), traj.q(t));
        [(b[0] - a[0]) / delta, (b[1] - a[1]) / delta]
    };
    let accel: Vec<[f64; 2]> = (1..=traj.slots())
        .map(|t| {
            let w = if t == 1 { 0.5 * delta } else { delta };
            let (a, b) = (velocity(t - 1), velocity(t));
            [(b[0] - a[0]) / w, (b[1] - a[1]) / w]
        })
        .collect();
    let jerks = accel
        .windows(2)
        .enumerate()
        .map(|(i, w)| {
            let window = if i == 0 { 2.0 * delta / 3.0 } else { delta };
            (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / window
        })
        .collect();
    (accel.iter().map(|a| a[0].hypot(a[1])).collect(), jerks)
}

/// A jerk limit and margins set through FMI: the initial plan and a re-plan after a landmark
/// move keep the acceleration within a_max less its margin and the jerk within j_max less its
/// margin over the whole track flown, the splice included (the re-plan counts its first jerk
/// from the acceleration flown), measured on the positions; the parameters read back.
#[test]
fn a_jerk_limit_and_margins_set_through_fmi_hold_across_a_replan() {
    let (mut core, _dir, r) = planned_with(Dynamics::Vehicle, |c| {
        for (name, value) in [
            ("max_jerk_mps3", 10.0),
            ("jerk_margin_pct", 20.0),
            ("accel_margin_pct", 10.0),
        ] {
            c.set_real(var(PLANNER_VARS, name), 0, value).unwrap();
        }
    });
    r.unwrap();
    assert_eq!(real(&core, "max_jerk_mps3", 0, 0.0), 10.0);
    assert_eq!(real(&core, "accel_margin_pct", 0, 0.0), 10.0);
    let check = |core: &Core| -> Vec<f64> {
        let r = run(core);
        let p = r.mission.params();
        let (accels, jerks) = accels_and_jerks(&r.traj, r.mission.start_velocity_mps(), p.slot_s);
        let (a_top, j_top) = (0.9 * p.max_accel_mps2, 8.0);
        for (t, a) in (1..).zip(&accels) {
            assert!(*a <= a_top * (1.0 + 1e-9), "slot {t}: {a} > {a_top}");
        }
        for (t, j) in (2..).zip(&jerks) {
            assert!(*j <= j_top * (1.0 + 1e-9), "slot {t}: {j} > {j_top}");
        }
        assert!(r.eval.meets(Dynamics::Vehicle));
        jerks
    };
    check(&core);
    // a move that makes the re-plan from slot 5 turn at once: its first slot, 6, is at the
    // limit from the acceleration flown into slot 5 (counted from none, it went to 9.3 m/s³)
    set_input(&mut core, 150.0, -50.0);
    core.step(2.5, 0.5, &Collect::default()).unwrap();
    assert_eq!(core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(), 1);
    let jerks = check(&core);
    assert!(jerks[6 - 2] >= 0.99 * 8.0, "{}", jerks[6 - 2]);
    // NaN is the start value (no limit); an infinite limit is refused at the set
    let mut fresh = Core::new(ModelKind::Planner);
    assert!(real(&fresh, "max_jerk_mps3", 0, 0.0).is_nan());
    let e = fresh
        .set_real(var(PLANNER_VARS, "max_jerk_mps3"), 0, f64::INFINITY)
        .unwrap_err();
    assert!(e.message.contains("max_jerk_mps3"), "{}", e.message);
}
