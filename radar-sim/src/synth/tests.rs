//! Tests of [`super`].

use super::*;
use crate::config::RadarConfig;

/// A small OFDM radar: 64-point FFT at NR's largest subcarrier spacing, 960 kHz (the physical
/// bounds refuse more), 40 subcarriers occupied.
fn small_radar(motion: MotionModel) -> RadarConfig {
    RadarConfig {
        fft_size: 64,
        cp_samples: 16,
        subcarrier_spacing_hz: 960e3,
        bandwidth_hz: Some(40.0 * 960e3),
        motion,
        ..RadarConfig::default()
    }
}

fn synth(motion: MotionModel) -> Synthesizer {
    let r = small_radar(motion);
    let num = Numerology::new(&r, 40e6, 0.1).unwrap();
    let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
    Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], vec![]).unwrap()
}

/// Brute force: evaluate the rectangular-windowed continuous OFDM signal at each sample.
fn brute(s: &Synthesizer, m: i64, paths: &[Path]) -> Vec<Complex64> {
    let num = s.numerology();
    let n = num.fft_size;
    let (ncp, ns) = (num.cp_samples as f64, num.symbol_samples() as f64);
    let fs = num.sample_rate_hz();
    (0..n)
        .map(|k| {
            let mut acc = Complex64::new(0.0, 0.0);
            for p in paths {
                let x = k as f64 - p.delay_samples;
                let j = ((x + ncp) / ns).floor();
                let sym = m + j as i64;
                if sym < 0 {
                    continue;
                }
                let xl = x - j * ns;
                let data = num.symbol_data(sym as u64);
                let mut u = Complex64::new(0.0, 0.0);
                for (i, d) in data.iter().enumerate() {
                    let kk = num.subcarrier_index(i) as f64;
                    u += Complex64::new(d.re as f64, d.im as f64)
                        * Complex64::from_polar(1.0, std::f64::consts::TAU * kk * xl / n as f64);
                }
                u /= (num.subcarriers as f64).sqrt();
                let dop = Complex64::from_polar(
                    1.0,
                    std::f64::consts::TAU * p.doppler_hz * (k as f64 - n as f64 / 2.0) / fs,
                );
                acc += p.amp * u * dop;
            }
            acc
        })
        .collect()
}

#[test]
fn exact_for_in_cp_and_split_paths() {
    for motion in [MotionModel::StopAndHop, MotionModel::IntraPulse] {
        let s = synth(motion);
        let dop = if motion == MotionModel::IntraPulse {
            1.0
        } else {
            0.0
        };
        let paths = vec![
            Path {
                amp: Complex64::new(1.0, 0.5),
                delay_samples: 0.37,
                doppler_hz: 3e3 * dop,
            },
            Path {
                amp: Complex64::new(-0.2, 0.1),
                delay_samples: 7.9,
                doppler_hz: -8e3 * dop,
            },
            Path {
                amp: Complex64::new(0.3, 0.0),
                delay_samples: 16.0,
                doppler_hz: 0.0,
            },
            // beyond the CP: split between symbols m−1 and m
            Path {
                amp: Complex64::new(0.1, -0.4),
                delay_samples: 23.6,
                doppler_hz: 5e3 * dop,
            },
            // more than a symbol late: symbols m−2 and m−1
            Path {
                amp: Complex64::new(0.05, 0.05),
                delay_samples: 101.2,
                doppler_hz: 0.0,
            },
            // early: symbols m and m+1
            Path {
                amp: Complex64::new(0.2, 0.2),
                delay_samples: -3.3,
                doppler_hz: 0.0,
            },
        ];
        let mut data = |m: i64| (m >= 0).then(|| Arc::new(s.numerology().symbol_data(m as u64)));
        let mut out = vec![Complex64::new(0.0, 0.0); 64];
        s.synthesize_window(5, &paths, &mut data, &mut out);
        let want = brute(&s, 5, &paths);
        let err: f64 = out.iter().zip(&want).map(|(a, b)| (a - b).norm_sqr()).sum();
        let pow: f64 = want.iter().map(|a| a.norm_sqr()).sum();
        assert!(
            err / pow < 1e-20,
            "{motion:?}: relative error {}",
            err / pow
        );
    }
}

