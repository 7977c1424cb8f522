//! Scoring of detections against the ground truth of one image: greedy nearest matching within
//! a gate, then detected / missed / false alarms and position errors.

use serde::{Deserialize, Serialize};

use crate::cfar::Detection;

/// A truth object as seen by one image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TruthInImage {
    /// Object id.
    pub id: usize,
    /// Position, m.
    pub pos_m: [f64; 2],
    /// Expected per-look image SNR, dB.
    pub expected_snr_db: f64,
    /// Landmark index, if any.
    pub landmark: Option<usize>,
}

/// The outcome for one truth object.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TruthOutcome {
    /// The object.
    pub truth: TruthInImage,
    /// Index of the matched detection.
    pub detection: Option<usize>,
    /// Distance to the matched detection, m.
    pub error_m: Option<f64>,
}

/// Scores of one image.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Score {
    /// Per truth object.
    pub outcomes: Vec<TruthOutcome>,
    /// Indices of detections matched to no object.
    pub false_alarms: Vec<usize>,
}

impl Score {
    /// Objects detected.
    pub fn detected(&self) -> usize {
        self.outcomes
            .iter()
            .filter(|o| o.detection.is_some())
            .count()
    }

    /// Objects missed.
    pub fn missed(&self) -> usize {
        self.outcomes.len() - self.detected()
    }

    /// Position errors of the detected objects, m.
    pub fn errors_m(&self) -> Vec<f64> {
        self.outcomes.iter().filter_map(|o| o.error_m).collect()
    }
}

/// Matches detections to truth greedily by distance (closest pair first), within `gate_m`.
pub fn score(truth: &[TruthInImage], dets: &[Detection], gate_m: f64) -> Score {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (ti, t) in truth.iter().enumerate() {
        for (di, d) in dets.iter().enumerate() {
            let e = (d.x_m - t.pos_m[0]).hypot(d.y_m - t.pos_m[1]);
            if e <= gate_m {
                pairs.push((e, ti, di));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut t_used = vec![None; truth.len()];
    let mut d_used = vec![false; dets.len()];
    for (e, ti, di) in pairs {
        if t_used[ti].is_none() && !d_used[di] {
            t_used[ti] = Some((di, e));
            d_used[di] = true;
        }
    }
    Score {
        outcomes: truth
            .iter()
            .zip(&t_used)
            .map(|(t, u)| TruthOutcome {
                truth: *t,
                detection: u.map(|x| x.0),
                error_m: u.map(|x| x.1),
            })
            .collect(),
        false_alarms: d_used
            .iter()
            .enumerate()
            .filter(|(_, u)| !**u)
            .map(|(i, _)| i)
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(x: f64, y: f64) -> Detection {
        Detection {
            aperture: 0,
            x_m: x,
            y_m: y,
            snr_db: 20.0,
            pixels: 3,
        }
    }

    #[test]
    fn greedy_matching() {
        let t = |id, x, y| TruthInImage {
            id,
            pos_m: [x, y],
            expected_snr_db: 20.0,
            landmark: None,
        };
        let truth = [t(0, 0.0, 0.0), t(1, 10.0, 0.0), t(2, 50.0, 50.0)];
        let dets = [det(0.5, 0.0), det(9.0, 0.0), det(-30.0, 0.0), det(0.2, 0.1)];
        let s = score(&truth, &dets, 3.0);
        assert_eq!(s.detected(), 2);
        assert_eq!(s.missed(), 1);
        assert_eq!(s.outcomes[0].detection, Some(3));
        assert_eq!(s.false_alarms, vec![0, 2]);
    }
}
