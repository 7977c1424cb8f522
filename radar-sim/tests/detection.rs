//! Acceptance: Poisson objects no closer than d_min; Pd ≥ 0.95 for objects with image SNR ≥ 13 dB,
//! position error ≤ max(δ_r, δ_a); on noise (and a cancelled direct path) only, the CFAR's
//! exceedance pixels and its false-alarm detections match their design counts (P_fa × pixels,
//! and the Euler-characteristic count of `cfar::expected_peaks_per_m2`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use radar_sim::config::{SceneFile, Weighting};
use radar_sim::synth::Components;

fn scene(pfa: f64) -> SceneFile {
    let mut s = SceneFile::default();
    // a low-power small cell so that object SNRs spread around the detection threshold
    s.radar.tx_power_w = 0.04;
    s.processing.range_weighting = Weighting::Hann;
    s.processing.azimuth_weighting = Weighting::Hann;
    s.processing.pfa = pfa;
    s
}

#[test]
fn poisson_scene_detection_and_scoring() {
    let params = planner::Params::default();
    let target = [0.0, 0.0];
    let mut strong = 0usize;
    let mut strong_hit = 0usize;
    let mut errors = Vec::new();
    let (mut fa_px, mut clear_px, mut fa_clusters) = (0usize, 0usize, 0usize);
    let mut design_clusters = 0.0;
    let pfa = 1e-4;
    for seed in 0..3u64 {
        let sc = scene(pfa);
        let proc = common::processor(&params, &sc);
        let setup = proc.setup().clone();
        let objs_cfg = radar_sim::config::ObjectsConfig {
            count: Some(12),
            radius_m: 45.0,
            center_m: Some(target),
            seed,
            min_separation_m: Some(params.d_min_m),
            rcs_m2: 2.5,
            rcs_spread_db: 12.0,
            include_landmarks: false,
            ..Default::default()
        };
        let objs = radar_sim::scene::generate(&objs_cfg, &[], params.d_min_m).unwrap();
        let track = common::track_through(&params, target, 180.0, 20.0, 2.0);
        let ap = common::aperture(&setup, target, 0.0, 4);
        let pulses = common::pulses(&setup, &track, &ap);
        let synth = setup.synthesizer(objs.clone()).unwrap();
        let iq = synth.synthesize_frame(&pulses, Components::ALL).unwrap();
        let r = proc.process_aperture(&ap, &pulses, &iq, &objs).unwrap();
        let dr = r.cell.range_width_m;
        let da = r.cell.along_track_width_m;
        for o in &r.score.outcomes {
            println!(
                "seed {seed} obj {:2} snr {:5.1} dB detected {} err {:?}",
                o.truth.id,
                o.truth.expected_snr_db,
                o.detection.is_some(),
                o.error_m
            );
            if o.truth.expected_snr_db >= 13.0 {
                strong += 1;
                if let Some(e) = o.error_m {
                    strong_hit += 1;
                    errors.push(e);
                    assert!(
                        e <= dr.max(da),
                        "position error {e} m > max(δ_r, δ_a) = {}",
                        dr.max(da)
                    );
                }
            }
        }
        fa_px += r.false_alarm_pixels;
        clear_px += r.clear_pixels;
        fa_clusters += r.score.false_alarms.len();
        design_clusters += r.design_false_alarms;
    }
    let pd = strong_hit as f64 / strong as f64;
    let design = pfa * clear_px as f64;
    println!("Pd(SNR ≥ 13 dB) = {pd:.3} ({strong_hit}/{strong}); false-alarm pixels {fa_px} (design {design:.1}); false-alarm clusters {fa_clusters} (design {design_clusters:.2})");
    assert!(
        strong >= 10,
        "too few strong objects ({strong}) for a meaningful Pd"
    );
    assert!(pd >= 0.95, "Pd {pd}");
    // design counts this low cannot be checked to a factor 2 here (see the noise test below);
    // check that the scene adds no false alarms beyond a few
    assert!(
        fa_clusters as f64 <= 2.0 * design_clusters + 2.0,
        "{fa_clusters} false-alarm clusters"
    );
    assert!(
        fa_px as f64 <= 2.0 * design + 100.0,
        "{fa_px} false-alarm pixels"
    );
}

/// Noise (and a cancelled direct path) only, at P_fa = 1e-2 and 1e-3: the CFAR's exceedance
/// pixels match P_fa × the pixels tested, every pixel is tested, and the false-alarm detections
/// (noise peaks after non-maximum suppression) match the Euler-characteristic design count
/// (the previous design, one detection per exceeding coherence area, was 6.5× too low at 1e-3).
#[test]
fn false_alarms_match_their_designs_on_noise() {
    let params = planner::Params::default();
    let target = [0.0, 0.0];
    for pfa in [1e-2, 1e-3] {
        let (mut fa_px, mut clear, mut tested) = (0usize, 0usize, 0usize);
        let (mut dets, mut design) = (0usize, 0.0);
        for (i, heading) in [180.0, 225.0, 250.0].into_iter().enumerate() {
            let mut sc = scene(pfa);
            sc.processing.grid_half_m = 100.0;
            sc.processing.pixel_m = 0.5;
            sc.radar.seed = 7 + i as u64;
            let proc = common::processor(&params, &sc);
            let setup = proc.setup().clone();
            let track = common::track_through(&params, target, heading, 20.0, 2.0);
            let ap = common::aperture(&setup, target, 10.0 * i as f64, 4);
            let pulses = common::pulses(&setup, &track, &ap);
            let synth = setup.synthesizer(vec![]).unwrap();
            let iq = synth.synthesize_frame(&pulses, Components::ALL).unwrap();
            let r = proc.process_aperture(&ap, &pulses, &iq, &[]).unwrap();
            let mean =
                r.multilook.iter().map(|v| *v as f64).sum::<f64>() / r.multilook.len() as f64;
            println!(
                "P_fa {pfa:e}, heading {heading}: mean normalised noise {mean:.3}, floor {:.3}, FA pixels {} of {} (fallback {}), detections {} (design {:.2})",
                r.image_floor,
                r.false_alarm_pixels,
                r.clear_pixels,
                r.cfar_fallback_pixels,
                r.detections.len(),
                r.design_false_alarms
            );
            assert!(
                (r.image_floor - 1.0).abs() < 0.05,
                "floor {}",
                r.image_floor
            );
            fa_px += r.false_alarm_pixels;
            clear += r.clear_pixels;
            tested += r.grid.pixels();
            dets += r.score.false_alarms.len();
            design += r.design_false_alarms;
        }
        // no objects: every pixel is clear (and tested)
        assert_eq!(clear, tested);
        let design_px = pfa * clear as f64;
        println!(
            "P_fa {pfa:e}: false-alarm pixels {fa_px} (design {design_px:.1}), detections {dets} (design {design:.1})"
        );
        assert!(
            (fa_px as f64) >= design_px / 2.0 && (fa_px as f64) <= design_px * 2.0,
            "{fa_px} vs {design_px}"
        );
        // the detections come in few, Poisson-distributed numbers: a factor 2 and 3σ
        let slack = 3.0 * design.sqrt();
        assert!(
            (dets as f64) >= design / 2.0 - slack && (dets as f64) <= 2.0 * design + slack,
            "{dets} detections vs design {design}"
        );
        assert!(design >= 5.0, "design {design}: too few for a check");
    }
}
