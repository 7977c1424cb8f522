//! The processor's references under an NR cell, against closed forms: a comb-K pilot symbol
//! aliases the range profile every N/K samples (c/(K Δf) of bistatic range) and the PRS's
//! staggered symbols, combined over a pulse, cancel that alias; hard decisions err at the QAM
//! symbol error rate of their SNR, on the grid and on the UAV's own direct-path recording; at the
//! default link the reconstructed reference is the ideal one; the expected SNR of an object
//! follows each reference's mask.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::sync::Arc;

use radar_sim::cancel::SymbolWindow;
use radar_sim::compress::RangeCompressor;
use radar_sim::config::{Modulation, NrConfig, RangeFilter, SceneFile, Weighting};
use radar_sim::nr::grid::Role;
use radar_sim::nr::Reference;
use radar_sim::pipeline::RadarSetup;
use radar_sim::synth::Components;
use radar_sim::track::dist3;
use radar_sim::waveform::C_MPS;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rustfft::num_complex::{Complex32, Complex64};

fn nr_scene(reference: Reference, nr: NrConfig) -> SceneFile {
    let mut s = SceneFile::default();
    s.radar.reference = reference;
    s.radar.nr = Some(nr);
    s
}

/// erfc(x), Numerical Recipes' Chebyshev fit (relative error < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Symbol error rate of square M-QAM with Gray-free nearest-point decisions at Es/N0 = `snr`:
/// 1 − (1 − 2 (1 − 1/√M) Q(√(3 snr / (M − 1))))².
fn qam_ser(m: Modulation, snr: f64) -> f64 {
    let mm = f64::from(1u32 << m.bits());
    let q = 0.5 * erfc((3.0 * snr / (mm - 1.0)).sqrt() / std::f64::consts::SQRT_2);
    let p = 2.0 * (1.0 - 1.0 / mm.sqrt()) * q;
    1.0 - (1.0 - p) * (1.0 - p)
}

#[test]
fn comb_pilots_alias_every_n_over_k_and_the_staggered_prs_cancels_it() {
    let nr = NrConfig {
        ssb: false,
        trs: false,
        load: 0.0, // the pulse's symbols carry the PRS alone
        ..NrConfig::default()
    };
    let setup = RadarSetup::new(
        &planner::Params::default(),
        &nr_scene(Reference::Pilots, nr),
    )
    .unwrap();
    let num = &setup.num;
    let ill = num.nr.clone().unwrap();
    let (n, nsc) = (num.fft_size, num.subcarriers);
    let m0 = ill.pulse_symbol(0.015);
    let a = Complex64::new(0.3, -0.4);
    let delay = 137.25;
    let window = |m: u64| {
        let x = ill.grid.symbol(m).pilots();
        let mut spec = vec![Complex64::default(); n];
        for (i, v) in x.iter().enumerate() {
            let k = num.subcarrier_index(i) as f64;
            spec[num.bin(i)] = a * v * n as f64 / (nsc as f64).sqrt()
                * Complex64::from_polar(1.0, -std::f64::consts::TAU * k * delay / n as f64);
        }
        SymbolWindow {
            spectrum: spec,
            data: Arc::new(
                x.iter()
                    .map(|v| Complex32::new(v.re as f32, v.im as f32))
                    .collect(),
            ),
            t_s: 0.0,
            dp_delay_samples: 0.0,
        }
    };
    // (the reference is held in f32: agreement to 1e-6)
    let comb = 4.0;
    let alias = n as f64 / comb; // 1024 samples: c / (4 Δf) = 1249 m of bistatic range
    assert!((alias * C_MPS / num.sample_rate_hz() - C_MPS / (comb * 60e3)).abs() < 1e-6);
    for filter in [RangeFilter::Reciprocal, RangeFilter::Matched] {
        let c = RangeCompressor::new(num, filter, Weighting::None, 8);
        // one PRS symbol: a quarter of the subcarriers; the profile repeats every N/4 samples
        let one = c.spectrum(&[window(m0)]);
        let peak = c.evaluate(&one, delay);
        assert!((peak - a).norm() < 1e-6, "{filter:?}: {peak} vs {a}");
        let ghost = c.evaluate(&one, delay + alias).norm();
        assert!((ghost - a.norm()).abs() < 1e-6, "{filter:?}: alias {ghost}");
        assert!(c.evaluate(&one, delay + alias / 2.0).norm() < 1e-6);
        // the pulse's four staggered symbols hold every subcarrier once: no alias left
        let all: Vec<SymbolWindow> = (0..4).map(|s| window(m0 + s)).collect();
        let z = c.spectrum(&all);
        assert!((c.evaluate(&z, delay) - a).norm() < 1e-6);
        let left = c.evaluate(&z, delay + alias).norm();
        assert!(left < 1e-6, "{filter:?}: alias after staggering {left}");
    }
}

