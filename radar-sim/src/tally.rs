//! What one processed aperture adds to a mission's results, and how those add up: one
//! implementation for `cellsar-radar-sim process` (a recording) and the `process` service
//! (frames over iceoryx2 or Zenoh), so that both write the same `detections.csv` and
//! `metrics.json` from the same IQ.

use rustfft::num_complex::Complex32;
use serde::{Deserialize, Serialize};

use crate::cancel::CancelStats;
use crate::error::Result;
use crate::pipeline::{ApertureResult, Processor};
use crate::run::{ApertureSummary, DetectionRow, MeasuredResolution, Metrics};
use crate::track::{Aperture, PulseMeta};

/// Expected per-look SNR from which an object counts as strong (enters `Metrics::pd`), dB.
pub const STRONG_SNR_DB: f64 = 13.0;

/// Everything one processed aperture adds to the mission's detections and metrics.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ApertureTally {
    /// Rows of `detections.csv`.
    pub rows: Vec<DetectionRow>,
    /// The per-aperture summary of `metrics.json`.
    pub summary: ApertureSummary,
    /// Truth objects in the image.
    pub objects: usize,
    /// ... of which detected.
    pub objects_detected: usize,
    /// Objects with expected SNR ≥ [`STRONG_SNR_DB`].
    pub strong: usize,
    /// ... of which detected.
    pub strong_detected: usize,
    /// Position errors of matched detections, m (in the scorer's order).
    pub errors_m: Vec<f64>,
    /// Unmatched detections.
    pub false_alarms: usize,
    /// Expected false-alarm clusters by design.
    pub design_false_alarms: f64,
    /// Canceller metrics.
    pub cancel: CancelStats,
    /// Expected SNRs of the truth objects that are this aperture's landmark (scorer order).
    pub landmark_snrs_db: Vec<f64>,
    /// The look used for the resolution measurement if this aperture is the best.
    pub resolution_look: usize,
}

impl ApertureTally {
    /// The tally of aperture `ap` processed into `r`, with the scene's `pfa` and the receiver's
    /// noise power per complex sample `noise_power_w`.
    pub fn new(ap: &Aperture, r: &ApertureResult, pfa: f64, noise_power_w: f64) -> Self {
        let rows = r
            .detections
            .iter()
            .enumerate()
            .map(|(di, d)| {
                let m = r.score.outcomes.iter().find(|o| o.detection == Some(di));
                DetectionRow {
                    aperture: ap.index,
                    x_m: d.x_m,
                    y_m: d.y_m,
                    snr_db: d.snr_db,
                    pixels: d.pixels,
                    truth_id: m.map(|o| o.truth.id),
                    error_m: m.and_then(|o| o.error_m),
                }
            })
            .collect();
        let (mut all, mut all_hit, mut strong, mut strong_hit) = (0, 0, 0, 0);
        let mut errors_m = Vec::new();
        let (mut lm_det, mut lm_snr) = (None, None);
        let mut landmark_snrs_db = Vec::new();
        for o in &r.score.outcomes {
            all += 1;
            if o.detection.is_some() {
                all_hit += 1;
            }
            if o.truth.expected_snr_db >= STRONG_SNR_DB {
                strong += 1;
                if o.detection.is_some() {
                    strong_hit += 1;
                }
            }
            if let Some(e) = o.error_m {
                errors_m.push(e);
            }
            if o.truth.landmark.is_some() && o.truth.landmark == ap.landmark {
                lm_det = Some(o.detection.is_some());
                lm_snr = Some(o.truth.expected_snr_db);
                landmark_snrs_db.push(o.truth.expected_snr_db);
            }
        }
        let summary = ApertureSummary {
            aperture: ap.index,
            landmark: ap.landmark,
            landmark_detected: lm_det,
            landmark_snr_db: lm_snr,
            detections: r.detections.len(),
            false_alarms: r.score.false_alarms.len(),
            dpi_reduction_db: r.cancel.dp_reduction_db(),
            residual_to_noise_db: 10.0 * (r.cancel.mean_output_power() / noise_power_w).log10(),
            worst_width_m: r.cell.worst_width_m,
        };
        ApertureTally {
            rows,
            summary,
            objects: all,
            objects_detected: all_hit,
            strong,
            strong_detected: strong_hit,
            errors_m,
            false_alarms: r.score.false_alarms.len(),
            design_false_alarms: r.design_false_alarm_clusters(pfa),
            cancel: r.cancel,
            landmark_snrs_db,
            resolution_look: ap.looks / 2,
        }
    }
}

