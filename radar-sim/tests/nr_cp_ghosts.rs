//! Echoes beyond the cyclic prefix under an NR cell: the window of each symbol holds the
//! previous symbol's tail and only part of its own, and range compression spreads that
//! interference over the profile with the power the processor predicts (`isi_power_w`: a path
//! of power P whose window keeps the fraction f of its own symbol leaves P (1 − f²), spread like
//! thermal noise). With `pilots`, though, the interference that reaches the profile is the
//! previous and the own symbol's pilots, and those are the same in every pulse (the PRS and the
//! DMRS are scrambled by the slot number, and the pulse is always the same slot of the frame):
//! the "ghost" it leaves is the same profile, pulse after pulse, so it adds up coherently like
//! the echo itself instead of averaging like noise. With `ideal` the random data dominate it.
//! Closed forms: the ghost's power per profile sample against `(1 − f²) P × profile noise
//! factor`, and the share of it that repeats from pulse to pulse.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::Arc;

use radar_sim::cancel::SymbolWindow;
use radar_sim::config::{NrConfig, SceneFile};
use radar_sim::nr::Reference;
use radar_sim::pipeline::{
    cp_overlap_factor, Processor, RadarSetup, GHOST_PEAK_OVER_MEAN, PATTERN_SAMPLES,
};
use rustfft::num_complex::{Complex32, Complex64};
use rustfft::FftPlanner;

/// Pulses averaged.
const PULSES: usize = 48;

struct Ghosts {
    /// Mean over pulses of the ghost's power per profile sample, over the echo's peak power.
    per_pulse: f64,
    /// The power of the pulses' mean ghost over `per_pulse`: 1 for a ghost that repeats
    /// exactly, 1/PULSES for one that is independent from pulse to pulse.
    coherent_share: f64,
    /// The processor's prediction of `per_pulse`: (1 − f²) × profile noise variance / σ².
    predicted: f64,
    /// The mean over pulses of the compressed spectrum less the exact response's share of it
    /// (`f z0`, f the overlap factor at the numerology's CP), over the main peak's value
    /// `f z0(delay)`: the measured coherent ghost, as [`Processor::pilot_ghost`] models it.
    mean_ghost: Vec<Complex64>,
    /// The pulses' first symbols.
    first_symbols: Vec<u64>,
}