#[test]
fn noise_has_kt0f_fs_variance() {
    let r = RadarConfig::default();
    let num = Numerology::new(&r, 150e6, 0.1).unwrap();
    let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
    let s = Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], vec![]).unwrap();
    let pulse = PulseMeta {
        index: 3,
        aperture: 0,
        look: 0,
        t_s: 1.0,
        symbol: 100,
        pos_m: [0.0, 0.0, 1000.0],
        vel_mps: [0.0, 20.0, 0.0],
        heading: [0.0, 1.0],
        window_delay_samples: 2000,
    };
    let comps = Components {
        direct: false,
        echoes: false,
        noise: true,
    };
    let mut out = vec![Complex32::new(0.0, 0.0); 4096];
    s.synthesize_pulse(&pulse, comps, &mut out).unwrap();
    let p: f64 = out.iter().map(|x| x.norm_sqr() as f64).sum::<f64>() / 4096.0;
    assert!(
        (p / s.noise_power_w() - 1.0).abs() < 0.08,
        "{}",
        p / s.noise_power_w()
    );
}

#[test]
fn radar_equation_amplitudes() {
    let r = RadarConfig::default();
    let num = Numerology::new(&r, 150e6, 0.1).unwrap();
    let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
    let obj = SceneObject {
        id: 0,
        x_m: 1000.0,
        y_m: 0.0,
        rcs_m2: 10.0,
        phase_rad: 0.0,
        landmark: None,
    };
    let s = Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], vec![obj]).unwrap();
    let pos = [0.0, 0.0, 1000.0];
    let heading = [0.0, 1.0];
    // P_r = P_t G_t G_r σ λ² / ((4π)³ R_t² R_r² L)
    let rt = (1000f64.powi(2) + 50f64.powi(2)).sqrt();
    let rr = 2f64.sqrt() * 1000.0;
    let g_r = ant.peak_gain;
    let want = 40.0 * 10f64.powf(1.2) * g_r * 10.0 * 0.01
        / ((4.0 * std::f64::consts::PI).powi(3) * rt * rt * rr * rr);
    let got = s.echo_power_w(&obj, pos, heading);
    assert!((got / want - 1.0).abs() < 1e-6, "{got} vs {want}");
    let paths = s.paths(pos, [0.0, 20.0, 0.0], heading, 0, Components::ALL);
    assert_eq!(paths.len(), 2);
    assert!((paths[1].amp.norm_sqr() / want - 1.0).abs() < 1e-6);
    let fs = 245.76e6;
    assert!((paths[1].delay_samples - (rt + rr) * fs / C_MPS).abs() < 1e-6);
}

/// A small NR cell: μ = 1, 8 PRBs (96 subcarriers) in a 128-point FFT, normal CP (9 samples, 11
/// on the first symbol of each half subframe), fully loaded.
fn nr_synth() -> Synthesizer {
    let nr = crate::config::NrConfig {
        numerology: 1,
        prbs: Some(8),
        ssb: false,
        prs: false, // a PRS spans 24 PRBs or more
        load: 1.0,
        // a PRS period of TS 38.214 at μ = 1 (2^μ × 5) that keeps the pulses on DDDSU's D slots
        pulse_period_slots: 10,
        ..Default::default()
    };
    let ill = nr.illumination(8, 3).unwrap();
    let r = RadarConfig {
        fft_size: 128,
        cp_samples: 9,
        subcarrier_spacing_hz: 30e3,
        bandwidth_hz: Some(96.0 * 30e3),
        nr: Some(nr),
        ..RadarConfig::default()
    };
    let num = Numerology::new(&r, 1e6, 0.1)
        .unwrap()
        .with_nr(Some(Arc::new(ill)))
        .unwrap();
    let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
    Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], vec![]).unwrap()
}

/// Brute force under NR: the stream's sample at window position k of symbol m lies in the
/// symbol whose [CP start, next CP start) holds it, found from the frame's symbol starts.
fn brute_nr(s: &Synthesizer, m: u64, paths: &[Path]) -> Vec<Complex64> {
    let num = s.numerology();
    let f = &num.nr.as_ref().unwrap().grid.frame;
    let n = num.fft_size;
    let u0 = f.useful_start_sample(m) as f64;
    (0..n)
        .map(|k| {
            let mut acc = Complex64::new(0.0, 0.0);
            for p in paths {
                let t = u0 + k as f64 - p.delay_samples;
                let mut sym = m.saturating_sub(3);
                while f.symbol_start_sample(sym + 1) as f64 <= t {
                    sym += 1;
                }
                let xl = t - f.useful_start_sample(sym) as f64;
                let data = num.symbol_data(sym);
                let mut u = Complex64::new(0.0, 0.0);
                for (i, d) in data.iter().enumerate() {
                    let kk = num.subcarrier_index(i) as f64;
                    u += Complex64::new(d.re as f64, d.im as f64)
                        * Complex64::from_polar(1.0, std::f64::consts::TAU * kk * xl / n as f64);
                }
                acc += p.amp * u / (num.subcarriers as f64).sqrt();
            }
            acc
        })
        .collect()
}

