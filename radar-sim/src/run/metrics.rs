//! `metrics.json` ([`Metrics`], with a [`ApertureSummary`] per aperture and the
//! [`MeasuredResolution`]s) and the detections' rows ([`DetectionRow`]).

use serde::{Deserialize, Serialize};

/// A measured resolution with its predictions (for `metrics.json`). Every pair uses one
/// definition: the `*_m` widths without `cell` are −3 dB widths of the image's response (the
/// cell times the weighting's main-lobe factor), the `*_cell_m` ones the unweighted cells
/// c/(B|g|), 1/(T|∇f_D|) and the paper's δ (the planner's definition).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MeasuredResolution {
    /// Measured −3 dB width, m.
    pub measured_m: f64,
    /// −3 dB main-lobe factor of the weighting along this axis (0.886 none, 1.44 Hann).
    pub mainlobe_factor: f64,
    /// General prediction of the −3 dB width: the general cell × `mainlobe_factor`, m.
    pub predicted_general_m: f64,
    /// The paper's δ × `mainlobe_factor`: the −3 dB width its cell implies, m.
    pub paper_mainlobe_m: f64,
    /// The general cell (no factor), m.
    pub general_cell_m: f64,
    /// The paper's δ (no factor), m.
    pub paper_cell_m: f64,
}

/// Per-aperture summary in `metrics.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ApertureSummary {
    /// Aperture index.
    pub aperture: usize,
    /// Landmark index.
    pub landmark: Option<usize>,
    /// Landmark detected (matched within the gate); None when no truth object is the
    /// landmark (not scored).
    pub landmark_detected: Option<bool>,
    /// Expected per-look SNR of the landmark, dB.
    pub landmark_snr_db: Option<f64>,
    /// Detections.
    pub detections: usize,
    /// Unmatched detections.
    pub false_alarms: usize,
    /// Expected false-alarm detections on noise by design (see [`Metrics::design_false_alarms`]).
    pub design_false_alarms: f64,
    /// CFAR exceedance pixels among the clear pixels (see [`Metrics::false_alarm_pixels`]).
    pub false_alarm_pixels: usize,
    /// Clear pixels (noise only by the truth's predicted responses).
    pub clear_pixels: usize,
    /// Pixels tested against the image-wide noise estimate (too few training cells).
    pub cfar_fallback_pixels: usize,
    /// The image's noise floor as the CFAR estimated it, dB over thermal noise.
    pub image_floor_db: f64,
    /// The floor predicted from the truth (thermal noise + the inter-symbol interference of
    /// echoes beyond the cyclic prefix), dB over thermal noise.
    pub predicted_image_floor_db: f64,
    /// Canceller: direct-path suppression, dB ([`crate::cancel::CancelStats::dp_suppression_db`]);
    /// None without a direct path in the scene.
    pub dp_suppression_db: Option<f64>,
    /// Canceller: residual over the predicted echo + noise floor, dB (0 = no direct path left).
    pub residual_over_floor_db: f64,
    /// Canceller: residual over thermal noise (echoes included), dB.
    pub residual_to_noise_db: f64,
    /// Worst width of the unweighted resolution cell (1/B, 1/T: the planner's definition) at
    /// the landmark (erratum 12 (docs/paper-notes.md)), m.
    pub worst_width_m: f64,
    /// The same with the weightings' main-lobe factors: the worst −3 dB width of the image's
    /// response there, m.
    pub worst_width_mainlobe_m: f64,
}

