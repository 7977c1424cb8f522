//! End to end under the default NR cell with `pilots`: a strong object whose echo lies far
//! beyond the cyclic prefix, the recording synthesised with noise and the direct path, processed
//! by `process_aperture`. Its pilots' ghost focuses beside it in range; the processor's exact
//! sidelobe editing, with the ghost in the object's response, leaves no false alarm, and the same
//! look images edited without the ghost (the response before the model) keep false alarms
//! there, along the object's line of equal Doppler.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use radar_sim::cfar::LookImages;
use radar_sim::config::{NrConfig, SceneFile};
use radar_sim::nr::Reference;
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::synth::Components;
use radar_sim::track::{plan_apertures, plan_pulses, LinearTrack};

#[test]
fn a_strong_echo_beyond_the_cp_leaves_no_ghost_detection() {
    let params = planner::Params::default();
    let mut scene = SceneFile::default();
    scene.radar.reference = Reference::Pilots;
    scene.radar.nr = Some(NrConfig::default());
    // the look images are kept, to edit them again without the ghost; no guard band, so that
    // the second editing needs only the grid's images
    scene.processing.save_complex = true;
    scene.processing.guard_band_m = Some(0.0);
    let setup = RadarSetup::new(&params, &scene).unwrap();
    let proc = Processor::new(setup.clone()).unwrap();
    let target = [-400.0, 200.0];
    let looks = 4.0;
    let t_mid = 0.5 * looks * setup.look_s;
    let track = LinearTrack::through(&params, target, 225.0, 20.0, t_mid);
    let ap = plan_apertures(
        &[(target, Some(0), 0.0, looks * setup.look_s)],
        setup.look_s,
        setup.scene.radar.prf_hz,
    )
    .unwrap()
    .remove(0);
    let pulses = plan_pulses(
        &track,
        &setup.num,
        setup.bs_m,
        &ap,
        setup.scene.radar.prf_hz,
    );
    let mid = &pulses[pulses.len() / 2];
    let delay = setup
        .geometry()
        .delay_samples(target, mid.pos_m, mid.window_delay_samples);
    let cp = setup.num.cp_samples as f64;
    eprintln!("the object's echo: {:.0} samples beyond the CP", delay - cp);
    assert!(delay > cp + 400.0, "{delay}");
    let object = SceneObject {
        id: 0,
        x_m: target[0],
        y_m: target[1],
        rcs_m2: 1000.0,
        phase_rad: 0.0,
        landmark: Some(0),
    };
    let iq = setup
        .synthesizer(vec![object])
        .unwrap()
        .synthesize_frame(&pulses, Components::ALL)
        .unwrap();
    let r = proc
        .process_aperture(&ap, &pulses, &iq, std::slice::from_ref(&object))
        .unwrap();
    let snr = r.score.outcomes[0].truth.expected_snr_db;
    eprintln!(
        "with the ghost: {} detections, {} false alarms, the object's expected SNR {snr:.1} dB",
        r.detections.len(),
        r.score.false_alarms.len()
    );
    assert_eq!(r.score.detected(), 1);
    // its ghost, about 35 dB under it, well over the noise
    assert!(snr > 55.0, "{snr}");
    assert!(r.score.false_alarms.is_empty(), "{:?}", r.detections);

    // the same images edited against the response without the ghost
    let grid = setup.grid(&ap);
    let ppl = ap.pulses_per_look;
    let c = proc
        .compress(&grid, &pulses, &iq, ppl, Some(ap.centre_m), false)
        .unwrap();
    let exact = proc.exact_response(&c, &ap);
    let gains = |q: [f64; 2]| proc.pulse_gains(&pulses, q);
    let scale = 1.0 / (proc.look_noise_var(ppl) * ap.looks as f64);
    let bare = proc
        .detect_edited(
            &ap,
            &pulses,
            &r.multilook,
            None,
            Some(LookImages {
                response: &exact,
                grid: &r.looks,
                band_grid: None,
                band: &[],
                scale,
                gains: &gains,
                ghosts: None,
            }),
        )
        .unwrap();
    // the scoring's gate (the same as `process_aperture`'s)
    let gate = setup
        .scene
        .processing
        .match_radius_m
        .unwrap_or(params.d_min_m / 2.0);
    let ghosts: Vec<_> = bare
        .detections
        .iter()
        .filter(|d| (d.x_m - target[0]).hypot(d.y_m - target[1]) > gate)
        .collect();
    eprintln!(
        "without the ghost: {} detections, {} away from the object: {:?}",
        bare.detections.len(),
        ghosts.len(),
        ghosts
    );
    assert!(!ghosts.is_empty());
    // beside it (measured 37–57 m away)
    for d in &ghosts {
        assert!(
            (d.x_m - target[0]).hypot(d.y_m - target[1]) < 100.0,
            "{d:?}"
        );
    }
}