#[test]
fn exact_under_nr_with_per_symbol_cps() {
    let s = nr_synth();
    let num = s.numerology();
    // the grid fills the data symbols: unit power per occupied RE
    let d = num.symbol_data(5);
    assert_eq!(d.len(), 96);
    let paths: Vec<Path> = [0.4, 8.7, 9.6, 10.5, 11.3, 40.2, 130.0, 141.9, -2.5]
        .iter()
        .enumerate()
        .map(|(i, &delay)| Path {
            amp: Complex64::from_polar(1.0 / (1.0 + i as f64), 0.7 * i as f64),
            delay_samples: delay,
            doppler_hz: 0.0,
        })
        .collect();
    // windows around the long CPs of symbols 0, 14 and 28 (μ = 1: 28 symbols per subframe)
    for m in [1u64, 13, 14, 15, 27, 28, 29, 33] {
        let mut data = |m: i64| (m >= 0).then(|| Arc::new(num.symbol_data(m as u64)));
        let mut out = vec![Complex64::new(0.0, 0.0); 128];
        s.synthesize_window(m as i64, &paths, &mut data, &mut out);
        let want = brute_nr(&s, m, &paths);
        let err: f64 = out.iter().zip(&want).map(|(a, b)| (a - b).norm_sqr()).sum();
        let pow: f64 = want.iter().map(|a| a.norm_sqr()).sum();
        assert!(
            pow > 0.0 && err / pow < 1e-20,
            "m {m}: relative error {}",
            err / pow
        );
    }
    // uplink symbols are silent: slot 4 of DDDSU (symbols 56..70)
    assert!(num.symbol_data(60).iter().all(|x| x.norm() == 0.0));
}

#[test]
fn the_sector_pattern_scales_the_direct_path_and_the_echoes() {
    let bs = [1000.0, -1000.0, 30.0];
    let iso_r = RadarConfig::default();
    let sec_r = RadarConfig {
        bs_antenna: Some(crate::config::BsAntennaConfig::default()),
        ..RadarConfig::default()
    };
    let obj = SceneObject {
        id: 0,
        x_m: -300.0,
        y_m: 400.0,
        rcs_m2: 10.0,
        phase_rad: 0.0,
        landmark: None,
    };
    let make = |r: &RadarConfig| {
        let num = Numerology::new(r, 150e6, 0.1).unwrap();
        let ant = Antenna::new(r, 0.1, std::f64::consts::FRAC_PI_4);
        Synthesizer::new(num, r, ant, bs, vec![obj]).unwrap()
    };
    let (iso, sec) = (make(&iso_r), make(&sec_r));
    let sector = sec_r.bs_antenna.as_ref().unwrap().sector(bs);
    // by default the sector points at the origin on the ground: 0 dB there
    assert!(sector.pattern_db(bs, [0.0, 0.0, 0.0]).abs() < 1e-12);
    let heading = [0.0, 1.0];
    for pos in [
        [0.0, 0.0, 100.0],
        [-500.0, 300.0, 100.0],
        [2000.0, -3000.0, 100.0],
    ] {
        let g = sector.gain_towards(bs, pos);
        let ratio = sec.direct_power_w(pos, heading) / iso.direct_power_w(pos, heading);
        assert!((ratio / g - 1.0).abs() < 1e-12, "{ratio} vs {g}");
        let q = [obj.x_m, obj.y_m, 0.0];
        let ratio = sec.echo_power_w(&obj, pos, heading) / iso.echo_power_w(&obj, pos, heading);
        assert!((ratio / sector.gain_towards(bs, q) - 1.0).abs() < 1e-12);
    }
    // the UAV behind the sector: 30 dB below the isotropic model
    let behind = [3000.0, -3000.0, 30.0];
    let ratio = sec.direct_power_w(behind, heading) / iso.direct_power_w(behind, heading);
    assert!((10.0 * ratio.log10() + 30.0).abs() < 1e-9, "{ratio}");
}

/// Many paths at delays in and beyond the CP and early ones (deterministic pseudo-random).
fn many_paths(count: usize, max_delay: f64, doppler_hz: f64) -> Vec<Path> {
    let mut x = 0.271_828_f64;
    let mut next = move || {
        x = (x * 997.0 + 0.123_456_7).fract();
        x
    };
    (0..count)
        .map(|_| Path {
            amp: Complex64::from_polar(0.1 + next(), std::f64::consts::TAU * next()),
            delay_samples: -4.0 + (max_delay + 4.0) * next(),
            doppler_hz: doppler_hz * (2.0 * next() - 1.0),
        })
        .collect()
}

