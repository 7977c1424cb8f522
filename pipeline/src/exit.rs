//! Exit codes of the `cellsar` binary, and failures that carry theirs.
//!
//! | code | meaning |
//! |---:|---|
//! | 0 | done (`run`: the mission completed) |
//! | 1 | failure at run time (a child that keeps failing, no plan in time, I/O, Zenoh) |
//! | 2 | bad input: an option, the mission or the scene file (the message names it); nothing started |
//! | 3 | the mission cannot be flown (the message names the first slot and the reason) |
//! | 4 | `run --strict`: completed, but a landmark in view was not detected |
//! | 130 | interrupted (SIGINT/SIGTERM); every child stopped |

use std::fmt;

/// Exit code of a failure at run time.
pub const RUNTIME: u8 = 1;
/// Exit code of bad input (an option, the mission or the scene file).
pub const BAD_INPUT: u8 = 2;
/// Exit code of a mission that cannot be flown.
pub const INFEASIBLE: u8 = 3;
/// Exit code of `run --strict` when a landmark in view was not detected.
pub const MISSED_LANDMARK: u8 = 4;
/// Exit code after SIGINT or SIGTERM.
pub const INTERRUPTED: u8 = 130;

/// What kind of failure ended a command; it picks the exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FailureKind {
    /// A failure at run time (exit code 1).
    Runtime,
    /// Bad input: an option, the mission or the scene file (exit code 2).
    BadInput,
    /// The mission cannot be flown (exit code 3).
    Infeasible,
}

impl FailureKind {
    /// The process exit code of this kind of failure.
    pub fn exit_code(self) -> u8 {
        match self {
            FailureKind::Runtime => RUNTIME,
            FailureKind::BadInput => BAD_INPUT,
            FailureKind::Infeasible => INFEASIBLE,
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
    /// Bad input (exit code 2).
    pub fn bad_input(e: impl Into<anyhow::Error>) -> Self {
        Failure {
            kind: FailureKind::BadInput,
            error: e.into(),
        }
    }

    /// A mission that cannot be flown (exit code 3).
    pub fn infeasible(e: impl Into<anyhow::Error>) -> Self {
        Failure {
            kind: FailureKind::Infeasible,
            error: e.into(),
        }
    }

    /// A failure at run time (exit code 1).
    pub fn runtime(e: impl Into<anyhow::Error>) -> Self {
        Failure {
            kind: FailureKind::Runtime,
            error: e.into(),
        }
    }

    /// The process exit code.
    pub fn exit_code(&self) -> u8 {
        self.kind.exit_code()
    }
}

impl From<anyhow::Error> for Failure {
    fn from(error: anyhow::Error) -> Self {
        Failure::runtime(error)
    }
}

impl fmt::Display for Failure {
    /// The error and its causes on one line, each cause once.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&planner::error_chain(self.error.as_ref()))
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
        let f: Failure = anyhow::anyhow!("inner").context("outer").into();
        assert_eq!(f.kind, FailureKind::Runtime);
        assert_eq!(f.to_string(), "outer: inner");
    }
}
