//! The closed loop's report: per aperture, whether the landmark the plan kept in view was
//! detected; and [`shorten`], which cuts a mission to a horizon.

use serde::{Deserialize, Serialize};

use super::Metrics;
use crate::error::{RadarError, Result};

/// Closed-loop report row: one aperture.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopRow {
    /// Aperture.
    pub aperture: usize,
    /// Landmark.
    pub landmark: Option<usize>,
    /// Fraction of the window's slots in which the plan keeps the landmark in view.
    pub in_view_fraction: f64,
    /// Landmark detected; None when no truth object is the landmark (a scene without
    /// landmark objects): not scored.
    pub detected: Option<bool>,
    /// Expected per-look SNR, dB.
    pub snr_db: Option<f64>,
}

/// A landmark counts as in view of its aperture when the plan keeps it in view in at least this
/// fraction of its window's slots; such a landmark must be detected.
pub const IN_VIEW_MIN_FRACTION: f64 = 0.5;

impl LoopRow {
    /// The landmark was in view (≥ [`IN_VIEW_MIN_FRACTION`] of its window), scored, and not
    /// detected.
    pub fn missed_in_view(&self) -> bool {
        self.in_view_fraction >= IN_VIEW_MIN_FRACTION && self.detected == Some(false)
    }

    /// `true`, `false`, or `-` when not scored.
    pub fn detected_label(&self) -> &'static str {
        match self.detected {
            Some(true) => "true",
            Some(false) => "false",
            None => "-",
        }
    }
}

/// The closed-loop report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopReport {
    /// Mission name.
    pub mission: String,
    /// Plan energy on the exact geometry, J.
    pub energy_j: f64,
    /// Per aperture.
    pub rows: Vec<LoopRow>,
    /// Every scored landmark in view (≥ [`IN_VIEW_MIN_FRACTION`] of its window) was
    /// detected (true when none was scored).
    pub all_in_view_detected: bool,
    /// Landmark windows scored (the landmark is a truth object of its image).
    pub landmarks_scored: usize,
    /// Processing metrics.
    pub metrics: Metrics,
}

/// In-view fraction per landmark window from the plan's exact evaluation.
pub fn in_view_fractions(mission: &planner::Mission, eval: &planner::Evaluation) -> Vec<f64> {
    let n = mission.schedule().landmarks.len();
    let mut count = vec![0usize; n];
    let mut inv = vec![0usize; n];
    for (s, lm) in eval.slots.iter().zip(&mission.schedule().slot_landmark) {
        if let Some(l) = lm {
            count[*l] += 1;
            if s.in_view {
                inv[*l] += 1;
            }
        }
    }
    count
        .iter()
        .zip(&inv)
        .map(|(c, i)| if *c > 0 { *i as f64 / *c as f64 } else { 0.0 })
        .collect()
}

/// Builds the loop report from a processed run.
pub fn loop_report(
    mission: &planner::Mission,
    eval: &planner::Evaluation,
    metrics: Metrics,
) -> LoopReport {
    let frac = in_view_fractions(mission, eval);
    let rows: Vec<LoopRow> = metrics
        .apertures
        .iter()
        .map(|a| LoopRow {
            aperture: a.aperture,
            landmark: a.landmark,
            in_view_fraction: a.landmark.and_then(|l| frac.get(l).copied()).unwrap_or(0.0),
            detected: a.landmark_detected,
            snr_db: a.landmark_snr_db,
        })
        .collect();
    LoopReport {
        mission: mission.name().to_string(),
        energy_j: eval.energy_j,
        all_in_view_detected: !rows.iter().any(LoopRow::missed_in_view),
        landmarks_scored: rows.iter().filter(|r| r.detected.is_some()).count(),
        rows,
        metrics,
    }
}

/// Cuts `mission` to the windows that end within `horizon_s` and sets the horizon.
///
/// `horizon_s` must be a finite number > 0 that holds at least one whole landmark window
/// (a [`RadarError::Config`] naming `horizon_s` otherwise).
pub fn shorten(mission: &planner::Mission, horizon_s: f64) -> Result<planner::Mission> {
    if !(horizon_s.is_finite() && horizon_s > 0.0) {
        return Err(RadarError::config(
            "horizon_s",
            format!("{horizon_s}: must be a finite number > 0"),
        ));
    }
    let mut file = mission.to_file_struct();
    let keep: Vec<planner::LandmarkWindow> = mission
        .schedule()
        .landmarks
        .iter()
        .filter(|w| w.to_s <= horizon_s + 1e-9)
        .copied()
        .collect();
    if keep.is_empty() {
        return Err(RadarError::config(
            "horizon_s",
            format!("{horizon_s} s holds no whole landmark window"),
        ));
    }
    file.landmarks = planner::LandmarksSpec {
        points: Some(keep),
        ..Default::default()
    };
    file.params.horizon_s = Some(horizon_s);
    planner::Mission::from_file_struct(&file)
        .map_err(|e| RadarError::config("mission", e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::{shorten, LoopRow, IN_VIEW_MIN_FRACTION};

    #[test]
    fn shorten_keeps_whole_windows_and_names_a_bad_horizon() {
        let m = planner::Mission::preset(planner::Preset::Default, 30.0).unwrap();
        let short = shorten(&m, 25.0).unwrap();
        assert_eq!(short.schedule().landmarks.len(), 2);
        assert_eq!(short.params().horizon_s, 25.0);
        for bad in [f64::NAN, f64::INFINITY, -10.0, 0.0, 5.0] {
            let e = shorten(&m, bad).unwrap_err();
            assert!(e.is_bad_input(), "{bad}: {e:?}");
            assert!(e.to_string().contains("horizon_s"), "{bad}: {e}");
        }
        let e = shorten(&m, f64::NAN).unwrap_err().to_string();
        assert!(e.contains("finite"), "{e}");
    }

    fn row(in_view_fraction: f64, detected: Option<bool>) -> LoopRow {
        LoopRow {
            aperture: 0,
            landmark: Some(0),
            in_view_fraction,
            detected,
            snr_db: None,
        }
    }

    #[test]
    fn a_miss_counts_only_when_the_plan_keeps_the_landmark_in_view() {
        assert!(row(1.0, Some(false)).missed_in_view());
        assert!(row(IN_VIEW_MIN_FRACTION, Some(false)).missed_in_view());
        assert!(!row(IN_VIEW_MIN_FRACTION - 0.01, Some(false)).missed_in_view());
        assert!(!row(1.0, Some(true)).missed_in_view());
        assert!(!row(0.0, Some(true)).missed_in_view());
    }

    /// A landmark that is no truth object (`include_landmarks = false`) is not scored: in
    /// view, it is no miss.
    #[test]
    fn a_landmark_without_a_truth_object_is_not_scored() {
        let r = row(1.0, None);
        assert!(!r.missed_in_view());
        assert_eq!(r.detected_label(), "-");
    }
}
