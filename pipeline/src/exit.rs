//! Exit codes of the `cellsar` binary, and failures that carry theirs: the codes every cellsar
//! binary shares ([`cellsar_error::exit`]).
//!
//! | code | `cellsar` |
//! |---:|---|
//! | 0 | done (`run`: the mission completed) |
//! | 1 | failure at run time (a child that keeps failing, no plan in time, I/O, Zenoh, a planner that failed) |
//! | 2 | bad input: an option, the mission or the scene file (the message names it); nothing started (or the planner refused the request as `bad_request`) |
//! | 3 | the mission cannot be flown (the message names the first slot and the reason), found before anything starts or by the planner (an `infeasible` refusal) |
//! | 4 | `run --strict`: completed, but a landmark in view was not detected |
//! | 5 | the planner found no plan that meets every constraint (none proven impossible) |
//! | 130 | interrupted (SIGINT/SIGTERM); every child stopped |

pub use cellsar_error::exit::*;

use planner::PlanError;
use radar_sim::RadarError;

/// The failure of a planning error: a mission proven infeasible exits 3, a plan not found 5, a
/// start trajectory that does not fit, a bad option or a free altitude the scheme does not
/// plan 2, a solver failure or a time limit 1 (and any later variant 1).
pub fn plan_failure(e: PlanError) -> Failure {
    let kind = match &e {
        PlanError::Infeasible(_) => FailureKind::Infeasible,
        PlanError::NotFound(_) => FailureKind::PlanNotFound,
        PlanError::InvalidInit(_)
        | PlanError::InvalidOption { .. }
        | PlanError::OptionConflict(_)
        | PlanError::AltitudeConflict { .. } => FailureKind::BadInput,
        PlanError::Solver { .. } | PlanError::TimeLimit { .. } => FailureKind::Runtime,
        _ => FailureKind::Runtime,
    };
    Failure::new(kind, e)
}

/// The failure of a radar error: bad input ([`RadarError::is_bad_input`]) exits 2, the rest 1.
pub fn radar_failure(e: RadarError) -> Failure {
    Failure::bad_input_or_runtime(e.is_bad_input(), e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn library_errors_map_to_the_documented_codes() {
        let bad_option = PlanError::InvalidOption {
            field: "tolerance",
            value: -1.0,
            reason: "must be positive",
        };
        assert_eq!(plan_failure(bad_option).exit_code(), BAD_INPUT);
        assert_eq!(
            plan_failure(PlanError::InvalidInit("x".into())).exit_code(),
            BAD_INPUT
        );
        let free = PlanError::AltitudeConflict {
            scheme: planner::Scheme::Exact,
        };
        assert_eq!(plan_failure(free).exit_code(), BAD_INPUT);
        let limit = PlanError::TimeLimit {
            limit_s: 1.0,
            iterations: 2,
            sensing_violation_m: 3.0,
        };
        assert_eq!(plan_failure(limit).exit_code(), RUNTIME);
        assert_eq!(
            radar_failure(RadarError::config("radar.prf_hz", "must be positive")).exit_code(),
            BAD_INPUT
        );
        assert_eq!(
            radar_failure(RadarError::Numerical {
                stage: "cancel".into(),
                reason: "singular".into()
            })
            .exit_code(),
            RUNTIME
        );
    }
}
