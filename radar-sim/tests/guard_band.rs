//! The guard band imaged around the image grid (`processing.guard_band_m`): a single strong
//! object just beyond the grid's edge gives no detection inside the grid (its peak lies in the
//! band, and its sidelobes inside the grid are edited against it), while without the band its
//! sidelobes inside the grid are detected as objects; an object just inside the edge is still
//! detected, at its position.
//!
//! No range or azimuth taper, so that the sidelobes (−13 dB) of an object at about 45 dB stand
//! far above the CFAR threshold; thermal noise on (the CFAR runs on noise as in the main job).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use radar_sim::config::{ProcessingConfig, SceneFile, Weighting, DEFAULT_GUARD_BAND_M};
use radar_sim::pipeline::ApertureResult;
use radar_sim::synth::Components;

/// Processes one aperture centred on the origin with a single object at `pos` (RCS 10 m²,
/// about 45 dB in the multilook image), with a guard band of `guard_band_m` (None: the
/// default, 100 m).
fn image_one(pos: [f64; 2], guard_band_m: Option<f64>, heading_deg: f64) -> ApertureResult {
    let params = planner::Params::default();
    let mut sc = SceneFile::default();
    sc.processing.range_weighting = Weighting::None;
    sc.processing.azimuth_weighting = Weighting::None;
    sc.processing.grid_half_m = 30.0;
    sc.processing.guard_band_m = guard_band_m;
    sc.radar.direct_path = false;
    let proc = common::processor(&params, &sc);
    let setup = proc.setup().clone();
    let target = [0.0, 0.0];
    let track = common::track_through(&params, target, heading_deg, 20.0, 5.0);
    let ap = common::aperture(&setup, target, 0.0, 10);
    let pulses = common::pulses(&setup, &track, &ap);
    let objs = vec![common::object(1, pos, 10.0)];
    let iq = setup
        .synthesizer(objs.clone())
        .unwrap()
        .synthesize_frame(&pulses, Components::ALL)
        .unwrap();
    proc.process_aperture(&ap, &pulses, &iq, &objs).unwrap()
}

/// Positions 8 m beyond each of the four edges of the ±30 m grid.
const OUTSIDE: [[f64; 2]; 4] = [[38.0, 3.0], [-38.0, -5.0], [4.0, 38.0], [-6.0, -38.0]];

#[test]
fn an_object_beyond_the_edge_gives_no_detection_inside() {
    let mut without = 0;
    for (k, pos) in OUTSIDE.into_iter().enumerate() {
        let heading = 180.0 + 40.0 * k as f64;
        let r = image_one(pos, None, heading);
        let peak = r.multilook.iter().fold(0f32, |a, v| a.max(*v));
        println!(
            "object at {pos:?}, heading {heading}: peak in the grid {:.1} dB, {} detections with \
             the guard band",
            10.0 * (peak as f64).log10(),
            r.detections.len()
        );
        // the object's response reaches far into the grid (well above the CFAR threshold)
        assert!(peak > 1e2, "peak {peak}: the test needs a response inside");
        assert!(
            r.score.outcomes.is_empty(),
            "the object lies outside the scored grid"
        );
        assert!(
            r.detections.is_empty(),
            "object at {pos:?}: detections inside the grid {:?}",
            r.detections
        );
        let r0 = image_one(pos, Some(0.0), heading);
        println!(
            "  without the guard band: {} detections",
            r0.detections.len()
        );
        without += r0.detections.len();
    }
    // the test is sensitive: without the band, the same responses are detected as objects
    assert!(
        without >= 4,
        "only {without} detections without the guard band"
    );
}