fn relative_error(got: &[Complex64], want: &[Complex64]) -> f64 {
    let err: f64 = got.iter().zip(want).map(|(a, b)| (a - b).norm_sqr()).sum();
    let pow: f64 = want.iter().map(|a| a.norm_sqr()).sum();
    assert!(pow > 0.0);
    err / pow
}

/// The corrections from a shared basis (split::) against brute force and against the segment
/// spectra, with and without Doppler, for a window whose paths mostly change symbol.
#[test]
fn corrections_agree_with_brute_force_and_the_segment_spectra() {
    for motion in [MotionModel::StopAndHop, MotionModel::IntraPulse] {
        let s = synth(motion);
        let dop = if motion == MotionModel::IntraPulse {
            5e3
        } else {
            0.0
        };
        let paths = many_paths(40, 150.0, dop);
        let mut data = |m: i64| (m >= 0).then(|| Arc::new(s.numerology().symbol_data(m as u64)));
        let mut by = |method| {
            let mut out = vec![Complex64::new(0.0, 0.0); 64];
            s.synthesize_window_by(
                7,
                &paths,
                &mut data,
                &mut out,
                method,
                &mut Default::default(),
            );
            out
        };
        let (seg, corr, auto) = (
            by(SplitMethod::Segments),
            by(SplitMethod::Corrections),
            by(SplitMethod::Auto),
        );
        let want = brute(&s, 7, &paths);
        assert!(relative_error(&seg, &want) < 1e-20, "{motion:?} segments");
        let e = relative_error(&corr, &want);
        assert!(e < 1e-20, "{motion:?}: corrections, relative error {e}");
        assert!(relative_error(&corr, &seg) < 1e-22, "{motion:?}");
        // 40 split paths are more than the series' terms: Auto takes the corrections
        assert_eq!(auto, corr, "{motion:?}");
    }
}

/// The same under NR's per-symbol CPs, windows across the long CPs.
#[test]
fn corrections_are_exact_under_nr() {
    let s = nr_synth();
    let num = s.numerology();
    let paths = many_paths(30, 250.0, 0.0);
    for m in [3u64, 13, 14, 15, 28, 33] {
        let mut data = |m: i64| (m >= 0).then(|| Arc::new(num.symbol_data(m as u64)));
        let mut out = vec![Complex64::new(0.0, 0.0); 128];
        s.synthesize_window_by(
            m as i64,
            &paths,
            &mut data,
            &mut out,
            SplitMethod::Corrections,
            &mut Default::default(),
        );
        let e = relative_error(&out, &brute_nr(&s, m, &paths));
        assert!(e < 1e-20, "m {m}: relative error {e}");
    }
}

/// The series' terms hold the truncation bound: 2 Σ_{q≥Q} (x/2)^q/q! < 1e-16, and one term
/// fewer does not; about 15 terms where a Taylor series in the fraction needs 19.
#[test]
fn series_terms_meet_the_bound() {
    for x in [0.1, 0.96, 1.35, std::f64::consts::FRAC_PI_2] {
        let q = split::series_terms(x);
        assert!(split::series_tail(x, q) < 1e-16, "x {x}: {q}");
        assert!(split::series_tail(x, q - 1) >= 1e-16, "x {x}: {q}");
        let taylor = |q: usize| x.powi(q as i32) / (1..=q).map(|v| v as f64).product::<f64>();
        assert!(
            taylor(q) * x.exp() > 1e-16,
            "x {x}: the Taylor bound with {q} terms"
        );
    }
    assert_eq!(split::series_terms(0.96), 15);
    // the tail is the sum it claims: 2 (x/2)^Q/Q! (1 + (x/2)/(Q+1) + ...)
    let t = split::series_tail(1.0, 3);
    let want: f64 = (3..40)
        .map(|q| 2.0 * 0.5f64.powi(q) / (1..=q).map(f64::from).product::<f64>())
        .sum();
    assert!((t / want - 1.0).abs() < 1e-14, "{t} vs {want}");
}

