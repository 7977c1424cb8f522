//! The convex subproblems of each scheme, assembled on [`crate::socp`].
//!
//! - [`exact`]: SCA on the exact geometry (schemes `exact`, `baseline-exact`, and phase I);
//! - [`paper`]: the paper's Algorithm 1 and its baseline, as printed (schemes `paper`, `baseline`).

pub mod exact;
pub mod paper;