/// An echo of unit amplitude at integer delay `delay` (samples from the window's start) in
/// each window of `PULSES` pulses, the CP-OFDM stream synthesised sample by sample (the
/// previous symbol's tail where the delay exceeds the CP), compressed with `reference`; the
/// ghost is the compressed spectrum less f times that of the same echo made cyclic.
fn ghosts(reference: Reference, delay: usize) -> Ghosts {
    let mut scene = SceneFile::default();
    scene.radar.reference = reference;
    scene.radar.nr = Some(NrConfig::default());
    let setup = RadarSetup::new(&planner::Params::default(), &scene).unwrap();
    let proc = Processor::new(setup.clone()).unwrap();
    let num = &setup.num;
    let ill = num.nr.clone().unwrap();
    let (n, nsc) = (num.fft_size, num.subcarriers);
    let mut planner = FftPlanner::new();
    let (fft, ifft) = (planner.plan_fft_forward(n), planner.plan_fft_inverse(n));
    // the useful part of symbol m in time, unit mean power per occupied RE over √N_sc
    let useful = |m: u64| -> Vec<Complex64> {
        let x = num.symbol_data(m);
        let mut buf = vec![Complex64::default(); n];
        for (i, v) in x.iter().enumerate() {
            buf[num.bin(i)] = Complex64::new(v.re as f64, v.im as f64) / (nsc as f64).sqrt();
        }
        ifft.process(&mut buf);
        buf
    };
    let reference_of = |m: u64| -> Vec<Complex32> {
        match reference {
            Reference::Pilots => ill
                .grid
                .symbol(m)
                .pilots()
                .iter()
                .map(|v| Complex32::new(v.re as f32, v.im as f32))
                .collect(),
            _ => num.symbol_data(m),
        }
    };
    let spectrum = |t: Vec<Complex64>| {
        let mut s = t;
        fft.process(&mut s);
        s
    };
    let symbols = ill.pulse.symbols as u64;
    let mut ghosts: Vec<Vec<Complex64>> = Vec::with_capacity(PULSES);
    let mut peak = 0.0;
    let mut f_mean = 0.0;
    let f_model = cp_overlap_factor(delay as f64, n, num.cp_samples);
    let mut model_share: Vec<Complex64> = vec![Complex64::default(); nsc];
    let mut main_peak = Complex64::default();
    for q in 0..PULSES {
        let m0 = ill.pulse_symbol(q as f64 / ill.prf_hz());
        let (mut real, mut cyclic) = (Vec::new(), Vec::new());
        for s in 0..symbols {
            let m = m0 + s;
            let cp = ill.grid.frame.cp_samples(m);
            let (own, prev) = (useful(m), useful(m - 1));
            let mut y = vec![Complex64::default(); n];
            for (k, v) in y.iter_mut().enumerate() {
                let j = k as i64 - delay as i64;
                *v = if j >= -(cp as i64) {
                    own[j.rem_euclid(n as i64) as usize]
                } else {
                    prev[(j + (cp + n) as i64) as usize]
                };
            }
            let c: Vec<Complex64> = (0..n)
                .map(|k| own[(k as i64 - delay as i64).rem_euclid(n as i64) as usize])
                .collect();
            let data = Arc::new(reference_of(m));
            let win = |spec| SymbolWindow {
                spectrum: spec,
                data: data.clone(),
                t_s: 0.0,
                dp_delay_samples: 0.0,
            };
            real.push(win(spectrum(y)));
            cyclic.push(win(spectrum(c)));
            f_mean += cp_overlap_factor(delay as f64, n, cp) / (symbols as usize * PULSES) as f64;
        }
        let z = proc.compressor().spectrum(&real);
        let z0 = proc.compressor().spectrum(&cyclic);
        let f = cp_overlap_factor(delay as f64, n, ill.grid.frame.cp_samples(m0));
        peak += proc.compressor().evaluate(&z0, delay as f64).norm_sqr() / PULSES as f64;
        main_peak += proc.compressor().evaluate(&z0, delay as f64) * f_model / PULSES as f64;
        for ((m, a), b) in model_share.iter_mut().zip(&z).zip(&z0) {
            *m += (a - b * f_model) / PULSES as f64;
        }
        ghosts.push(z.iter().zip(&z0).map(|(a, b)| a - b * f).collect());
    }
    // Parseval: the mean over the N profile samples of |Σ_i G_i e^{j2πk_i x/N}|² is Σ |G_i|²
    let power = |g: &[Complex64]| g.iter().map(|v| v.norm_sqr()).sum::<f64>();
    let per_pulse = ghosts.iter().map(|g| power(g)).sum::<f64>() / PULSES as f64 / peak;
    let mean: Vec<Complex64> = (0..nsc)
        .map(|i| ghosts.iter().map(|g| g[i]).sum::<Complex64>() / PULSES as f64)
        .collect();
    let coherent_share = power(&mean) / peak / per_pulse;
    // the processor's floor: the echo's power P (here the mean power of a window of the
    // useful parts) leaves P (1 − f²), spread like thermal noise of that power
    let p_echo: f64 = {
        let m0 = ill.pulse_symbol(0.0);
        (0..symbols)
            .map(|s| useful(m0 + s).iter().map(|v| v.norm_sqr()).sum::<f64>() / n as f64)
            .sum::<f64>()
            / symbols as f64
    };
    let noise_gain = proc.profile_noise_var() / proc.noise_power_w();
    Ghosts {
        per_pulse,
        coherent_share,
        predicted: (1.0 - f_mean * f_mean) * p_echo * noise_gain,
        mean_ghost: model_share.iter().map(|v| v / main_peak).collect(),
        first_symbols: (0..PULSES)
            .map(|q| ill.pulse_symbol(q as f64 / ill.prf_hz()))
            .collect(),
    }
}

