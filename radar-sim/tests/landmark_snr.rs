//! The expected SNR of the landmarks at their apertures from the radar's link budget
//! (`run::landmark_snrs`), against
//!
//! - the closed form of the link budget's altitude-dependent terms: the same track flown at
//!   800 m and at 1200 m (a mission with `altitude = "free"`) changes each look's SNR by
//!   20 log10 of the ratio of Σ w f √G / R_r over its pulses (Hann weights w, the cyclic-prefix
//!   overlap f, the UAV antenna's gain G towards the landmark, the slant range R_r), computed
//!   here from the geometry alone; the BS's gain, the BS–landmark range, the RCS and the noise
//!   do not depend on the altitude;
//! - the closed loop: for a fixed plan, each aperture's figure is the landmark SNR the closed
//!   loop's processing reports (`report.json`'s `snr_db`) for the same plan.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use radar_sim::config::{CancellerKind, SceneFile};
use radar_sim::limits::IqLimits;
use radar_sim::run::{self, landmark_snrs, SnrSummary};
use radar_sim::waveform::C_MPS;

fn default_scene() -> SceneFile {
    SceneFile::from_path(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/default.toml"))
        .unwrap()
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn sinc(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x)
    }
}

/// One pulse's terms of the link budget that depend on the UAV's position: the Hann weight w,
/// the cyclic-prefix overlap f, the UAV antenna's gain towards the landmark relative to its peak
/// G and the slant range R_r, m, for each pulse of look `look` (pulse i at t = `t0_s` + l T +
/// (i + ½)/PRF) of a UAV flying north at `speed_mps` at `x_m`, through y = `y_mid_m` at
/// `t_mid_s`, climbing linearly from `start_m` at t = 0 to `altitude_m` at t = `slot_s` and
/// level after, towards the landmark `lm`.
fn look_terms(
    p: &planner::Params,
    scene: &SceneFile,
    lm: [f64; 2],
    (x_m, y_mid_m, t_mid_s, speed_mps): (f64, f64, f64, f64),
    (start_m, altitude_m): (f64, f64),
    (t0_s, look, pulses_per_look): (f64, usize, usize),
) -> Vec<[f64; 4]> {
    let r = &scene.radar;
    let lam = p.wavelength_m;
    let eta = p.observation_angle_rad;
    let fs = r.fft_size as f64 * r.subcarrier_spacing_hz;
    let bs = [p.bs_m[0], p.bs_m[1], p.bs_height_m];
    let q = [lm[0], lm[1], 0.0];
    let floor = 10f64.powf(r.sidelobe_floor_db / 10.0);
    // heading north: right of the track is +x, boresight (sin η, 0, −cos η), the aperture's
    // axes along track (0, 1, 0) and across h × b = (−cos η, 0, −sin η)
    let b = [eta.sin(), 0.0, -eta.cos()];
    let e = [-eta.cos(), 0.0, -eta.sin()];
    (0..pulses_per_look)
        .map(|i| {
            let t = t0_s + look as f64 * p.integration_time_s + (i as f64 + 0.5) / r.prf_hz;
            let z = start_m + (altitude_m - start_m) * (t / p.slot_s).min(1.0);
            let uav = [x_m, y_mid_m + speed_mps * (t - t_mid_s), z];
            let rr = dist(uav, q);
            let u = [
                (q[0] - uav[0]) / rr,
                (q[1] - uav[1]) / rr,
                (q[2] - uav[2]) / rr,
            ];
            let dot = |a: [f64; 3]| u[0] * a[0] + u[1] * a[1] + u[2] * a[2];
            assert!(dot(b) > 0.0);
            let f = sinc(r.antenna_length_m * u[1] / lam) * sinc(r.antenna_height_m * dot(e) / lam);
            let gain = (f * f).max(floor);
            let delay = (dist(bs, q) + rr) * fs / C_MPS - (dist(uav, bs) * fs / C_MPS).floor();
            let spill = (delay - r.cp_samples as f64).max(0.0) + (-delay).max(0.0);
            let overlap = (1.0 - spill / r.fft_size as f64).max(0.0);
            let x = (i as f64 + 0.5) / pulses_per_look as f64;
            let hann = 0.5 - 0.5 * (std::f64::consts::TAU * x).cos();
            [hann, overlap, gain, rr]
        })
        .collect()
}

