//! `plan_with_stop`: a stop flag set from outside ends a plan as its time limit would.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicBool, Ordering};

use planner::{
    plan_with_stop, IterationRecord, LandmarksSpec, Mission, MissionFile, NoObserver, Observer,
    ParamsOverride, PlanError, PlanOptions, Preset, Scheme, TerminationReason,
};

/// The default mission cut to 60 s.
fn short_mission() -> Mission {
    Mission::from_file_struct(&MissionFile {
        name: None,
        params: ParamsOverride {
            horizon_s: Some(60.0),
            ..Default::default()
        },
        landmarks: LandmarksSpec {
            preset: Some(Preset::Default),
            spacing_m: Some(30.0),
            ..Default::default()
        },
    })
    .unwrap()
}

/// Sets the flag at the first iteration, as a host's interrupt handler would.
struct StopAtFirst<'a>(&'a AtomicBool, usize);

impl Observer for StopAtFirst<'_> {
    fn on_iteration(&mut self, _record: &IterationRecord) {
        self.1 += 1;
        self.0.store(true, Ordering::Relaxed);
    }
}

#[test]
fn a_stop_during_the_iterations_returns_the_last_accepted_iterate() {
    let m = short_mission();
    let options = PlanOptions {
        ..PlanOptions::for_scheme(Scheme::Paper)
    };
    let unstopped = planner::plan(&m, &options).unwrap();
    assert!(unstopped.iterations > 2, "{}", unstopped.iterations);
    let stop = AtomicBool::new(false);
    let mut observer = StopAtFirst(&stop, 0);
    let r = plan_with_stop(&m, &options, &mut observer, &stop).unwrap();
    assert_eq!(r.termination, TerminationReason::TimeLimit);
    assert_eq!(r.iterations, 1);
    assert_eq!(observer.1, 1);
}

#[test]
fn a_stop_before_the_start_ends_at_once() {
    let m = short_mission();
    let stop = AtomicBool::new(true);
    match plan_with_stop(&m, &PlanOptions::least_energy(), &mut NoObserver, &stop) {
        Err(PlanError::TimeLimit { iterations, .. }) => assert_eq!(iterations, 0),
        Ok(r) => {
            assert_eq!(r.termination, TerminationReason::TimeLimit);
            assert_eq!(r.iterations, 0);
        }
        Err(e) => panic!("unexpected error {e}"),
    }
}

#[test]
fn an_unset_flag_changes_nothing() {
    let m = short_mission();
    let stop = AtomicBool::new(false);
    let with_flag =
        plan_with_stop(&m, &PlanOptions::least_energy(), &mut NoObserver, &stop).unwrap();
    let plain = planner::plan(&m, &PlanOptions::least_energy()).unwrap();
    assert_eq!(with_flag.trajectory, plain.trajectory);
    assert_eq!(with_flag.evaluation.energy_j, plain.evaluation.energy_j);
}