/// `metrics.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Metrics {
    /// Detection probability over object-aperture pairs with expected SNR ≥ 13 dB: an object
    /// counts once per aperture whose image holds it.
    pub pd: f64,
    /// Object-aperture pairs with expected SNR ≥ 13 dB.
    pub strong_objects: usize,
    /// Detection probability over all object-aperture pairs in the images.
    pub pd_all: f64,
    /// Distinct objects with expected SNR ≥ 13 dB in at least one image.
    pub strong_distinct_objects: usize,
    /// Fraction of those detected in at least one image in which they are strong.
    pub pd_distinct: f64,
    /// Unmatched detections.
    pub false_alarms: usize,
    /// Expected unmatched detections on noise by design: the Euler-characteristic density of
    /// the multilook noise at the CFAR's threshold times the image area outside the truth
    /// objects' gates ([`crate::cfar::expected_peaks_per_m2`]).
    pub design_false_alarms: f64,
    /// CFAR exceedance pixels among the clear pixels: outside every truth object's gate, where
    /// the objects' predicted responses (sidelobes included) stay 10 dB below the thermal noise
    /// ([`crate::pipeline::CLEAR_SIGNAL`]).
    pub false_alarm_pixels: usize,
    /// Expected exceedance pixels there on noise: P_fa × the clear pixels.
    pub design_false_alarm_pixels: f64,
    /// Pixels tested against the image-wide noise estimate (too few training cells of their
    /// own); no pixel is left untested.
    pub cfar_fallback_pixels: usize,
    /// Pixels tested by the CFAR (every pixel of every image).
    pub cfar_pixels: usize,
    /// Mean position error of matched detections, m.
    pub mean_position_error_m: f64,
    /// Canceller: direct-path suppression, dB: the direct path's power before cancellation over
    /// the power the projection leaves of it (its measured copy through the same projection,
    /// [`crate::cancel::CancelStats::dp_suppression_db`]). None without a direct path.
    pub dp_suppression_db: Option<f64>,
    /// The direct path's power before cancellation over the predicted echo + noise floor, dB.
    /// None without a direct path.
    pub dp_over_floor_db: Option<f64>,
    /// Canceller: residual power after cancellation over the predicted echo + noise floor (the
    /// truth objects' link budget plus the thermal noise the projection keeps), dB: 0 when
    /// nothing of the direct path is left above the floor.
    pub residual_over_floor_db: f64,
    /// Canceller: mean power reduction P_in/P_out, dB (the echoes' share of the input bounds it).
    pub cancellation_db: f64,
    /// Canceller: mean residual over thermal noise, dB (echoes included).
    pub residual_to_noise_db: f64,
    /// Canceller: power loss of a target at the landmark delay, dB.
    pub target_loss_db: f64,
    /// Measured range resolution (along g) of the strongest landmark.
    pub range_resolution_m: Option<MeasuredResolution>,
    /// Measured azimuth resolution (along the Doppler gradient).
    pub azimuth_resolution_m: Option<MeasuredResolution>,
    /// Aperture and look of the resolution measurement.
    pub resolution_from: Option<(usize, usize)>,
    /// Per aperture.
    pub apertures: Vec<ApertureSummary>,
}

impl Metrics {
    /// One line on detection: Pd over object-aperture pairs and distinct objects, false alarms
    /// against their design counts, position error.
    pub fn detection_summary(&self) -> String {
        format!(
            "Pd {:.3} over {} object-aperture pairs ≥ 13 dB (per distinct object: {:.3} of {}), {} false alarms (expected from noise: {:.3}), mean error {:.2} m; CFAR: {} of {} pixels tested against the image-wide noise floor",
            self.pd,
            self.strong_objects,
            self.pd_distinct,
            self.strong_distinct_objects,
            self.false_alarms,
            self.design_false_alarms,
            self.mean_position_error_m,
            self.cfar_fallback_pixels,
            self.cfar_pixels
        )
    }

    /// One line on the canceller.
    pub fn canceller_summary(&self) -> String {
        let rest = format!(
            "residual {:+.2} dB over the predicted echo+noise floor ({:.2} dB over thermal noise), target loss {:.4} dB",
            self.residual_over_floor_db, self.residual_to_noise_db, self.target_loss_db
        );
        match (self.dp_suppression_db, self.dp_over_floor_db) {
            (Some(s), Some(f)) => format!(
                "direct-path suppression {s:.1} dB (the path was {f:.1} dB above the echo+noise floor), {rest}"
            ),
            _ => format!("no direct path in the scene; {rest}"),
        }
    }

    /// One line on the measured resolution, if measured: −3 dB widths against the general
    /// prediction and the paper's δ, both × the main-lobe factor, then the cells.
    pub fn resolution_summary(&self) -> Option<String> {
        let (r, a) = (
            self.range_resolution_m.as_ref()?,
            self.azimuth_resolution_m.as_ref()?,
        );
        Some(format!(
            "resolution (−3 dB, main-lobe factors {:.3}/{:.3}): range {:.3} m (general {:.3}, paper {:.3}), azimuth {:.3} m (general {:.3}, paper {:.3}); cells without the factor: range general {:.3}, paper {:.3}; azimuth general {:.3}, paper {:.3}",
            r.mainlobe_factor,
            a.mainlobe_factor,
            r.measured_m,
            r.predicted_general_m,
            r.paper_mainlobe_m,
            a.measured_m,
            a.predicted_general_m,
            a.paper_mainlobe_m,
            r.general_cell_m,
            r.paper_cell_m,
            a.general_cell_m,
            a.paper_cell_m
        ))
    }
}

/// One row of `detections.csv`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DetectionRow {
    /// Aperture.
    pub aperture: usize,
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// SNR over the local noise, dB.
    pub snr_db: f64,
    /// Pixels.
    pub pixels: usize,
    /// Matched truth id.
    pub truth_id: Option<usize>,
    /// Distance to the matched truth, m.
    pub error_m: Option<f64>,
}
