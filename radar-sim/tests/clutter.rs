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
        // the image and a margin of several resolution cells
        half_width_m: Some(55.0),
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

/// Clutter about 20 dB above the thermal noise (with the direct path and its canceller): the
/// CFAR, whose threshold follows the local clutter level, keeps its design false-alarm rate.
/// The exceedance pixels come in clumps, one per excursion above the threshold, of about
/// m = design pixels / design excursions pixels (the Euler-characteristic count of
/// `cfar::expected_peaks_per_m2`), so their count's standard deviation is √(design × m): the
/// count must lie within 4 of them of P_fa × the pixels tested. The detections (peaks after
/// non-maximum suppression) are Poisson: within a factor 2 and 3 standard deviations of their
/// design.
#[test]
fn cfar_keeps_its_false_alarm_rate_on_clutter() {
    let sc = scene(-25.0);
    let params = planner::Params::default();
    let probe = common::processor(&params, &sc);
    let setup = probe.setup().clone();
    let track = common::track_through(&params, TARGET, 200.0, 20.0, 2.0);
    let ap = common::aperture(&setup, TARGET, 0.0, LOOKS);
    let pulses = common::pulses(&setup, &track, &ap);
    let clutter = GroundClutter::for_run(&setup, &track, std::slice::from_ref(&ap))
        .unwrap()
        .unwrap();
    let iq = clutter
        .synthesizer(&setup, &[], &ap, &pulses)
        .unwrap()
        .synthesize_frame(&pulses, Components::ALL)
        .unwrap();
    let cnr = predicted_cnr(&probe, &clutter, &ap, &pulses, TARGET);
    let cnr_db = 10.0 * (cnr.iter().sum::<f64>() / LOOKS as f64).log10();
    assert!(
        cnr_db > 15.0,
        "clutter-to-noise {cnr_db} dB: not clutter-dominated"
    );
    for pfa in [1e-2, 1e-3] {
        let mut s = sc.clone();
        s.processing.pfa = pfa;
        let r = common::processor(&params, &s)
            .process_aperture(&ap, &pulses, &iq, &[])
            .unwrap();
        let design_px = pfa * r.clear_pixels as f64;
        let clump = design_px / r.design_false_alarms.max(1e-9);
        let sd_px = (design_px * clump).sqrt();
        println!(
            "P_fa {pfa:e}: clutter-to-noise {cnr_db:.1} dB at the centre, floor {:.1}, \
             exceedance pixels {} of {} (design {design_px:.1} ± {sd_px:.1}), fallback {}, \
             detections {} (design {:.1})",
            r.image_floor,
            r.false_alarm_pixels,
            r.clear_pixels,
            r.cfar_fallback_pixels,
            r.score.false_alarms.len(),
            r.design_false_alarms
        );
        assert_eq!(
            r.clear_pixels,
            r.grid.pixels(),
            "no objects: every pixel is clear"
        );
        let fa = r.false_alarm_pixels as f64;
        assert!(
            (fa - design_px).abs() <= 4.0 * sd_px,
            "{fa} exceedance pixels vs design {design_px} ± {sd_px}"
        );
        let (dets, design) = (r.score.false_alarms.len() as f64, r.design_false_alarms);
        let slack = 3.0 * design.sqrt();
        assert!(
            dets >= design / 2.0 - slack && dets <= 2.0 * design + slack,
            "{dets} false-alarm detections vs design {design}"
        );
    }
}

