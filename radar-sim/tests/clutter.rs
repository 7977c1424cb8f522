//! Ground clutter (`[clutter]`, `radar_sim::clutter`): the images of constant-γ clutter against
//! their closed forms, and the CFAR against clutter.
//!
//! - the mean clutter power of an image is σ⁰ × the response's integrated area × the radar
//!   equation's factors (the expected SNR of a point of that RCS), within 4 standard deviations
//!   of a mean of exponential pixels over the image's independent cells;
//! - the single-look amplitudes are Rayleigh: mean² / mean-square = π/4;
//! - on clutter 20 dB above the noise the CFAR's exceedance pixels stay at P_fa × the pixels
//!   tested, and its false-alarm detections at their design count;
//! - an object 15 dB above the clutter is detected;
//! - with clutter off a recording is what it was before the table existed, byte for byte.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use radar_sim::clutter::{look_resolution_areas_m2, sigma0, GroundClutter};
use radar_sim::config::{CancellerKind, ClutterConfig, SceneFile, Weighting};
use radar_sim::pipeline::{ApertureResult, Processor};
use radar_sim::scene::SceneObject;
use radar_sim::synth::Components;
use radar_sim::track::{Aperture, PulseMeta};

const TARGET: [f64; 2] = [0.0, 0.0];
const LOOKS: usize = 4;

fn scene(gamma_db: f64) -> SceneFile {
    let mut s = SceneFile::default();
    s.processing.range_weighting = Weighting::Hann;
    s.processing.azimuth_weighting = Weighting::Hann;
    s.processing.grid_half_m = 40.0;
    s.processing.pixel_m = 0.5;
    s.clutter = ClutterConfig {
        enabled: true,
        gamma_db: Some(gamma_db),
        seed: 5,
        ..Default::default()
    };
    s
}

/// One aperture of [`LOOKS`] looks over `TARGET` with the scene's clutter (and `objects`):
/// the processed result, the clutter model, the aperture and its pulses.
fn image(
    sc: &SceneFile,
    objects: &[SceneObject],
    heading_deg: f64,
) -> (
    ApertureResult,
    Processor,
    GroundClutter,
    Aperture,
    Vec<PulseMeta>,
) {
    let params = planner::Params::default();
    let proc = common::processor(&params, sc);
    let setup = proc.setup().clone();
    let track = common::track_through(&params, TARGET, heading_deg, 20.0, 2.0);
    let ap = common::aperture(&setup, TARGET, 0.0, LOOKS);
    let pulses = common::pulses(&setup, &track, &ap);
    let clutter = GroundClutter::for_run(&setup, &track, std::slice::from_ref(&ap))
        .unwrap()
        .unwrap();
    let synth = clutter.synthesizer(&setup, objects, &ap, &pulses).unwrap();
    println!(
        "{} scatterers {:.2} m apart",
        synth.objects().len() - objects.len(),
        clutter.spacing_m
    );
    let iq = synth.synthesize_frame(&pulses, Components::ALL).unwrap();
    let r = proc.process_aperture(&ap, &pulses, &iq, objects).unwrap();
    (r, proc, clutter, ap, pulses)
}

/// The closed form of the clutter-to-noise ratio of look `l` at `p_m`: the expected SNR of a
/// point of RCS σ⁰(p) A_l(p) (A_l the look's integrated response area).
fn predicted_cnr(
    proc: &Processor,
    clutter: &GroundClutter,
    ap: &Aperture,
    pulses: &[PulseMeta],
    p_m: [f64; 2],
) -> Vec<f64> {
    let setup = proc.setup();
    let uav = pulses[pulses.len() / 2].pos_m;
    let s0 = sigma0(clutter.gamma, setup.bs_m, uav, p_m);
    let areas = look_resolution_areas_m2(setup, ap, pulses, p_m);
    let ppl = ap.pulses_per_look;
    areas
        .iter()
        .enumerate()
        .map(|(l, a)| {
            let o = common::object(0, p_m, s0 * a);
            10f64.powf(proc.expected_snr_db(&o, &pulses[l * ppl..(l + 1) * ppl]) / 10.0)
        })
        .collect()
}

/// Clutter only (no noise, no direct path): the images' mean power and amplitude statistics
/// against the closed forms.
#[test]
fn clutter_images_match_the_closed_form_and_are_rayleigh() {
    let mut sc = scene(-10.0);
    sc.radar.thermal_noise = false;
    sc.radar.direct_path = false;
    sc.processing.canceller = CancellerKind::None;
    sc.processing.save_complex = true;
    let (r, proc, clutter, ap, pulses) = image(&sc, &[], 200.0);
    let g = &r.grid;
    // pixels on a 4-pixel lattice (the closed form per pixel costs a pass over the pulses)
    let step = 4;
    let (mut meas, mut pred) = (0.0, 0.0);
    let mut per_look_pred = vec![Vec::new(); LOOKS];
    let mut n = 0usize;
    for iy in (0..g.ny).step_by(step) {
        for ix in (0..g.nx).step_by(step) {
            let c = predicted_cnr(&proc, &clutter, &ap, &pulses, [g.x(ix), g.y(iy)]);
            meas += r.multilook[iy * g.nx + ix] as f64;
            pred += c.iter().sum::<f64>() / LOOKS as f64;
            for (l, v) in c.iter().enumerate() {
                per_look_pred[l].push((iy * g.nx + ix, *v));
            }
            n += 1;
        }
    }
    let (meas, pred) = (meas / n as f64, pred / n as f64);
    // independent cells: the image's pixels over its pixels per coherence area, per look
    let cells = (g.pixels() as f64 / r.pixels_per_cell).min(n as f64) * LOOKS as f64;
    let sd = 1.0 / cells.sqrt();
    println!(
        "mean clutter-to-noise {meas:.3} (closed form {pred:.3}, ratio {:.4}), {cells:.0} \
         independent cells, relative sd {sd:.4}",
        meas / pred
    );
    assert!(
        pred > 10.0,
        "closed form {pred}: the scene should be clutter"
    );
    assert!(
        (meas / pred - 1.0).abs() <= 4.0 * sd,
        "measured {meas} vs closed form {pred}: {:.1} sd",
        (meas / pred - 1.0) / sd
    );
    // Rayleigh: on amplitudes normalised by the closed form's per-pixel level, mean² / mean
    // square = π/4; the estimate's standard deviation is 0.24/√N (delta method on Rayleigh
    // moments)
    let (mut m1, mut m2, mut k) = (0.0, 0.0, 0usize);
    for (l, img) in r.looks.iter().enumerate() {
        for (i, c) in &per_look_pred[l] {
            let a = (img[*i].norm_sqr() as f64 / r.noise_var / c).sqrt();
            m1 += a;
            m2 += a * a;
            k += 1;
        }
    }
    let (m1, m2) = (m1 / k as f64, m2 / k as f64);
    let ratio = m1 * m1 / m2;
    let sd = 0.24 / cells.sqrt();
    println!(
        "amplitude mean²/mean-square {ratio:.4} (Rayleigh π/4 = {:.4}, sd {sd:.4})",
        std::f64::consts::FRAC_PI_4
    );
    assert!(
        (ratio - std::f64::consts::FRAC_PI_4).abs() <= 4.0 * sd,
        "{ratio}"
    );
}
