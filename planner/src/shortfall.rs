//! The resolution shortfall of a trajectory, measured on the exact geometry: which landmark slots
//! and windows have a resolution cell (erratum 12 (docs/paper-notes.md)) wider than d_min, the
//! worst width per window, and the deficit the best-effort planner minimises.
//!
//! Everything here is computed from an [`Evaluation`], so it judges any trajectory
//! independently of the optimiser that produced it.

use serde::{Deserialize, Serialize};

use crate::{Evaluation, Mission};

/// The deficit of one landmark slot whose worst cell width is `width_m`:
/// d_min (1 − d_min / w)⁺, m.
///
/// It equals the excess w − d_min to first order near d_min and is bounded by d_min in blind
/// geometry (w → ∞), so that one blind slot cannot outweigh all others; it is the measure the
/// best-effort subproblem's slacks bound (linearised at the previous iterate). NaN widths count
/// as blind.
pub fn slot_deficit_m(d_min_m: f64, width_m: f64) -> f64 {
    if width_m.is_nan() {
        return d_min_m;
    }
    if width_m <= d_min_m {
        0.0
    } else {
        d_min_m * (1.0 - d_min_m / width_m)
    }
}

/// Σ over landmark slots of [`slot_deficit_m`], m: the resolution deficit of a trajectory.
pub fn total_deficit_m(mission: &Mission, ev: &Evaluation) -> f64 {
    let d_min = mission.params().d_min_m;
    ev.slots
        .iter()
        .filter(|s| s.landmark_m.is_some())
        .map(|s| slot_deficit_m(d_min, s.worst_width_m))
        .fold(0.0, |a, b| a + b)
}

/// The resolution cell over one landmark window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WindowResolution {
    /// 0-based landmark index.
    pub landmark: usize,
    /// First and last slot (1-based) that sense it.
    pub first_slot: usize,
    /// Last slot (1-based) that senses it.
    pub last_slot: usize,
    /// Median over the window's slots of the worst cell width, m.
    pub median_worst_width_m: f64,
    /// Largest worst cell width over the window's slots, m.
    pub max_worst_width_m: f64,
    /// Slots of the window whose worst cell width exceeds d_min.
    pub unresolved_slots: usize,
    /// The median worst width exceeds d_min (objects d_min apart merge over most of the window).
    pub unresolved: bool,
}

/// The resolution shortfall of a trajectory (`summary.json`'s `resolution_shortfall`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResolutionShortfall {
    /// The required worst width, m.
    pub d_min_m: f64,
    /// Landmark slots whose worst cell width exceeds d_min.
    pub unresolved_slots: usize,
    /// Landmark windows whose median worst width exceeds d_min.
    pub unresolved_windows: usize,
    /// The first unresolved landmark slot (1-based), if any.
    pub first_unresolved_slot: Option<usize>,
    /// Σ over landmark slots of (worst width − d_min)⁺, m (finite widths only; the slots of
    /// infinite width are counted in `infinite_width_slots`).
    pub total_excess_width_m: f64,
    /// Landmark slots whose cell is unbounded: an infinite or undefined worst width (the range
    /// gradient along the track exactly, ψ = 0, or vanishing). A subset of `unresolved_slots`,
    /// and not the same count as `summary.json`'s `slots_blind`, the landmark slots with
    /// ψ < 5° (whose worst width is finite, only large). Read from `blind_slots` in summaries
    /// written before it was renamed.
    #[serde(alias = "blind_slots")]
    pub infinite_width_slots: usize,
    /// Σ over landmark slots of [`slot_deficit_m`], m.
    pub total_deficit_m: f64,
    /// Per landmark window, in landmark order (windows without slots are left out).
    pub windows: Vec<WindowResolution>,
}

impl ResolutionShortfall {
    /// The shortfall of the trajectory evaluated as `ev` against `mission`.
    pub fn new(mission: &Mission, ev: &Evaluation) -> Self {
        let d_min = mission.params().d_min_m;
        let schedule = mission.schedule();
        let mut per_window: Vec<Vec<(usize, f64)>> = vec![Vec::new(); schedule.landmarks.len()];
        for (s, lm) in ev.slots.iter().zip(&schedule.slot_landmark) {
            if let Some(w) = lm.and_then(|l| per_window.get_mut(l)) {
                w.push((s.t, s.worst_width_m));
            }
        }
        let windows: Vec<WindowResolution> = per_window
            .into_iter()
            .enumerate()
            .filter_map(|(landmark, slots)| window(landmark, slots, d_min))
            .collect();
        let landmark_slots = || ev.slots.iter().filter(|s| s.landmark_m.is_some());
        let unresolved = |w: f64| w > d_min || w.is_nan();
        Self {
            d_min_m: d_min,
            unresolved_slots: landmark_slots()
                .filter(|s| unresolved(s.worst_width_m))
                .count(),
            unresolved_windows: windows.iter().filter(|w| w.unresolved).count(),
            first_unresolved_slot: landmark_slots()
                .find(|s| unresolved(s.worst_width_m))
                .map(|s| s.t),
            total_excess_width_m: landmark_slots()
                .map(|s| s.worst_width_m - d_min)
                .filter(|x| x.is_finite() && *x > 0.0)
                .fold(0.0, |a, b| a + b),
            infinite_width_slots: landmark_slots()
                .filter(|s| !s.worst_width_m.is_finite())
                .count(),
            total_deficit_m: total_deficit_m(mission, ev),
            windows,
        }
    }
}

fn window(landmark: usize, slots: Vec<(usize, f64)>, d_min: f64) -> Option<WindowResolution> {
    let first_slot = slots.first()?.0;
    let last_slot = slots.last()?.0;
    let mut widths: Vec<f64> = slots.iter().map(|s| s.1).collect();
    widths.sort_by(f64::total_cmp);
    let median = widths[widths.len() / 2];
    Some(WindowResolution {
        landmark,
        first_slot,
        last_slot,
        median_worst_width_m: median,
        max_worst_width_m: widths.iter().copied().fold(0.0, f64::max),
        unresolved_slots: widths.iter().filter(|w| **w > d_min || w.is_nan()).count(),
        unresolved: median > d_min || median.is_nan(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deficit_is_zero_within_d_min_and_bounded_by_it() {
        assert_eq!(slot_deficit_m(20.0, 19.0), 0.0);
        assert_eq!(slot_deficit_m(20.0, 20.0), 0.0);
        assert!((slot_deficit_m(20.0, 40.0) - 10.0).abs() < 1e-12);
        assert!((slot_deficit_m(20.0, f64::INFINITY) - 20.0).abs() < 1e-12);
        assert_eq!(slot_deficit_m(20.0, f64::NAN), 20.0);
        // first order near d_min: the excess
        let w = 20.01;
        assert!((slot_deficit_m(20.0, w) - (w - 20.0)).abs() < 1e-4);
    }

    #[test]
    fn windows_use_the_median_of_their_slots() {
        let w = window(3, vec![(5, 10.0), (6, 30.0), (7, 50.0)], 20.0);
        let w = w.expect("a window");
        assert_eq!((w.landmark, w.first_slot, w.last_slot), (3, 5, 7));
        assert_eq!(w.median_worst_width_m, 30.0);
        assert_eq!(w.max_worst_width_m, 50.0);
        assert_eq!(w.unresolved_slots, 2);
        assert!(w.unresolved);
        assert!(window(0, vec![], 20.0).is_none());
    }
}
