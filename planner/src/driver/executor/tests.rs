//! The executor on a test scheme: one file, one row of rules. The scheme minimises
//! f(x) = (x − 3)² on the real line from x = 0 by a damped Newton step, clipped to the trust
//! radius; its "exact evaluation" carries f in `energy_j` and x in `length_m`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::*;
use crate::driver::options::Deadline;
use crate::driver::progress::MAX_REJECTS;
use crate::driver::NoObserver;
use crate::evaluate::Violations;

/// What the test scheme does at each proposal.
#[derive(Clone, Copy, PartialEq)]
enum Proposes {
    /// x + damping (3 − x), clipped to the trust radius.
    Newton { damping: f64 },
    /// x − 10 (uphill from x ≤ 3, clipped or not).
    Uphill,
    /// A failed cone program.
    Fails,
    /// A Newton step (damping 1) at the first proposal, failures after it.
    OnceThenFails,
}

struct TestScheme {
    proposes: Proposes,
    /// Stop with [`Stop::Goal`] once x passes this.
    goal_x: Option<f64>,
    /// Every control the executor proposed with.
    controls: Vec<Control>,
    programs: usize,
}

impl TestScheme {
    fn new(proposes: Proposes) -> Self {
        Self {
            proposes,
            goal_x: None,
            controls: Vec::new(),
            programs: 0,
        }
    }
}

fn judged(x: f64) -> Evaluation {
    Evaluation {
        slots: Vec::new(),
        energy_j: (x - 3.0).powi(2),
        violations: Violations::default(),
        min_speed_mps: 0.0,
        max_speed_mps: 0.0,
        length_m: x,
        slots_out_of_view: 0,
        slots_unresolved: 0,
        slots_blind: 0,
        max_accel_mps2: 0.0,
        accel_limit_mps2: 0.0,
        max_jerk_mps3: 0.0,
        jerk_limit_mps3: None,
        start_altitude_m: 0.0,
    }
}

impl Step for TestScheme {
    type Iterate = f64;

    fn evaluate(&self, x: &f64) -> Result<Evaluation, PlanError> {
        Ok(judged(*x))
    }

    fn propose(&mut self, x: &f64, control: Control) -> Result<Candidate<f64>, Failure> {
        self.controls.push(control);
        self.programs += 1;
        let step = match self.proposes {
            Proposes::Newton { damping } => damping * (3.0 - x),
            Proposes::OnceThenFails if self.programs == 1 => 3.0 - x,
            Proposes::Uphill => -10.0,
            Proposes::Fails | Proposes::OnceThenFails => {
                return Err(Failure::Solver(SolveError::Setup("test".into())))
            }
        };
        let step = control.trust_radius_m.map_or(step, |r| step.clamp(-r, r));
        let next = x + step;
        Ok(Candidate {
            iterate: next,
            evaluation: judged(next),
            objective: (next - 3.0).powi(2),
            ipm_iterations: 1,
        })
    }

    fn merit(&self, ev: &Evaluation) -> f64 {
        ev.energy_j
    }

    fn admissible(&self, _candidate: &Evaluation, _current: &Evaluation) -> bool {
        true
    }

    fn review(&mut self, accepted: bool, _candidate: &Evaluation, current: &Evaluation) -> Review {
        match self.goal_x {
            Some(g) if accepted && current.length_m > g => Review::Stop(Stop::Goal),
            _ => Review::Continue,
        }
    }

    fn cone_programs(&self) -> usize {
        self.programs
    }
}

/// The test scheme's row.
fn rules() -> Rules {
    Rules {
        max_iterations: 50,
        tolerance: 1e-6,
        measure: Measure::Merit,
        acceptance: Acceptance::Descent,
        centre: None,
        trust: TrustRule::Counted,
        failure: FailureRule::Shorten {
            error_before_progress: true,
        },
        stall: None,
        records: true,
        numbered_before: 0,
    }
}

const FREE: Control = Control {
    trust_radius_m: None,
    kappa_scale: 1.0,
};

fn run(
    scheme: &mut TestScheme,
    rules: &Rules,
    flag: &AtomicBool,
) -> Result<Outcome<f64>, PlanError> {
    let deadline = Deadline::after(Instant::now(), None, Some(flag));
    execute(
        scheme,
        0.0,
        rules,
        FREE,
        LoopEnd::starting(f64::NAN),
        &mut NoObserver,
        deadline,
    )
}