#[test]
fn hard_decisions_err_at_the_qam_symbol_error_rate() {
    for (m, snr_db) in [
        (Modulation::Qpsk, 7.0),
        (Modulation::Qam16, 14.0),
        (Modulation::Qam64, 20.0),
        (Modulation::Qam256, 26.0),
    ] {
        let nr = NrConfig {
            ssb: false,
            trs: false,
            prs: false,
            load: 1.0,
            modulations: vec![m],
            ..NrConfig::default()
        };
        let ill = nr.illumination(100, 5).unwrap();
        let snr = 10f64.powf(snr_db / 10.0);
        let sigma = (0.5 / snr).sqrt();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (mut errors, mut count) = (0usize, 0usize);
        // data symbols of the three D slots of each DDDSU period (not the DMRS symbols 2, 11)
        for period in 0..12u64 {
            for slot in 0..3u64 {
                for l in [0u64, 1, 3, 4, 5, 6, 7, 8, 9, 10, 12, 13] {
                    let sym = ill.grid.symbol((period * 5 + slot) * 14 + l);
                    let noisy: Vec<Complex64> = sym
                        .values
                        .iter()
                        .map(|v| {
                            let re: f64 = StandardNormal.sample(&mut rng);
                            let im: f64 = StandardNormal.sample(&mut rng);
                            v + Complex64::new(re, im) * sigma
                        })
                        .collect();
                    let rec = ill.grid.reconstruct(&sym, &noisy);
                    for ((r, v), role) in rec.iter().zip(&sym.values).zip(&sym.roles) {
                        if *role == Role::Data(m) {
                            count += 1;
                            errors += usize::from((r - v).norm() > 1e-9);
                        }
                    }
                }
            }
        }
        let (got, want) = (errors as f64 / count as f64, qam_ser(m, snr));
        println!("{m:?} at {snr_db} dB: SER {got:.4} over {count} REs, closed form {want:.4}");
        assert!(count > 100_000);
        assert!((got / want - 1.0).abs() < 0.08, "{m:?}: {got} vs {want}");
    }
}

/// The pulses of one look of a track past the origin, their IQ (direct path, one object, noise)
/// and the setup.
fn recording(tx_power_w: f64) -> (RadarSetup, Vec<radar_sim::track::PulseMeta>, Vec<Complex32>) {
    let params = planner::Params::default();
    let mut scene = nr_scene(Reference::Reconstructed, NrConfig::default());
    scene.radar.tx_power_w = tx_power_w;
    let setup = RadarSetup::new(&params, &scene).unwrap();
    let track = common::track_through(&params, [0.0, 0.0], 90.0, 20.0, 0.5);
    let ap = common::aperture(&setup, [0.0, 0.0], 0.0, 1);
    let pulses: Vec<_> = common::pulses(&setup, &track, &ap)
        .into_iter()
        .step_by(2)
        .collect();
    let iq = setup
        .synthesizer(vec![common::object(0, [0.0, 0.0], 10.0)])
        .unwrap()
        .synthesize_frame(&pulses, Components::ALL)
        .unwrap();
    (setup, pulses, iq)
}

/// Per pulse: (the reconstructed reference, the ideal one, each RE's role, the direct path's
/// SNR per RE).
type PulseRefs = (
    Vec<Vec<Complex32>>,
    Vec<Vec<Complex32>>,
    Vec<Vec<Role>>,
    f64,
);

fn references(tx_power_w: f64) -> Vec<PulseRefs> {
    let (setup, pulses, iq) = recording(tx_power_w);
    let proc = radar_sim::pipeline::Processor::new(setup.clone()).unwrap();
    let link = setup.synthesizer(Vec::new()).unwrap();
    let num = &setup.num;
    let ill = num.nr.clone().unwrap();
    let (n, spp) = (num.fft_size, setup.scene.radar.symbols_per_pulse);
    let fft = rustfft::FftPlanner::new().plan_fft_forward(n);
    pulses
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let spectra: Vec<Vec<Complex64>> = (0..spp)
                .map(|s| {
                    let off = (k * spp + s) * n;
                    let mut v: Vec<Complex64> = iq[off..off + n]
                        .iter()
                        .map(|x| Complex64::new(x.re as f64, x.im as f64))
                        .collect();
                    fft.process(&mut v);
                    v
                })
                .collect();
            let fs = num.sample_rate_hz();
            let dp = dist3(p.pos_m, setup.bs_m) * fs / C_MPS - p.window_delay_samples as f64;
            let rec = proc.pulse_reference(p.symbol, &spectra, dp);
            let ideal = (0..spp as u64)
                .map(|s| num.symbol_data(p.symbol + s))
                .collect();
            let roles = (0..spp as u64)
                .map(|s| ill.grid.symbol(p.symbol + s).roles)
                .collect();
            // per RE: |g|² N² / N_sc of signal against N σ² of noise (Es/N0)
            let snr = link.direct_power_w(p.pos_m, p.heading) * n as f64
                / (num.subcarriers as f64 * link.noise_power_w());
            (rec, ideal, roles, snr)
        })
        .collect()
}