#[test]
fn pilots_ghosts_of_echoes_beyond_the_cp_repeat_from_pulse_to_pulse() {
    // 800 samples beyond the normal CP (288): 1.3 km of bistatic range, as the main job's
    // landmarks in apertures 22-28 (740-1130 samples)
    let delay = 288 + 800;
    let pilots = ghosts(Reference::Pilots, delay);
    let ideal = ghosts(Reference::Ideal, delay);
    let db = |x: f64| 10.0 * x.log10();
    for (name, g) in [("pilots", &pilots), ("ideal", &ideal)] {
        eprintln!(
            "{name}: ghost per profile sample {:.1} dB under the peak per pulse (predicted {:.1} dB), \
             share repeating from pulse to pulse {:.3} (independent: {:.3})",
            -db(g.per_pulse),
            -db(g.predicted),
            g.coherent_share,
            1.0 / PULSES as f64
        );
        // the floor's prediction holds the ghost's power (measured: within 1.3 dB)
        assert!(
            (db(g.per_pulse) - db(g.predicted)).abs() < 2.0,
            "{name}: {} vs {}",
            db(g.per_pulse),
            db(g.predicted)
        );
        // but not its coherence: far more of it repeats than independent draws would leave
        assert!(
            g.coherent_share > 8.0 / PULSES as f64,
            "{name}: {}",
            g.coherent_share
        );
    }
    // with pilots more of it repeats (measured 0.37 against 0.23 with ideal: the data that
    // the ideal reference knows are drawn afresh in every slot), and its power per sample is
    // higher: with the noise per profile sample higher too, the same ratio to thermal noise
    assert!(
        pilots.coherent_share > ideal.coherent_share + 0.08,
        "{} vs {}",
        pilots.coherent_share,
        ideal.coherent_share
    );
    assert!(
        pilots.coherent_share * pilots.per_pulse > 2.0 * ideal.coherent_share * ideal.per_pulse,
        "coherent ghost: pilots {} vs ideal {}",
        pilots.coherent_share * pilots.per_pulse,
        ideal.coherent_share * ideal.per_pulse
    );
}

#[test]
fn echoes_inside_the_cp_leave_no_ghost() {
    for reference in [Reference::Pilots, Reference::Ideal] {
        let g = ghosts(reference, 200);
        assert!(g.per_pulse < 1e-20, "{reference:?}: {}", g.per_pulse);
        assert!(g.predicted.abs() < 1e-12, "{reference:?}: {}", g.predicted);
    }
}