/// Objects 15 dB above the clutter (and the noise) in the multilook image are detected: the
/// RCS of each is 10^1.5 × (the clutter-to-noise closed form + 1) over the SNR per m².
#[test]
fn objects_above_the_clutter_are_detected() {
    let sc = scene(-25.0);
    let params = planner::Params::default();
    let probe = common::processor(&params, &sc);
    let setup = probe.setup().clone();
    let track = common::track_through(&params, TARGET, 220.0, 20.0, 2.0);
    let ap = common::aperture(&setup, TARGET, 0.0, LOOKS);
    let pulses = common::pulses(&setup, &track, &ap);
    let clutter = GroundClutter::for_run(&setup, &track, std::slice::from_ref(&ap))
        .unwrap()
        .unwrap();
    let ppl = ap.pulses_per_look;
    let scr_db = 15.0;
    let mut positions = vec![TARGET];
    for k in 0..6 {
        let a = std::f64::consts::TAU * k as f64 / 6.0;
        positions.push([22.0 * a.cos(), 22.0 * a.sin()]);
    }
    let objects: Vec<SceneObject> = positions
        .iter()
        .enumerate()
        .map(|(id, p)| {
            let cnr = predicted_cnr(&probe, &clutter, &ap, &pulses, *p);
            let cnr = cnr.iter().sum::<f64>() / LOOKS as f64;
            let unit = common::object(id, *p, 1.0);
            let snr_per_m2 = (0..LOOKS)
                .map(|l| {
                    10f64.powf(probe.expected_snr_db(&unit, &pulses[l * ppl..(l + 1) * ppl]) / 10.0)
                })
                .sum::<f64>()
                / LOOKS as f64;
            common::object(id, *p, 10f64.powf(scr_db / 10.0) * (cnr + 1.0) / snr_per_m2)
        })
        .collect();
    let (r, ..) = image(&sc, &objects, 220.0);
    for o in &r.score.outcomes {
        println!(
            "object {} at SNR {:.1} dB: detected {} (error {:?} m)",
            o.truth.id,
            o.truth.expected_snr_db,
            o.detection.is_some(),
            o.error_m
        );
    }
    println!("false alarms {}", r.score.false_alarms.len());
    assert_eq!(r.score.outcomes.len(), objects.len());
    assert!(
        r.score.outcomes.iter().all(|o| o.detection.is_some()),
        "an object {scr_db} dB above the clutter was missed"
    );
}

/// With `[clutter]` off a recording is byte for byte the one of a scene without the table, the
/// table stays out of `meta.json`, and clutter on adds no truth objects.
#[test]
fn clutter_off_is_the_recording_without_clutter() {
    let mission = planner::Mission::preset(planner::Preset::Default, 30.0).unwrap();
    let mission = radar_sim::run::shorten(&mission, 25.0).unwrap();
    let plan = planner::plan(&mission, &planner::PlanOptions::default()).unwrap();
    let mut base = SceneFile::default();
    base.radar.prf_hz = 20.0;
    let off = {
        let mut s = base.clone();
        s.clutter = ClutterConfig {
            enabled: false,
            terrain: Some(radar_sim::config::Terrain::Woods),
            seed: 3,
            ..Default::default()
        };
        s
    };
    let on = {
        let mut s = base.clone();
        s.clutter = ClutterConfig {
            enabled: true,
            scatterers_per_cell: 1.0,
            ..Default::default()
        };
        s
    };
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, scene: &SceneFile| {
        let out = dir.path().join(name);
        radar_sim::run::simulate(&mission, &plan.trajectory, scene, &out, &mut |_, _| {}).unwrap();
        out
    };
    let (a, b, c) = (run("base", &base), run("off", &off), run("on", &on));
    let read = |d: &std::path::Path, f: &str| std::fs::read(d.join(f)).unwrap();
    let iq: Vec<String> = std::fs::read_dir(a.join("iq"))
        .unwrap()
        .map(|e| format!("iq/{}", e.unwrap().file_name().to_string_lossy()))
        .collect();
    assert_eq!(iq.len(), 2);
    for f in iq
        .iter()
        .map(String::as_str)
        .chain(["pulses.csv", "truth.csv"])
    {
        assert!(read(&a, f) == read(&b, f), "{f} differs with clutter off");
    }
    assert_eq!(read(&a, "truth.csv"), read(&c, "truth.csv"));
    assert!(
        read(&a, &iq[0]) != read(&c, &iq[0]),
        "clutter on changed nothing"
    );
    let meta = String::from_utf8(read(&a, "meta.json")).unwrap();
    assert!(
        !meta.contains("clutter"),
        "the default scene serialises a [clutter] table"
    );
}
