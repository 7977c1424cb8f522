//! Progress reporting: [`IterationRecord`], [`Observer`], [`NoObserver`].

use serde::{Deserialize, Serialize};

/// One iteration as seen by an [`Observer`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Iteration number (1-based).
    pub iteration: usize,
    /// The optimiser's own objective after this iteration (J, or m for distance schemes).
    pub objective: f64,
    /// True energy of the iterate on the exact geometry, J.
    pub true_energy_j: f64,
    /// Largest sensing violation of the iterate on the exact geometry, m.
    pub sensing_violation_m: f64,
    /// Largest azimuth (minimum speed) violation on the exact geometry, m/s.
    pub speed_violation_mps: f64,
    /// Interior-point iterations spent in this iteration's cone programs.
    pub ipm_iterations: u32,
    /// Wall time of this iteration, s.
    pub seconds: f64,
    /// Whether the step was accepted.
    pub accepted: bool,
}

/// Receives progress of a planning run.
pub trait Observer {
    /// Called after every iteration (accepted or rejected).
    fn on_iteration(&mut self, _record: &IterationRecord) {}
    /// Called when a phase starts ("repair", "solve").
    fn on_phase(&mut self, _phase: &str) {}
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoObserver;
impl Observer for NoObserver {}