#[test]
fn a_test_scheme_converges_to_its_minimum_with_every_step_recorded() {
    let mut scheme = TestScheme::new(Proposes::Newton { damping: 0.5 });
    let out = run(&mut scheme, &rules(), &AtomicBool::new(false)).unwrap();
    assert_eq!(out.stop, Stop::Converged);
    // every step halves the distance, so f falls by 3/4 a step (a relative change of 0.75) until
    // it is under the 1e-12 guard of the relative change; the loop converges there
    assert!((out.iterate - 3.0).abs() < 1e-5, "{}", out.iterate);
    assert_eq!(out.end.records.len(), out.last_iteration);
    assert!(out.end.records.iter().all(|r| r.accepted));
    assert_eq!(out.end.objective_history.len(), out.end.records.len());
    assert_eq!(out.end.cone_programs, scheme.programs);
    assert_eq!(out.end.termination, TerminationReason::Converged);
}

#[test]
fn rejected_steps_halve_the_trust_radius_until_the_loop_gives_up() {
    let mut scheme = TestScheme::new(Proposes::Uphill);
    let out = run(&mut scheme, &rules(), &AtomicBool::new(false)).unwrap();
    assert_eq!(out.stop, Stop::NoProgress);
    assert_eq!(out.iterate, 0.0, "the start stands");
    assert_eq!(out.last_iteration, MAX_REJECTS + 1);
    let radii: Vec<_> = scheme.controls.iter().map(|c| c.trust_radius_m).collect();
    assert_eq!(radii[..4], [None, Some(2.0), Some(1.0), Some(0.5)]);
    assert!(out.end.records.iter().all(|r| !r.accepted));
    assert!(out.end.objective_history.is_empty());
}

#[test]
fn a_shortened_step_is_accepted_and_the_radius_grows_again() {
    // from 0, damping 2.5 overshoots to 7.5 (f = 20.25 > 9): rejected; at radius 2, x = 2
    // (f = 1): accepted, the radius grows to 8; from 2 the step 2.5 to 4.5 (f = 2.25): rejected
    let mut scheme = TestScheme::new(Proposes::Newton { damping: 2.5 });
    let rules = Rules {
        max_iterations: 3,
        ..rules()
    };
    let out = run(&mut scheme, &rules, &AtomicBool::new(false)).unwrap();
    let radii: Vec<_> = scheme.controls.iter().map(|c| c.trust_radius_m).collect();
    assert_eq!(radii, [None, Some(2.0), Some(8.0)]);
    let accepted: Vec<_> = out.end.records.iter().map(|r| r.accepted).collect();
    assert_eq!(accepted, [false, true, false]);
    assert_eq!(out.stop, Stop::MaxIterations);
    assert_eq!(out.iterate, 2.0);
}

#[test]
fn the_deadline_stops_the_loop_before_any_program() {
    let mut scheme = TestScheme::new(Proposes::Newton { damping: 0.5 });
    let out = run(&mut scheme, &rules(), &AtomicBool::new(true)).unwrap();
    assert_eq!(out.stop, Stop::TimeLimit);
    assert_eq!(scheme.programs, 0);
    assert_eq!(out.last_iteration, 0);
    assert_eq!(out.end.termination, TerminationReason::TimeLimit);
}

#[test]
fn failures_follow_the_rows_failure_rule() {
    let flag = AtomicBool::new(false);
    // shorten: the loop's error once the trust region gives up before any progress
    let mut scheme = TestScheme::new(Proposes::Fails);
    match run(&mut scheme, &rules(), &flag) {
        Err(PlanError::Solver { iteration, .. }) => assert_eq!(iteration, MAX_REJECTS + 1),
        other => panic!("{:?}", other.map(|o| o.stop)),
    }
    // …and a stop (the accepted iterate stands) after progress
    let mut scheme = TestScheme::new(Proposes::OnceThenFails);
    let out = run(&mut scheme, &rules(), &flag).unwrap();
    assert!(
        matches!(out.stop, Stop::SubproblemFailed(_)),
        "{:?}",
        out.stop
    );
    assert_eq!(out.iterate, 3.0);
    assert_eq!(
        out.end.records.len(),
        MAX_REJECTS + 2,
        "failures are recorded"
    );
    // stop: the first failure is the error before progress
    let stop_rules = Rules {
        failure: FailureRule::Stop,
        ..rules()
    };
    let mut scheme = TestScheme::new(Proposes::Fails);
    match run(&mut scheme, &stop_rules, &flag) {
        Err(PlanError::Solver { iteration, .. }) => assert_eq!(iteration, 1),
        other => panic!("{:?}", other.map(|o| o.stop)),
    }
    // proven centre: an optimistic scale is restored once, then the failure is the error
    let centre_rules = Rules {
        failure: FailureRule::ProvenCentre,
        ..rules()
    };
    let mut scheme = TestScheme::new(Proposes::Fails);
    let deadline = Deadline::after(Instant::now(), None, Some(&flag));
    let optimistic = Control {
        trust_radius_m: None,
        kappa_scale: 0.25,
    };
    let out = execute(
        &mut scheme,
        0.0,
        &centre_rules,
        optimistic,
        LoopEnd::starting(f64::NAN),
        &mut NoObserver,
        deadline,
    );
    assert!(matches!(out, Err(PlanError::Solver { iteration: 0, .. })));
    let scales: Vec<_> = scheme.controls.iter().map(|c| c.kappa_scale).collect();
    assert_eq!(scales, [0.25, 1.0]);
}