#[test]
fn reconstructed_is_ideal_at_the_default_link_and_errs_as_qam_at_low_direct_snr() {
    for (rec, ideal, _, snr) in references(40.0) {
        assert!(10.0 * snr.log10() > 28.0, "{snr}");
        for (r, i) in rec.iter().zip(&ideal) {
            for (a, b) in r.iter().zip(i) {
                assert!((a - b).norm() < 1e-6, "{a} vs {b} at {snr} direct SNR");
            }
        }
    }
    // a weak BS: the decisions on the UAV's own recording err as the closed form of each
    // PRB's QAM order at the direct path's SNR (the echo lies far below the noise)
    let mods = NrConfig::default().modulations;
    let mut tally = vec![(0usize, 0usize, 0.0f64); mods.len()]; // errors, REs, expected errors
    let mut snr_db = 0.0;
    for (rec, ideal, roles, snr) in references(0.4) {
        snr_db = 10.0 * snr.log10();
        for ((r, i), ro) in rec.iter().zip(&ideal).zip(&roles) {
            for ((a, b), role) in r.iter().zip(i).zip(ro) {
                match role {
                    Role::Data(m) => {
                        let t = &mut tally[mods.iter().position(|x| x == m).unwrap()];
                        t.0 += usize::from((a - b).norm() > 1e-6);
                        t.1 += 1;
                        t.2 += qam_ser(*m, snr);
                    }
                    Role::Pilot => assert!((a - b).norm() < 1e-6, "a pilot is known"),
                    Role::Empty => assert_eq!(a.norm(), 0.0),
                }
            }
        }
    }
    for (m, (errors, res, expected)) in mods.iter().zip(&tally) {
        println!(
            "{m:?} at {snr_db:.1} dB direct SNR per RE: {errors} wrong of {res} REs, closed form {expected:.1}"
        );
        if *expected >= 100.0 {
            let ratio = *errors as f64 / expected;
            assert!((ratio - 1.0).abs() < 0.15, "{m:?}: {errors} vs {expected}");
        } else {
            assert!(
                (*errors as f64) < expected + 4.0 * expected.sqrt() + 3.0,
                "{m:?}"
            );
        }
    }
    assert!(
        tally.iter().any(|t| t.2 >= 100.0),
        "no QAM order errs: {tally:?}"
    );
}

#[test]
fn profile_noise_follows_each_references_mask() {
    // thermal noise alone through the processor: its profile variance against the prediction
    // (the masked profile is normalised by the known REs, so fewer known REs mean more noise)
    let params = planner::Params::default();
    let mut vars = Vec::new();
    for (reference, filter) in [
        (Reference::Ideal, RangeFilter::Reciprocal),
        (Reference::Pilots, RangeFilter::Reciprocal),
        (Reference::Pilots, RangeFilter::Matched),
    ] {
        let mut scene = nr_scene(reference, NrConfig::default());
        scene.radar.direct_path = false;
        scene.processing.canceller = radar_sim::config::CancellerKind::None;
        scene.processing.range_filter = filter;
        scene.processing.range_weighting = Weighting::Hann;
        let proc = common::processor(&params, &scene);
        let setup = proc.setup().clone();
        let track = common::track_through(&params, [0.0, 0.0], 90.0, 20.0, 0.5);
        let ap = common::aperture(&setup, [0.0, 0.0], 0.0, 1);
        let pulses = common::pulses(&setup, &track, &ap);
        let iq = setup
            .synthesizer(Vec::new())
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
                false,
            )
            .unwrap();
        let measured =
            c.profiles.iter().map(|v| v.norm_sqr() as f64).sum::<f64>() / c.profiles.len() as f64;
        let predicted = proc.profile_noise_var();
        println!(
            "{reference:?} {filter:?}: profile noise {measured:.4e} W, predicted {predicted:.4e} W"
        );
        assert!(
            (measured / predicted - 1.0).abs() < 0.05,
            "{measured} vs {predicted}"
        );
        vars.push(predicted);
    }
    // the pilots (28 % of the pulse's REs: the comb-4 PRS and a DMRS) carry more noise per
    // profile sample than the half-loaded grid (56 %), less than the 2× of the shares because
    // the reciprocal filter's 1/|X|² raises the noise of the 16- and 64-QAM data REs
    assert!(vars[1] > 1.2 * vars[0], "{vars:?}");
}