/// The processor's model of the ghost ([`Processor::pilot_ghost`], from the pilots' waveform
/// alone) against the mean over pulses of the ghost synthesised with the data: their profiles
/// compared at every delay over the profile's period (not only near the echo).
#[test]
fn the_pilots_ghost_model_is_the_ghost_that_repeats() {
    let mut scene = SceneFile::default();
    scene.radar.reference = Reference::Pilots;
    scene.radar.nr = Some(NrConfig::default());
    let setup = RadarSetup::new(&planner::Params::default(), &scene).unwrap();
    let proc = Processor::new(setup.clone()).unwrap();
    let num = &setup.num;
    let n = num.fft_size;
    // (the measured profile at x samples from the echo)
    let profile = |z: &[Complex64], delay: usize, x: f64| -> Complex64 {
        z.iter()
            .enumerate()
            .map(|(i, v)| {
                let k = num.subcarrier_index(i) as f64;
                v * Complex64::from_polar(
                    1.0,
                    std::f64::consts::TAU * k * (delay as f64 + x) / n as f64,
                )
            })
            .sum()
    };
    let xs: Vec<f64> = (0..(n as f64 / 0.37) as usize)
        .map(|t| -(n as f64) / 2.0 + t as f64 * 0.37)
        .collect();
    // ‖a − b‖² / ‖a‖² over every delay
    let misfit = |measured: &[Complex64], delay: usize, model: &radar_sim::cfar::GhostProfile| {
        let (mut err, mut pw) = (0.0, 0.0);
        for x in &xs {
            let a = profile(measured, delay, *x);
            err += (a - model.at(*x)).norm_sqr();
            pw += a.norm_sqr();
        }
        err / pw
    };
    for delay in [288 + 800, 288 + 150] {
        let g = ghosts(Reference::Pilots, delay);
        let model = proc.pilot_ghost(&g.first_symbols, delay as f64).unwrap();
        let fit = misfit(&g.mean_ghost, delay, &model);
        // the data's share of the ghost does not repeat: over 48 pulses its power is about
        // (1 − 0.37) / 48 of a pulse's ghost against the pilots' 0.37 (0.035)
        eprintln!(
            "delay {delay}: misfit {fit:.4}, ghost peak {:.1} dB under the main peak",
            -20.0 * model.peak().log10()
        );
        assert!(fit < 0.1, "delay {delay}: {fit}");
        // the bound on its peak that decides which sources' ghosts are modelled holds
        let f = cp_overlap_factor(delay as f64, n, num.cp_samples);
        let mean = (1.0 - f * f) / num.subcarriers as f64;
        let over = model.peak().powi(2) / mean;
        eprintln!(
            "delay {delay}: ghost peak {:.1} dB over its mean",
            10.0 * over.log10()
        );
        assert!(over < GHOST_PEAK_OVER_MEAN, "delay {delay}: {over}");
        // the model with half the excess delay does not fit: the ghost grows with the part of
        // the window the previous symbol holds
        let half = delay as f64 - (delay - 288) as f64 / 2.0;
        let wrong = proc.pilot_ghost(&g.first_symbols, half).unwrap();
        let off = misfit(&g.mean_ghost, delay, &wrong);
        eprintln!("delay {delay}: misfit at {half}: {off:.4}");
        assert!(off > 0.2, "delay {delay}: {off}");
        // the processor's estimate from a few pulses' pilots fits as well
        let sampled: Vec<u64> = (0..PATTERN_SAMPLES)
            .map(|j| g.first_symbols[(2 * j + 1) * PULSES / (2 * PATTERN_SAMPLES)])
            .collect();
        let few = proc.pilot_ghost(&sampled, delay as f64).unwrap();
        let est = misfit(&g.mean_ghost, delay, &few);
        eprintln!("delay {delay}: misfit of {PATTERN_SAMPLES} pulses' pilots: {est:.4}");
        assert!(est < 0.1, "delay {delay}: {est}");
        // but not the first pulse's alone: the PDSCH's DMRS lies on other PRBs every slot
        let first = proc
            .pilot_ghost(&g.first_symbols[..1], delay as f64)
            .unwrap();
        let one = misfit(&g.mean_ghost, delay, &first);
        eprintln!("delay {delay}: misfit of the first pulse's pattern: {one:.4}");
        assert!(one > 2.0 * fit, "delay {delay}: {one}");
    }
    // inside the CP there is none
    assert!(proc.pilot_ghost(&[0], 200.0).is_none());
    // under `ideal` the pilots' ghost is the part of the ghost that repeats too
    let mut ideal = scene.clone();
    ideal.radar.reference = Reference::Ideal;
    let ideal = Processor::new(RadarSetup::new(&planner::Params::default(), &ideal).unwrap());
    let ideal = ideal.unwrap();
    for delay in [288 + 800, 288 + 150] {
        let g = ghosts(Reference::Ideal, delay);
        let model = ideal.pilot_ghost(&g.first_symbols, delay as f64).unwrap();
        let fit = misfit(&g.mean_ghost, delay, &model);
        eprintln!("ideal, delay {delay}: misfit {fit:.4}");
        // (measured 0.067 and 0.049: the data's share that does not repeat is larger)
        assert!(fit < 0.15, "ideal, delay {delay}: {fit}");
    }
}
