//! Acceptance: measured −3 dB range and Doppler widths of a point target are within 15% of the
//! general predictions (erratum 11 (docs/paper-notes.md), × 0.886) for B = 50, 100, 150 MHz at several
//! positions along the track (different bistatic angles).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use radar_sim::config::SceneFile;
use radar_sim::synth::Components;

#[test]
fn point_target_widths_match_general_predictions() {
    // (target, heading) pairs: different bistatic angles and gradient orientations
    let cases: [([f64; 2], f64); 3] = [
        ([0.0, 0.0], 180.0),
        ([300.0, 500.0], 270.0),
        ([-400.0, 200.0], 225.0),
    ];
    let mut rows = Vec::new();
    for b in [50e6, 100e6, 150e6] {
        for (target, heading) in cases {
            let params = planner::Params {
                bandwidth_hz: b,
                ..Default::default()
            };
            let mut scene = SceneFile::default();
            scene.radar.thermal_noise = false;
            scene.radar.direct_path = false;
            scene.processing.canceller = radar_sim::config::CancellerKind::None;
            let proc = common::processor(&params, &scene);
            let setup = proc.setup().clone();
            let track = common::track_through(&params, target, heading, 20.0, 0.5);
            let ap = common::aperture(&setup, target, 0.0, 1);
            let pulses = common::pulses(&setup, &track, &ap);
            let synth = setup
                .synthesizer(vec![common::object(0, target, 10.0)])
                .unwrap();
            let iq = synth.synthesize_frame(&pulses, Components::ALL).unwrap();
            let grid = setup.grid(&ap);
            let c = proc
                .compress(&grid, &pulses, &iq, ap.pulses_per_look, None, true)
                .unwrap();
            let r = proc
                .measure_resolution(&c, &pulses, 0..pulses.len(), target)
                .unwrap();
            rows.push(format!(
                "B={:>3} MHz target={:?} β={:6.1}° ψ={:5.1}°: range {:.3} m (general {:.3}, paper δ_r {:.3}); azimuth {:.3} m (general {:.3}, paper δ_a {:.3})",
                b / 1e6, target, r.bistatic_angle_deg, r.psi_deg, r.range_measured_m, r.range_general_m, r.range_paper_m,
                r.azimuth_measured_m, r.azimuth_general_m, r.azimuth_paper_m
            ));
            assert!(r.range_error().abs() < 0.15, "{}", rows.last().unwrap());
            assert!(r.azimuth_error().abs() < 0.15, "{}", rows.last().unwrap());
        }
    }
    for r in rows {
        println!("{r}");
    }
}

/// The principal −3 dB widths of the measured point response (its −3 dB region traced in 40
/// directions and along the predicted major axis, not two cuts) agree with the predicted cell
/// within 10 % away from blind geometry, and its longest chord (the worst width) with the major
/// axis of the predicted −3 dB ellipse within 3 %; within a few degrees of blind the measured
/// cross-track width is large, as predicted. At `b_hz` = 150 MHz the range width is a quarter of
/// the along-track width; at 30 MHz the two are comparable, where the longest chord is up to √2
/// shorter than the parallelogram's longer side. (The cases of `cellsar-radar-sim resolution`.)
fn principal_widths_match_the_cell(b_hz: f64) {
    let params = radar_sim::psf::params_at(b_hz);
    for case in radar_sim::psf::default_cases() {
        let t = std::time::Instant::now();
        let r = radar_sim::psf::measure_case(&params, &case).unwrap();
        let e = r.errors();
        println!(
            "{} at {:.0} MHz: β = {:.1}°, ψ = {:.1}°; range {:.3} m (pred {:.3}), along-track {:.3} (pred {:.3}), cross-track {:.2} (pred {:.2}), iso-range {:.2} (pred {:.2}), worst {:.2} (pred {:.2}, planner {:.2}); errors {:+.4?}, worst {:+.4}; paper δ_r {:.2}, δ_a {:.2}; {:.2} s",
            case.label, b_hz / 1e6, r.bistatic_angle_deg, r.psi_deg, r.range_width_m, r.range_width_pred_m,
            r.along_track_width_m, r.along_track_width_pred_m, r.cross_track_width_m,
            r.cross_track_width_pred_m, r.iso_range_width_m, r.iso_range_width_pred_m,
            r.worst_width_m, r.worst_width_pred_m, r.planner_worst_width_m, e, r.worst_width_error(),
            r.paper_range_m, r.paper_azimuth_m, t.elapsed().as_secs_f64()
        );
        assert!(
            r.worst_width_m >= r.cross_track_width_m.max(r.iso_range_width_m) - 1e-9,
            "the longest chord is at least each measured chord: {r:?}"
        );
        if case.near_blind {
            assert!(r.psi_deg < 8.0, "not near blind: ψ = {}", r.psi_deg);
            assert!(
                r.cross_track_width_m > 5.0 * r.range_width_m
                    && r.cross_track_width_m > 0.5 * r.cross_track_width_pred_m
                    && r.cross_track_width_m < 2.0 * r.cross_track_width_pred_m,
                "{r:?}"
            );
            assert!(r.worst_width_m > params.d_min_m, "{r:?}");
        } else {
            assert!(r.psi_deg > 20.0, "ψ = {}", r.psi_deg);
            for (k, err) in e.iter().enumerate() {
                assert!(err.abs() < 0.10, "width {k}: error {err:.3}: {r:?}");
            }
            assert!(
                r.worst_width_error().abs() < 0.03,
                "worst width: error {:.4}: {r:?}",
                r.worst_width_error()
            );
        }
    }
}

#[test]
fn principal_and_worst_widths_match_the_cell_at_150_mhz() {
    principal_widths_match_the_cell(150e6);
}

#[test]
fn principal_and_worst_widths_match_the_cell_where_the_widths_are_comparable() {
    principal_widths_match_the_cell(30e6);
}