/// ε_q J_q(x): the Jacobi–Anger sum Σ_q ε_q (−j)^q J_q(x) T_q(t) is e^{−jxt}, and J_0, J_1 match
/// tabulated values.
#[test]
fn bessel_weights_expand_the_fractional_delay() {
    let w = split::bessel_weights(1.0, 20);
    assert!(
        (w[0] - 0.765_197_686_557_966_6).abs() < 1e-15,
        "J0(1) {}",
        w[0]
    );
    assert!(
        (w[1] / 2.0 - 0.440_050_585_744_933_5).abs() < 1e-15,
        "J1(1)"
    );
    for x in [-1.5, -0.3, 0.0, 0.96, 1.5] {
        let w = split::bessel_weights(x, split::series_terms(1.5));
        for t in [-1.0, -0.37, 0.0, 0.5, 1.0] {
            let (mut t0, mut t1) = (1.0, t);
            let mut sum = Complex64::new(0.0, 0.0);
            for (q, wq) in w.iter().enumerate() {
                let tq = if q == 0 { 1.0 } else { t1 };
                if q > 0 {
                    (t0, t1) = (t1, 2.0 * t * t1 - t0);
                }
                sum += Complex64::new(0.0, -1.0).powu(q as u32) * wq * tq;
            }
            let want = Complex64::from_polar(1.0, -x * t);
            assert!((sum - want).norm() < 1e-15, "x {x} t {t}: {sum} vs {want}");
        }
    }
}

/// The occupied subcarriers land in the bins of `Numerology::bin`; every other bin is zero.
#[test]
fn to_bins_places_every_subcarrier() {
    let num = nr_synth().numerology().clone();
    let v: Vec<Complex64> = (0..num.subcarriers)
        .map(|i| Complex64::new(i as f64 + 1.0, -(i as f64)))
        .collect();
    let mut dst = vec![Complex64::new(7.0, 7.0); num.fft_size];
    split::to_bins(&v, &mut dst);
    let mut want = vec![Complex64::new(0.0, 0.0); num.fft_size];
    for (i, x) in v.iter().enumerate() {
        want[num.bin(i)] = *x;
    }
    assert_eq!(dst, want);
}

/// A pulse of four windows (stop-and-hop: the same paths in each, their sums computed once)
/// is, sample for sample, the four windows synthesised one by one.
#[test]
fn a_pulse_is_its_windows_synthesised_one_by_one() {
    let r = RadarConfig {
        symbols_per_pulse: 4,
        prf_hz: 1e3,
        ..small_radar(MotionModel::StopAndHop)
    };
    let num = Numerology::new(&r, 40e6, 0.1).unwrap();
    let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
    // objects 0..~60 samples of excess delay: inside the 16-sample CP and beyond it
    let objects: Vec<SceneObject> = (0..30)
        .map(|i| SceneObject {
            id: i,
            x_m: 200.0 + 37.0 * i as f64,
            y_m: -150.0 + 11.0 * (i % 7) as f64,
            rcs_m2: 1.0 + i as f64,
            phase_rad: 0.3 * i as f64,
            landmark: None,
        })
        .collect();
    let s = Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], objects).unwrap();
    let pos_m = [0.0, 0.0, 100.0];
    let fs = s.numerology().sample_rate_hz();
    let d = (dist3(pos_m, [1000.0, -1000.0, 50.0]) * fs / C_MPS).floor() as i64;
    let pulse = PulseMeta {
        index: 3,
        aperture: 0,
        look: 0,
        t_s: 0.0,
        symbol: 40,
        pos_m,
        vel_mps: [20.0, 0.0, 0.0],
        heading: [1.0, 0.0],
        window_delay_samples: d,
    };
    let comps = Components {
        noise: false,
        ..Components::ALL
    };
    let n = s.numerology().fft_size;
    let mut got = vec![Complex32::new(0.0, 0.0); 4 * n];
    s.synthesize_pulse(&pulse, comps, &mut got).unwrap();
    let paths = s.paths(pos_m, pulse.vel_mps, pulse.heading, d, comps);
    let split = paths
        .iter()
        .filter(|p| p.delay_samples > s.numerology().cp_samples as f64)
        .count();
    // more split paths than the series has terms (the corrections), beside paths in the CP
    assert!(
        split > s.split_terms && split < paths.len(),
        "{split} of {}",
        paths.len()
    );
    let num = s.numerology().clone();
    let mut data = |m: i64| (m >= 0).then(|| Arc::new(num.symbol_data(m as u64)));
    for w in 0..4 {
        let mut out = vec![Complex64::new(0.0, 0.0); n];
        s.synthesize_window(40 + w as i64, &paths, &mut data, &mut out);
        let want: Vec<Complex32> = out
            .iter()
            .map(|v| Complex32::new(v.re as f32, v.im as f32))
            .collect();
        assert_eq!(&got[w * n..(w + 1) * n], &want[..], "window {w}");
    }
}
