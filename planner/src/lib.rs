//! # cellsar planner
//!
//! Least-energy trajectory planning for a cellular-connected rotary-wing UAV that forms a
//! bistatic SAR with its serving base station (Hu, Yuan, Ni, Wang, IEEE Trans. Commun.),
//! with the corrections of `SPEC.md` §4.
//!
//! Layers, bottom up:
//! - models: [`params`], [`landmarks`], [`mission`], [`power`], [`geometry`], [`dmin`];
//! - exact-geometry evaluation of any trajectory: [`evaluate()`];
//! - trajectories and their files: [`trajectory`];
//! - the convex machinery: [`socp`] (Clarabel), [`schemes`] (the subproblems), [`init`]
//!   (pre-check and start), [`driver`] (the iteration loop: [`plan`]).

pub mod dmin;
pub mod driver;
pub mod evaluate;
pub mod geometry;
pub mod init;
pub mod landmarks;
pub mod mission;
pub mod params;
pub mod power;
pub mod report;
pub mod schemes;
#[cfg(feature = "service")]
pub mod service;
pub mod socp;
pub mod trajectory;

pub use driver::{
    plan, plan_with_observer, IterationRecord, NoObserver, Observer, PlanError, PlanOptions,
    PlanResult, Scheme, TerminationReason,
};
pub use evaluate::{evaluate, Evaluation, SlotEval, Violations};
pub use landmarks::{LandmarkWindow, LandmarksSpec, Preset, Schedule};
pub use mission::{Mission, MissionError, MissionFile};
pub use params::{ParamError, Params, ParamsOverride};
pub use power::PowerModel;
pub use trajectory::{Trajectory, TrajectoryError};

/// The message of `error` followed by each cause in its `source()` chain that the message
/// does not already contain, joined by ": ".
///
/// Many error types here include their source in their own message (so that `to_string()`
/// alone, as sent in a service's error reply, is complete) and also expose it as `source()`;
/// printing the chain with `{:#}` would then name the same cause twice. Binaries print errors
/// through this function so that each cause appears once.
pub fn error_chain(error: &(dyn std::error::Error + 'static)) -> String {
    let mut msg = error.to_string();
    let mut cause = error.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
        cause = c.source();
    }
    msg
}

#[cfg(test)]
mod error_chain_tests {
    use super::error_chain;

    #[derive(Debug, thiserror::Error)]
    #[error("reading {path}: {source}")]
    struct Outer {
        path: String,
        #[source]
        source: std::io::Error,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("cannot plan")]
    struct Terse {
        #[source]
        source: Outer,
    }

    #[test]
    fn each_cause_is_named_once() {
        let inner = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let outer = Outer {
            path: "m.toml".into(),
            source: inner,
        };
        assert_eq!(error_chain(&outer), "reading m.toml: no such file");
        let terse = Terse { source: outer };
        assert_eq!(
            error_chain(&terse),
            "cannot plan: reading m.toml: no such file"
        );
        let any = anyhow::Error::new(terse).context("plan service");
        assert_eq!(
            error_chain(any.as_ref()),
            "plan service: cannot plan: reading m.toml: no such file"
        );
    }
}