#[test]
fn an_object_just_inside_the_edge_is_still_detected() {
    for (k, pos) in OUTSIDE.into_iter().enumerate() {
        let heading = 180.0 + 40.0 * k as f64;
        // 3 m inside the same edge
        let inside = pos.map(|v| if v.abs() > 30.0 { v.signum() * 27.0 } else { v });
        let r = image_one(inside, None, heading);
        let o = r.score.outcomes.first().expect("the object is in the grid");
        let err = o.error_m.unwrap_or(f64::NAN);
        println!(
            "object at {inside:?}: detected {} (error {err:.2} m), {} false alarms",
            o.detection.is_some(),
            r.score.false_alarms.len()
        );
        assert!(o.detection.is_some(), "object at {inside:?} missed");
        assert!(err < 1.0, "position error {err} m");
        assert!(
            r.score.false_alarms.is_empty(),
            "false alarms {:?}",
            r.score.false_alarms
        );
    }
}

/// The guard band changes nothing inside the grid but the detections: the reported multilook
/// image is the larger image's centre, equal to the image of the reported grid alone (to the
/// single-precision rounding of range profiles computed over a longer range window).
#[test]
fn the_reported_image_is_the_same_with_and_without_the_band() {
    let a = image_one([5.0, -3.0], None, 200.0);
    let b = image_one([5.0, -3.0], Some(0.0), 200.0);
    assert_eq!(a.grid, b.grid);
    assert_eq!(a.multilook.len(), b.multilook.len());
    let worst = a
        .multilook
        .iter()
        .zip(&b.multilook)
        .map(|(x, y)| ((x - y).abs() / (1.0 + y.abs())) as f64)
        .fold(0.0, f64::max);
    assert!(worst < 2e-3, "largest relative difference {worst}");
}

/// The default band is 100 m wide whatever the image's size (the reach of responses from
/// beyond the edge is the resolution cell's, not the image's): the guard grid of a ±30 m image
/// spans ±130 m at 4 × the pixel spacing; 0 turns it off and an explicit width is kept.
#[test]
fn the_default_band_is_100_m_whatever_the_grid() {
    assert_eq!(DEFAULT_GUARD_BAND_M, 100.0);
    let params = planner::Params::default();
    let ap_centre = [12.0, -7.0];
    for (grid_half_m, band, want_half_m) in [
        (30.0, None, Some(130.0)),
        (50.0, None, Some(150.0)),
        (50.0, Some(50.0), Some(100.0)),
        (50.0, Some(0.0), None),
    ] {
        let mut sc = SceneFile::default();
        sc.processing.grid_half_m = grid_half_m;
        sc.processing.guard_band_m = band;
        let proc = common::processor(&params, &sc);
        let setup = proc.setup().clone();
        let ap = common::aperture(&setup, ap_centre, 0.0, 2);
        let g = setup.guard_grid(&ap);
        match want_half_m {
            None => assert!(g.is_none(), "band {band:?}: a guard grid {g:?}"),
            Some(half_m) => {
                let g = g.expect("a guard grid");
                let spacing_m = 4.0 * sc.processing.pixel_m;
                assert!((g.spacing_m - spacing_m).abs() < 1e-12, "{g:?}");
                let n = 2 * (half_m / spacing_m).round() as usize + 1;
                assert_eq!((g.nx, g.ny), (n, n), "grid ±{grid_half_m} m, band {band:?}");
                assert_eq!(g.centre_m, ap_centre);
            }
        }
    }
}

/// The default band's grid is checked too: at a pixel spacing so fine that it would exceed
/// the grid limit, the error names `processing.guard_band_m` and says it is the default.
#[test]
fn a_default_band_too_fine_to_image_is_refused_by_name() {
    let pc = ProcessingConfig {
        grid_half_m: 5.0,
        pixel_m: 0.01,
        ..ProcessingConfig::default()
    };
    let err = pc
        .validate()
        .expect_err("a 5250-pixel guard grid")
        .to_string();
    assert!(
        err.contains("processing.guard_band_m") && err.contains("default"),
        "{err}"
    );
    // a narrower band or none is accepted
    for g in [10.0, 0.0] {
        let pc = ProcessingConfig {
            guard_band_m: Some(g),
            ..pc.clone()
        };
        pc.validate().unwrap();
    }
}
