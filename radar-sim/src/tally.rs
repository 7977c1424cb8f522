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
    /// Per truth object in the image: (id, expected SNR ≥ [`STRONG_SNR_DB`], detected).
    pub object_outcomes: Vec<(usize, bool, bool)>,
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
    /// Expected false-alarm detections on noise by design.
    pub design_false_alarms: f64,
    /// CFAR exceedance pixels among the clear pixels (noise only, see
    /// [`ApertureResult::clear_pixels`]).
    pub false_alarm_pixels: usize,
    /// P_fa × the clear pixels.
    pub design_false_alarm_pixels: f64,
    /// Pixels tested against the image-wide noise estimate.
    pub cfar_fallback_pixels: usize,
    /// Pixels of the image (all tested).
    pub pixels: usize,
    /// Canceller metrics.
    pub cancel: CancelStats,
    /// Σ over the aperture's windows of the predicted echo + noise floor after cancellation, W.
    pub floor_power: f64,
    /// Whether the scene has a direct path.
    pub direct_path: bool,
    /// Expected SNRs of the truth objects that are this aperture's landmark (scorer order).
    pub landmark_snrs_db: Vec<f64>,
    /// The look used for the resolution measurement if this aperture is the best.
    pub resolution_look: usize,
}

impl ApertureTally {
    /// The tally of aperture `ap` processed into `r`, with the receiver's noise power per
    /// complex sample `noise_power_w`.
    pub fn new(ap: &Aperture, r: &ApertureResult, noise_power_w: f64) -> Self {
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
        let mut object_outcomes = Vec::with_capacity(r.score.outcomes.len());
        for o in &r.score.outcomes {
            object_outcomes.push((
                o.truth.id,
                o.truth.expected_snr_db >= STRONG_SNR_DB,
                o.detection.is_some(),
            ));
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
        let floor_power = r.predicted_floor_w * r.cancel.windows as f64;
        let summary = ApertureSummary {
            aperture: ap.index,
            landmark: ap.landmark,
            landmark_detected: lm_det,
            landmark_snr_db: lm_snr,
            detections: r.detections.len(),
            false_alarms: r.score.false_alarms.len(),
            design_false_alarms: r.design_false_alarms,
            false_alarm_pixels: r.false_alarm_pixels,
            clear_pixels: r.clear_pixels,
            cfar_fallback_pixels: r.cfar_fallback_pixels,
            image_floor_db: 10.0 * r.image_floor.log10(),
            predicted_image_floor_db: 10.0 * r.predicted_image_floor.log10(),
            dp_suppression_db: r.direct_path.then(|| r.cancel.dp_suppression_db()),
            residual_over_floor_db: 10.0 * (r.cancel.output_power / floor_power).log10(),
            residual_to_noise_db: 10.0 * (r.cancel.mean_output_power() / noise_power_w).log10(),
            worst_width_m: r.cell.worst_width_m,
            worst_width_mainlobe_m: r.worst_width_mainlobe_m(),
        };
        ApertureTally {
            rows,
            summary,
            object_outcomes,
            objects: all,
            objects_detected: all_hit,
            strong,
            strong_detected: strong_hit,
            errors_m,
            false_alarms: r.score.false_alarms.len(),
            design_false_alarms: r.design_false_alarms,
            false_alarm_pixels: r.false_alarm_pixels,
            design_false_alarm_pixels: r.design_false_alarm_pixels,
            cfar_fallback_pixels: r.cfar_fallback_pixels,
            pixels: r.grid.pixels(),
            cancel: r.cancel,
            floor_power,
            direct_path: r.direct_path,
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
    let (mut fa_px, mut design_fa_px, mut fallback, mut pixels) = (0usize, 0.0, 0usize, 0usize);
    let mut floor_power = 0.0;
    let mut direct_path = false;
    // per distinct object: (strong in some image, detected in an image where it is strong)
    let mut distinct: std::collections::BTreeMap<usize, (bool, bool)> =
        std::collections::BTreeMap::new();
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
        fa_px += t.false_alarm_pixels;
        design_fa_px += t.design_false_alarm_pixels;
        fallback += t.cfar_fallback_pixels;
        pixels += t.pixels;
        floor_power += t.floor_power;
        direct_path |= t.direct_path;
        for &(id, strong, detected) in &t.object_outcomes {
            let e = distinct.entry(id).or_insert((false, false));
            e.0 |= strong;
            e.1 |= strong && detected;
        }
        summaries.push(t.summary.clone());
    }
    let strong_distinct = distinct.values().filter(|v| v.0).count();
    let strong_distinct_hit = distinct.values().filter(|v| v.1).count();
    let frac = |a: usize, b: usize| if b > 0 { a as f64 / b as f64 } else { f64::NAN };
    (
        Metrics {
            pd: frac(strong_hit, strong),
            strong_objects: strong,
            pd_all: frac(all_hit, all),
            strong_distinct_objects: strong_distinct,
            pd_distinct: frac(strong_distinct_hit, strong_distinct),
            false_alarms: fa,
            design_false_alarms: design_fa,
            false_alarm_pixels: fa_px,
            design_false_alarm_pixels: design_fa_px,
            cfar_fallback_pixels: fallback,
            cfar_pixels: pixels,
            mean_position_error_m: if errors.is_empty() {
                f64::NAN
            } else {
                errors.iter().sum::<f64>() / errors.len() as f64
            },
            dp_suppression_db: direct_path.then(|| cancel.dp_suppression_db()),
            dp_over_floor_db: direct_path
                .then(|| 10.0 * (cancel.dp_mf_before / floor_power).log10()),
            residual_over_floor_db: 10.0 * (cancel.output_power / floor_power).log10(),
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
            let (fr, fa) = (rep.mainlobe_factor, rep.azimuth_mainlobe_factor);
            (
                MeasuredResolution {
                    measured_m: rep.range_measured_m,
                    mainlobe_factor: fr,
                    predicted_general_m: rep.range_general_m,
                    paper_mainlobe_m: fr * rep.range_paper_m,
                    general_cell_m: rep.range_general_m / fr,
                    paper_cell_m: rep.range_paper_m,
                },
                MeasuredResolution {
                    measured_m: rep.azimuth_measured_m,
                    mainlobe_factor: fa,
                    predicted_general_m: rep.azimuth_general_m,
                    paper_mainlobe_m: fa * rep.azimuth_paper_m,
                    general_cell_m: rep.azimuth_general_m / fa,
                    paper_cell_m: rep.azimuth_paper_m,
                },
            )
        }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tally of one aperture whose image holds `objects` (id, strong, detected).
    fn tally(aperture: usize, objects: &[(usize, bool, bool)]) -> ApertureTally {
        let strong = objects.iter().filter(|o| o.1).count();
        let strong_detected = objects.iter().filter(|o| o.1 && o.2).count();
        ApertureTally {
            rows: Vec::new(),
            summary: ApertureSummary {
                aperture,
                landmark: None,
                landmark_detected: None,
                landmark_snr_db: None,
                detections: 0,
                false_alarms: 0,
                design_false_alarms: 0.0,
                false_alarm_pixels: 0,
                clear_pixels: 0,
                cfar_fallback_pixels: 0,
                image_floor_db: 0.0,
                predicted_image_floor_db: 0.0,
                dp_suppression_db: None,
                residual_over_floor_db: 0.0,
                residual_to_noise_db: 0.0,
                worst_width_m: 10.0,
                worst_width_mainlobe_m: 14.4,
            },
            object_outcomes: objects.to_vec(),
            objects: objects.len(),
            objects_detected: objects.iter().filter(|o| o.2).count(),
            strong,
            strong_detected,
            errors_m: Vec::new(),
            false_alarms: 0,
            design_false_alarms: 0.0,
            false_alarm_pixels: 0,
            design_false_alarm_pixels: 0.0,
            cfar_fallback_pixels: 0,
            pixels: 100,
            cancel: CancelStats {
                windows: 1,
                input_power: 2.0,
                output_power: 1.0,
                ..Default::default()
            },
            floor_power: 1.0,
            direct_path: false,
            landmark_snrs_db: Vec::new(),
            resolution_look: 0,
        }
    }

    /// Pd over object-aperture pairs counts an object once per image that holds it; Pd per
    /// distinct object counts it once, detected if detected in an image where it is strong.
    #[test]
    fn pd_per_pair_and_per_distinct_object() {
        // object 1 in three images (missed in two), object 2 in one, object 3 weak everywhere
        let a = tally(0, &[(1, true, true), (2, true, true), (3, false, false)]);
        let b = tally(1, &[(1, true, false), (3, false, true)]);
        let c = tally(2, &[(1, true, false)]);
        let (m, _) = fold([&a, &b, &c], 1.0);
        assert_eq!(m.strong_objects, 4);
        assert!((m.pd - 0.5).abs() < 1e-12);
        assert_eq!(m.strong_distinct_objects, 2);
        assert!((m.pd_distinct - 1.0).abs() < 1e-12);
        // no direct path: nothing to report on it
        assert_eq!(m.dp_suppression_db, None);
        assert!(m.detection_summary().contains("4 object-aperture pairs"));
        assert!(m
            .detection_summary()
            .contains("per distinct object: 1.000 of 2"));
        let (m, _) = fold([&b, &c], 1.0);
        assert_eq!(m.strong_distinct_objects, 1);
        assert_eq!(m.pd_distinct, 0.0);
    }
}
