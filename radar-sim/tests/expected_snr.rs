//! The expected per-look SNR of an object (`Processor::expected_snr_db`, which decides what
//! counts as strong for Pd) against the peak of its noise-free image: equal inside the cyclic
//! prefix, and beyond it too, where the window holds part of the previous symbol and the
//! object loses that fraction of its coherent gain (physics review, finding 3).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use radar_sim::config::{CancellerKind, SceneFile};
use radar_sim::pipeline::cp_overlap_factor;
use radar_sim::synth::Components;

/// (expected SNR, image peak over the noise) of one object, dB, and its delay into the window.
fn expected_and_measured(cp_samples: usize) -> (f64, f64, f64) {
    let params = planner::Params::default();
    let mut scene = SceneFile::default();
    scene.radar.cp_samples = cp_samples;
    scene.radar.thermal_noise = false;
    scene.radar.direct_path = false;
    scene.processing.canceller = CancellerKind::None;
    let proc = common::processor(&params, &scene);
    let setup = proc.setup().clone();
    let target = [0.0, 0.0];
    let track = common::track_through(&params, target, 180.0, 20.0, 0.5);
    let ap = common::aperture(&setup, target, 0.0, 1);
    let pulses = common::pulses(&setup, &track, &ap);
    let obj = common::object(0, target, 10.0);
    let iq = setup
        .synthesizer(vec![obj])
        .unwrap()
        .synthesize_frame(&pulses, Components::ALL)
        .unwrap();
    let c = proc
        .compress(
            &setup.grid(&ap),
            &pulses,
            &iq,
            ap.pulses_per_look,
            None,
            true,
        )
        .unwrap();
    let peak = proc
        .image_points_exact(&c, 0..pulses.len(), &[target])
        .unwrap()[0]
        .norm_sqr();
    let measured = 10.0 * (peak / proc.look_noise_var(pulses.len())).log10();
    let mid = &pulses[pulses.len() / 2];
    let delay = setup
        .geometry()
        .delay_samples(target, mid.pos_m, mid.window_delay_samples);
    (proc.expected_snr_db(&obj, &pulses), measured, delay)
}

#[test]
fn expected_snr_matches_the_image_peak_inside_and_beyond_the_cyclic_prefix() {
    // the same echo, about 1190 samples into the window, with a CP of 2048 (inside), 1024 (the
    // default: ~165 samples beyond) and 256 (~930 beyond)
    let (inside, inside_measured, delay) = expected_and_measured(2048);
    println!("CP 2048: echo {delay:.0} samples into the window, expected {inside:.3} dB, image {inside_measured:.3} dB");
    assert!(delay < 2048.0);
    assert!((inside - inside_measured).abs() < 0.1);
    for cp in [1024usize, 256] {
        let (beyond, measured, delay) = expected_and_measured(cp);
        let f = cp_overlap_factor(delay, 4096, cp);
        println!("CP {cp}: echo {delay:.0} samples into the window (overlap {f:.3}), expected {beyond:.3} dB, image {measured:.3} dB");
        assert!(
            delay > cp as f64 + 100.0,
            "the echo is not beyond the CP: {delay}"
        );
        assert!((beyond - measured).abs() < 0.05, "{beyond} vs {measured}");
        // the loss is the coherent overlap, larger than the agreement required above
        let loss = inside - beyond;
        assert!(loss > 0.3, "{loss}");
        assert!(
            (loss + 20.0 * f.log10()).abs() < 0.05,
            "{loss} vs {}",
            -20.0 * f.log10()
        );
    }
}

#[test]
fn cp_overlap_factor_counts_the_samples_of_the_neighbouring_symbols() {
    assert_eq!(cp_overlap_factor(0.0, 4096, 1024), 1.0);
    assert_eq!(cp_overlap_factor(1024.0, 4096, 1024), 1.0);
    assert!((cp_overlap_factor(1024.0 + 409.6, 4096, 1024) - 0.9).abs() < 1e-12);
    assert!((cp_overlap_factor(-40.96, 4096, 1024) - 0.99).abs() < 1e-12);
    assert_eq!(cp_overlap_factor(1e6, 4096, 1024), 0.0);
}
