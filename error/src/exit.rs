//! Exit codes shared by every cellsar binary, and a failure that carries its code.
//!
//! | code | meaning |
//! |---:|---|
//! | 0 | done |
//! | 1 | failure at run time (a solver, I/O, Zenoh, a child that keeps failing) |
//! | 2 | bad input: an option, a mission, scene or plan file (the message names it); nothing was done |
//! | 3 | the mission cannot be flown, proven (the message names the first slot and the reason) |
//! | 4 | completed, but a landmark in view was not detected (`cellsar run --strict`, `cellsar-radar-sim closed-loop`) |
//! | 5 | no plan found that meets every constraint, none proven impossible (`cellsar-planner plan` writes the best plan found, marked infeasible) |
//! | 130 | interrupted (SIGINT/SIGTERM) |
//!
//! A binary's `main` returns [`Failure::report`]'s [`std::process::ExitCode`], so that every
//! binary prints an error the same way (`error: ` and the chain of causes, each once) and maps
//! it to the same code.

use std::fmt;
use std::process::ExitCode;

/// Exit code of a failure at run time.
pub const RUNTIME: u8 = 1;
/// Exit code of bad input (an option, a mission, scene or plan file).
pub const BAD_INPUT: u8 = 2;
/// Exit code of a mission that cannot be flown.
pub const INFEASIBLE: u8 = 3;
/// Exit code of a run that completed but did not detect a landmark in view.
pub const MISSED_LANDMARK: u8 = 4;
/// Exit code of a plan that was not found (and not proven impossible).
pub const PLAN_NOT_FOUND: u8 = 5;
/// Exit code after SIGINT or SIGTERM.
pub const INTERRUPTED: u8 = 130;

/// What kind of failure ended a command; it picks the exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FailureKind {
    /// A failure at run time (exit code 1).
    Runtime,
    /// Bad input: an option, a mission, scene or plan file (exit code 2).
    BadInput,
    /// The mission cannot be flown (exit code 3).
    Infeasible,
    /// The run completed, but a landmark in view was not detected (exit code 4).
    MissedLandmark,
    /// The planner found no plan that meets every constraint, and none is proven impossible
    /// (exit code 5).
    PlanNotFound,
}

impl FailureKind {
    /// The process exit code of this kind of failure.
    pub fn exit_code(self) -> u8 {
        match self {
            FailureKind::Runtime => RUNTIME,
            FailureKind::BadInput => BAD_INPUT,
            FailureKind::Infeasible => INFEASIBLE,
            FailureKind::MissedLandmark => MISSED_LANDMARK,
            FailureKind::PlanNotFound => PLAN_NOT_FOUND,
        }
    }
}

/// A failed command: the error and its kind.
#[derive(Debug)]
pub struct Failure {
    /// What kind of failure (picks the exit code).
    pub kind: FailureKind,
    /// The error, naming what failed.
    pub error: anyhow::Error,
}

impl Failure {
    /// A failure of the given kind.
    pub fn new(kind: FailureKind, e: impl Into<anyhow::Error>) -> Self {
        Failure {
            kind,
            error: e.into(),
        }
    }

    /// Bad input (exit code 2).
    pub fn bad_input(e: impl Into<anyhow::Error>) -> Self {
        Self::new(FailureKind::BadInput, e)
    }

    /// A mission that cannot be flown (exit code 3).
    pub fn infeasible(e: impl Into<anyhow::Error>) -> Self {
        Self::new(FailureKind::Infeasible, e)
    }

    /// A landmark in view was not detected (exit code 4).
    pub fn missed_landmark(e: impl Into<anyhow::Error>) -> Self {
        Self::new(FailureKind::MissedLandmark, e)
    }

    /// A failure at run time (exit code 1).
    pub fn runtime(e: impl Into<anyhow::Error>) -> Self {
        Self::new(FailureKind::Runtime, e)
    }

    /// Bad input (exit code 2) when `bad_input`, else a failure at run time (exit code 1): how
    /// an error that knows whether its cause was the input classifies itself.
    pub fn bad_input_or_runtime(bad_input: bool, e: impl Into<anyhow::Error>) -> Self {
        if bad_input {
            Self::bad_input(e)
        } else {
            Self::runtime(e)
        }
    }

    /// The same failure with `context` in front of its message.
    #[must_use]
    pub fn context(self, context: impl fmt::Display + Send + Sync + 'static) -> Self {
        Failure {
            kind: self.kind,
            error: self.error.context(context),
        }
    }

    /// The process exit code.
    pub fn exit_code(&self) -> u8 {
        self.kind.exit_code()
    }

    /// Prints `error: ` and the error with its causes (each once) on stderr and returns the
    /// exit code: what a binary's `main` ends with.
    pub fn report(&self) -> ExitCode {
        eprintln!("error: {self}");
        ExitCode::from(self.exit_code())
    }
}

impl From<anyhow::Error> for Failure {
    /// Any error not classified otherwise is a failure at run time.
    fn from(error: anyhow::Error) -> Self {
        Failure::runtime(error)
    }
}

impl fmt::Display for Failure {
    /// The error and its causes on one line, each cause once.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&crate::error_chain(self.error.as_ref()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_map_to_the_documented_codes() {
        assert_eq!(Failure::runtime(anyhow::anyhow!("x")).exit_code(), 1);
        assert_eq!(Failure::bad_input(anyhow::anyhow!("x")).exit_code(), 2);
        assert_eq!(Failure::infeasible(anyhow::anyhow!("x")).exit_code(), 3);
        assert_eq!(
            Failure::missed_landmark(anyhow::anyhow!("x")).exit_code(),
            4
        );
        let f: Failure = anyhow::anyhow!("inner").context("outer").into();
        assert_eq!(f.kind, FailureKind::Runtime);
        assert_eq!(f.to_string(), "outer: inner");
        let f = Failure::bad_input(anyhow::anyhow!("inner")).context("reading m.toml");
        assert_eq!(f.kind, FailureKind::BadInput);
        assert_eq!(f.to_string(), "reading m.toml: inner");
    }

    #[test]
    fn the_module_table_lists_every_code() {
        let doc = include_str!("exit.rs");
        for code in [RUNTIME, BAD_INPUT, INFEASIBLE, MISSED_LANDMARK, INTERRUPTED] {
            assert!(doc.contains(&format!("//! | {code} |")), "code {code}");
        }
    }
}