#[test]
fn the_same_track_at_800_and_1200_m_changes_each_looks_snr_by_the_closed_form() {
    let scene = default_scene();
    let one = run::shorten(
        &planner::Mission::preset(planner::Preset::Default, 30.0).unwrap(),
        10.0,
    )
    .unwrap();
    let lm = one.schedule().landmarks[0].pos_m();
    let mut p = one.params().clone();
    // north at 10 m/s, the sensing centre at 1000 m passing the landmark at mid-window
    let (speed, t_mid) = (10.0, 5.0);
    let x = lm[0] - p.altitude_m * p.observation_angle_rad.tan();
    let at = |t: f64| [x, lm[1] + speed * (t - t_mid)];
    p.start_m = at(0.0);
    p.altitude = planner::AltitudeMode::Free;
    p.min_altitude_m = Some(600.0);
    p.max_altitude_m = Some(1300.0);
    let m = one.with_params(p.clone()).unwrap();
    let traj = planner::Trajectory {
        slot_s: p.slot_s,
        start_m: p.start_m,
        pos_m: (1..=m.slots()).map(|k| at(k as f64 * p.slot_s)).collect(),
    };
    let snr_at = |h: f64| {
        let z = vec![h; m.slots()];
        let ev = planner::evaluate::evaluate_with_altitudes(&m, &traj, &z).unwrap();
        let rows = landmark_snrs(&m, &traj, Some(&z), &ev, &scene).unwrap();
        assert_eq!(rows.len(), 1);
        rows.into_iter().next().unwrap()
    };
    let (low, high) = (snr_at(800.0), snr_at(1200.0));
    let looks = low.look_snr_db.len();
    let looks_in_window = (10.0 / p.integration_time_s + 1e-9).floor() as usize;
    assert_eq!(looks, looks_in_window);
    assert_eq!(high.look_snr_db.len(), looks);
    let ppl = (p.integration_time_s * scene.radar.prf_hz).round() as usize;
    let t0 = 0.5 * (10.0 - looks as f64 * p.integration_time_s);
    let track = (x, lm[1], t_mid, speed);
    let terms =
        |l: usize, h: f64| look_terms(&p, &scene, lm, track, (p.altitude_m, h), (t0, l, ppl));
    // Σ w f √G / R_r, the gain left out without `with_gain`
    let amplitude = |l: usize, h: f64, with_gain: bool| -> f64 {
        terms(l, h)
            .iter()
            .map(|[w, f, g, rr]| w * f * if with_gain { g.sqrt() } else { 1.0 } / rr)
            .sum()
    };
    let difference_db = |l: usize, with_gain: bool| {
        20.0 * (amplitude(l, 800.0, with_gain) / amplitude(l, 1200.0, with_gain)).log10()
    };
    let mut largest: f64 = 0.0;
    for l in 0..looks {
        let want = difference_db(l, true);
        let range_only = difference_db(l, false);
        let got = low.look_snr_db[l] - high.look_snr_db[l];
        eprintln!(
            "look {l}: 800 m {:.3} dB, 1200 m {:.3} dB: difference {got:.6} dB, closed form \
             {want:.6} dB (the range terms alone {range_only:.3} dB)",
            low.look_snr_db[l], high.look_snr_db[l]
        );
        assert!((got - want).abs() < 1e-6, "look {l}: {got} vs {want}");
        // the antenna's gain towards the landmark at the flown altitude counts: without it
        // the range terms alone are far off
        assert!(
            (got - range_only).abs() > 1.0,
            "look {l}: {got} vs {range_only}"
        );
        largest = largest.max(want.abs());
    }
    // an SNR that ignored the flown altitude would not move: here it moves by far more than
    // the agreement asked for above
    assert!(largest > 0.1, "{largest} dB");
    // the aperture's figure: the mean of the looks' linear SNRs
    for r in [&low, &high] {
        let mean = r
            .look_snr_db
            .iter()
            .map(|d| 10f64.powf(d / 10.0))
            .sum::<f64>()
            / looks as f64;
        assert!((r.snr_db - 10.0 * mean.log10()).abs() < 1e-9);
    }
    // the aperture's mean slant range and gain towards the landmark
    for (r, h) in [(&low, 800.0), (&high, 1200.0)] {
        let all: Vec<[f64; 4]> = (0..looks).flat_map(|l| terms(l, h)).collect();
        let n = all.len() as f64;
        let range_m = all.iter().map(|t| t[3]).sum::<f64>() / n;
        let gain_db = 10.0 * (all.iter().map(|t| t[2]).sum::<f64>() / n).log10();
        assert!(
            (r.mean_slant_range_m - range_m).abs() < 1e-6,
            "{h} m: {r:?}"
        );
        assert!((r.gain_db - gain_db).abs() < 1e-9, "{h} m: {r:?}");
        assert!((r.mean_altitude_m - h).abs() < 30.0, "{h} m: {r:?}");
    }
    // the summary is over the landmark apertures in view
    let s = SnrSummary::of(std::slice::from_ref(&low));
    if low.in_view() {
        assert_eq!(
            (s.apertures_in_view, s.min_db, s.mean_db),
            (1, low.snr_db, low.snr_db)
        );
    } else {
        assert_eq!(s.apertures_in_view, 0);
        assert!(s.min_db.is_nan() && s.mean_db.is_nan());
    }
}