/// Pixel positions (column, row) of `r`'s detections in its grid, for marking the image.
pub fn detection_pixels(r: &ApertureResult) -> Vec<(usize, usize)> {
    r.detections
        .iter()
        .map(|d| {
            let (x, y) = r.grid.index_of([d.x_m, d.y_m]);
            (x.round().max(0.0) as usize, y.round().max(0.0) as usize)
        })
        .collect()
}

/// Adds up the tallies of a mission's apertures (in aperture order) into its metrics, without
/// the resolution measurement; returns them with the (aperture, look) on which to measure the
/// resolution: the look [`ApertureTally::resolution_look`] of the aperture whose landmark has
/// the highest expected SNR (the first of equals), if any aperture has its landmark in view.
pub fn fold<'a>(
    tallies: impl IntoIterator<Item = &'a ApertureTally>,
    noise_power_w: f64,
) -> (Metrics, Option<(usize, usize)>) {
    let (mut strong, mut strong_hit, mut all, mut all_hit) = (0usize, 0usize, 0usize, 0usize);
    let mut errors = Vec::new();
    let (mut fa, mut design_fa) = (0usize, 0.0);
    let mut cancel = CancelStats::default();
    let mut best: Option<(f64, usize, usize)> = None;
    let mut summaries = Vec::new();
    for t in tallies {
        cancel.add(&t.cancel);
        all += t.objects;
        all_hit += t.objects_detected;
        strong += t.strong;
        strong_hit += t.strong_detected;
        errors.extend_from_slice(&t.errors_m);
        for s in &t.landmark_snrs_db {
            if best.is_none_or(|b| *s > b.0) {
                best = Some((*s, t.summary.aperture, t.resolution_look));
            }
        }
        fa += t.false_alarms;
        design_fa += t.design_false_alarms;
        summaries.push(t.summary.clone());
    }
    let frac = |a: usize, b: usize| if b > 0 { a as f64 / b as f64 } else { f64::NAN };
    (
        Metrics {
            pd: frac(strong_hit, strong),
            strong_objects: strong,
            pd_all: frac(all_hit, all),
            false_alarms: fa,
            design_false_alarms: design_fa,
            mean_position_error_m: if errors.is_empty() {
                f64::NAN
            } else {
                errors.iter().sum::<f64>() / errors.len() as f64
            },
            dpi_reduction_db: cancel.dp_reduction_db(),
            cancellation_db: cancel.cancellation_db(),
            residual_to_noise_db: 10.0 * (cancel.mean_output_power() / noise_power_w).log10(),
            target_loss_db: cancel.target_loss_db(),
            range_resolution_m: None,
            azimuth_resolution_m: None,
            resolution_from: None,
            apertures: summaries,
        },
        best.map(|(_, a, l)| (a, l)),
    )
}

/// Measures the range and azimuth resolution on one look of aperture `ap` (`look_pulses`
/// and their IQ, `look_pulses.len() × samples per pulse`), at the aperture's centre, against
/// the general and the paper's predictions; `None` when the measurement finds no clean peak.
pub fn measure_look(
    proc: &Processor,
    ap: &Aperture,
    look_pulses: &[PulseMeta],
    iq: &[Complex32],
) -> Result<Option<(MeasuredResolution, MeasuredResolution)>> {
    let grid = proc.setup().grid(ap);
    let c = proc.compress(
        &grid,
        look_pulses,
        iq,
        ap.pulses_per_look,
        Some(ap.centre_m),
        true,
    )?;
    Ok(proc
        .measure_resolution(&c, look_pulses, 0..look_pulses.len(), ap.centre_m)
        .ok()
        .map(|rep| {
            (
                MeasuredResolution {
                    measured_m: rep.range_measured_m,
                    predicted_general_m: rep.range_general_m,
                    paper_m: rep.range_paper_m,
                },
                MeasuredResolution {
                    measured_m: rep.azimuth_measured_m,
                    predicted_general_m: rep.azimuth_general_m,
                    paper_m: rep.azimuth_paper_m,
                },
            )
        }))
}