#[test]
fn an_optimistic_centre_is_restored_before_the_trust_region_shortens() {
    let mut scheme = TestScheme::new(Proposes::Uphill);
    let rules = Rules {
        max_iterations: 4,
        centre: Some(CentreRule {
            accept_factor: 0.5,
            floor: 0.125,
            reject_factor: 2.0,
        }),
        ..rules()
    };
    let deadline = Deadline::after(Instant::now(), None, None);
    let start = Control {
        trust_radius_m: None,
        kappa_scale: 0.25,
    };
    let out = execute(
        &mut scheme,
        0.0,
        &rules,
        start,
        LoopEnd::starting(f64::NAN),
        &mut NoObserver,
        deadline,
    )
    .unwrap();
    let seen: Vec<_> = scheme
        .controls
        .iter()
        .map(|c| (c.kappa_scale, c.trust_radius_m))
        .collect();
    assert_eq!(
        seen,
        [(0.25, None), (0.5, None), (1.0, None), (1.0, Some(2.0))]
    );
    assert_eq!(out.stop, Stop::MaxIterations);
}

#[test]
fn every_candidate_is_accepted_by_block_coordinate_descent() {
    let mut scheme = TestScheme::new(Proposes::Uphill);
    let rules = Rules {
        max_iterations: 3,
        acceptance: Acceptance::Every,
        measure: Measure::Objective,
        trust: TrustRule::Off,
        ..rules()
    };
    let out = run(&mut scheme, &rules, &AtomicBool::new(false)).unwrap();
    assert_eq!(out.iterate, -30.0);
    assert!(out.end.records.iter().all(|r| r.accepted));
    assert_eq!(out.end.objective_history.len(), 3);
    assert!(scheme.controls.iter().all(|c| c.trust_radius_m.is_none()));
}

#[test]
fn the_scheme_may_stop_the_loop_at_its_goal() {
    let mut scheme = TestScheme::new(Proposes::Newton { damping: 0.5 });
    scheme.goal_x = Some(2.0);
    let out = run(&mut scheme, &rules(), &AtomicBool::new(false)).unwrap();
    assert_eq!(out.stop, Stop::Goal);
    assert_eq!(out.iterate, 2.25, "0 → 1.5 → 2.25");
    assert_eq!(out.last_iteration, 2);
    assert_eq!(out.end.termination, TerminationReason::Converged);
}

#[test]
fn a_best_effort_stops_when_its_merit_stalls() {
    // damping 0.001: f falls by about 0.2 % a step, under 1 % over 5 steps
    let mut scheme = TestScheme::new(Proposes::Newton { damping: 0.001 });
    let rules = Rules {
        stall: Some(StallRule {
            steps: 5,
            rel: 1e-2,
        }),
        ..rules()
    };
    let out = run(&mut scheme, &rules, &AtomicBool::new(false)).unwrap();
    assert_eq!(out.stop, Stop::Converged);
    assert_eq!(out.last_iteration, 5);
}

#[test]
fn records_continue_the_numbering_of_an_earlier_loop() {
    let mut scheme = TestScheme::new(Proposes::Newton { damping: 0.5 });
    let rules = Rules {
        max_iterations: 2,
        numbered_before: 7,
        ..rules()
    };
    let out = run(&mut scheme, &rules, &AtomicBool::new(false)).unwrap();
    let numbers: Vec<_> = out.end.records.iter().map(|r| r.iteration).collect();
    assert_eq!(numbers, [8, 9]);
    assert_eq!(out.last_iteration, 9);
}
