//! The expected SNR of every landmark at its aperture from the radar's link budget, for a
//! mission and its plan, without synthesising echoes: the closed loop's apertures, looks and
//! pulses along the planned track (at its altitudes for a mission with `altitude = "free"`),
//! each look's [`Processor::expected_snr_db`] of the landmark object, and the aperture's figure
//! as the closed loop reports it (`report.json`'s `snr_db`: the mean over looks of the linear
//! per-look SNR, in dB).

use serde::{Deserialize, Serialize};

use super::closed_loop::{in_view_fractions, IN_VIEW_MIN_FRACTION};
use super::simulate::planned_track;
use crate::config::SceneFile;
use crate::error::Result;
use crate::pipeline::{Processor, RadarSetup};
use crate::scene::SceneObject;

/// The expected SNR of one landmark at its aperture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LandmarkSnr {
    /// Aperture (one per landmark window).
    pub aperture: usize,
    /// The landmark sensed in the aperture's window.
    pub landmark: usize,
    /// Fraction of the window's slots in which the plan keeps the landmark in view.
    pub in_view_fraction: f64,
    /// Mean flown altitude over the aperture's pulses, m.
    pub mean_altitude_m: f64,
    /// Mean slant range from the UAV to the landmark over the aperture's pulses, m.
    pub mean_slant_range_m: f64,
    /// The UAV antenna's gain towards the landmark relative to its peak, mean over the
    /// aperture's pulses (of the linear gain), dB.
    pub gain_db: f64,
    /// Expected per-look image SNR of each look, dB.
    pub look_snr_db: Vec<f64>,
    /// Expected per-look SNR of the aperture, dB: the mean over its looks of the linear SNR
    /// (what the closed loop reports for the landmark).
    pub snr_db: f64,
}

impl LandmarkSnr {
    /// The plan keeps the landmark in view in at least [`IN_VIEW_MIN_FRACTION`] of its window
    /// (the closed loop's rule for a landmark it must detect).
    pub fn in_view(&self) -> bool {
        self.in_view_fraction >= IN_VIEW_MIN_FRACTION
    }
}

/// Min and mean of the expected SNR over the landmark apertures in view.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SnrSummary {
    /// Apertures whose landmark is in view ([`LandmarkSnr::in_view`]).
    pub apertures_in_view: usize,
    /// Least aperture SNR among them, dB (NaN when there are none).
    pub min_db: f64,
    /// Mean of their aperture SNRs in dB, dB (NaN when there are none).
    pub mean_db: f64,
    /// Mean of their [`LandmarkSnr::gain_db`], dB (NaN when there are none).
    pub mean_gain_db: f64,
    /// Mean of their [`LandmarkSnr::mean_slant_range_m`], m (NaN when there are none).
    pub mean_slant_range_m: f64,
}

impl SnrSummary {
    /// The summary of `rows` over those in view.
    pub fn of(rows: &[LandmarkSnr]) -> Self {
        let in_view: Vec<&LandmarkSnr> = rows.iter().filter(|r| r.in_view()).collect();
        let n = in_view.len();
        let mean = |f: fn(&LandmarkSnr) -> f64| {
            if n == 0 {
                f64::NAN
            } else {
                in_view.iter().map(|r| f(r)).sum::<f64>() / n as f64
            }
        };
        Self {
            apertures_in_view: n,
            min_db: if n == 0 {
                f64::NAN
            } else {
                in_view
                    .iter()
                    .map(|r| r.snr_db)
                    .fold(f64::INFINITY, f64::min)
            },
            mean_db: mean(|r| r.snr_db),
            mean_gain_db: mean(|r| r.gain_db),
            mean_slant_range_m: mean(|r| r.mean_slant_range_m),
        }
    }
}

/// Each landmark's expected SNR at its aperture for `mission` flown along `traj` (at the
/// mission's altitude, or through `altitudes_m`, one per slot, for a mission with
/// `altitude = "free"`: [`planned_track`] refuses a mismatch) over `scene`, with the in-view
/// fraction of its window from `evaluation` (the plan's exact evaluation at the flown
/// altitudes).
///
/// The apertures, looks and pulses are those the closed loop forms
/// ([`RadarSetup::apertures`], [`RadarSetup::pulses`]); the landmark is the scene's landmark
/// object (`objects.include_landmarks`), or, in a scene without landmark objects, an object of
/// `objects.landmark_rcs_m2` at the landmark. Errors name the field at fault (the scene's, the
/// altitude profile's) or say why the mission gives no aperture.
pub fn landmark_snrs(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    altitudes_m: Option<&[f64]>,
    evaluation: &planner::Evaluation,
    scene: &SceneFile,
) -> Result<Vec<LandmarkSnr>> {
    let track = planned_track(mission, traj, altitudes_m)?;
    let setup = RadarSetup::new(mission.params(), scene)?;
    let apertures = setup.apertures(mission)?;
    let objects = setup.objects(mission)?;
    let fractions = in_view_fractions(mission, evaluation);
    let landmark_rcs_m2 = setup.scene.objects.landmark_rcs_m2;
    let proc = Processor::new(setup)?;
    let mut rows = Vec::with_capacity(apertures.len());
    for ap in &apertures {
        let Some(landmark) = ap.landmark else {
            continue;
        };
        let object = match objects.iter().find(|o| o.landmark == Some(landmark)) {
            Some(o) => *o,
            None => SceneObject {
                id: objects.len() + landmark,
                x_m: ap.centre_m[0],
                y_m: ap.centre_m[1],
                rcs_m2: landmark_rcs_m2,
                phase_rad: 0.0,
                landmark: Some(landmark),
            },
        };
        let pulses = proc.setup().pulses(&track, ap);
        let look_snr_db = proc.look_snrs_db(&object, &pulses, ap.pulses_per_look, ap.looks);
        let mean_lin = Processor::mean_look_snr(&look_snr_db);
        let n = pulses.len().max(1) as f64;
        let mean_altitude_m = pulses.iter().map(|p| p.pos_m[2]).sum::<f64>() / n;
        let target = [object.x_m, object.y_m, 0.0];
        let mean_slant_range_m = pulses
            .iter()
            .map(|p| crate::track::dist3(p.pos_m, target))
            .sum::<f64>()
            / n;
        let antenna = &proc.setup().antenna;
        let gain = pulses
            .iter()
            .map(|p| antenna.gain_towards(p.pos_m, p.heading, target))
            .sum::<f64>()
            / n;
        rows.push(LandmarkSnr {
            aperture: ap.index,
            landmark,
            in_view_fraction: fractions.get(landmark).copied().unwrap_or(0.0),
            mean_altitude_m,
            mean_slant_range_m,
            gain_db: 10.0 * (gain / antenna.peak_gain).log10(),
            look_snr_db,
            snr_db: 10.0 * mean_lin.log10(),
        });
    }
    Ok(rows)
}