#[test]
fn a_fixed_plan_gives_the_closed_loops_landmark_snr() {
    let m = run::shorten(
        &planner::Mission::preset(planner::Preset::Default, 30.0).unwrap(),
        25.0,
    )
    .unwrap();
    let plan = planner::plan(&m, &planner::PlanOptions::least_energy()).unwrap();
    // the default scene's radar; processing made cheap (only the landmarks, a small image, no
    // canceller and no direct path): none of it enters the expected SNR
    let mut scene = default_scene();
    scene.objects.count = Some(0);
    scene.objects.intensity_per_km2 = None;
    scene.radar.direct_path = false;
    scene.processing.canceller = CancellerKind::None;
    scene.processing.grid_half_m = 20.0;
    scene.processing.guard_band_m = Some(0.0);
    let rows = landmark_snrs(&m, &plan.trajectory, None, &plan.evaluation, &scene).unwrap();
    assert_eq!(rows.len(), m.schedule().landmarks.len());

    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("recording");
    run::simulate(&m, &plan.trajectory, &scene, &rec, &mut |_, _| {}).unwrap();
    let metrics = run::process_limited(
        &rec,
        &dir.path().join("processed"),
        &IqLimits::default(),
        &mut |_, _| {},
        &mut run::no_image_views,
    )
    .unwrap();
    let report = run::loop_report(&m, &plan.evaluation, metrics);
    assert_eq!(report.rows.len(), rows.len());
    for (ours, theirs) in rows.iter().zip(&report.rows) {
        let loop_snr = theirs.snr_db.expect("the landmark is a truth object");
        eprintln!(
            "aperture {}: landmark {} in view {:.2}: {:.4} dB, closed loop {loop_snr:.4} dB",
            ours.aperture, ours.landmark, ours.in_view_fraction, ours.snr_db
        );
        assert_eq!(Some(ours.landmark), theirs.landmark);
        assert_eq!(ours.aperture, theirs.aperture);
        assert_eq!(ours.in_view_fraction, theirs.in_view_fraction);
        // the closed loop reads the pulses and objects back from its CSV files (rounded)
        assert!(
            (ours.snr_db - loop_snr).abs() < 1e-3,
            "{ours:?} vs {theirs:?}"
        );
    }
}
