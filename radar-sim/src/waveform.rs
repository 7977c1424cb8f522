//! The BS's OFDM downlink signal: numerology, seeded QAM data with random access by symbol
//! index, and the useful (CP-free) part of each symbol in the time domain.
//!
//! Conventions: subcarrier `k ∈ [−N_sc/2, N_sc − N_sc/2)` sits in FFT bin `k mod N`; the
//! useful part of symbol m is `u_m[n] = N_sc^{-1/2} Σ_k X_{m,k} e^{j2πkn/N}`, n = 0..N−1, so a
//! symbol has unit mean power per sample when the QAM alphabet has unit mean power. Symbol m
//! starts (CP first) at time `m (N + N_cp) / f_s` in BS time.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rustfft::num_complex::{Complex32, Complex64};
use serde::{Deserialize, Serialize};

use crate::config::{Modulation, RadarConfig};
use crate::error::{RadarError, Result};
use crate::nr::NrIllumination;

/// Speed of light, m/s (same constant as the planner).
pub const C_MPS: f64 = planner::params::SPEED_OF_LIGHT_MPS;

/// A resolved OFDM numerology.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Numerology {
    /// Subcarrier spacing Δf, Hz.
    pub subcarrier_spacing_hz: f64,
    /// FFT size N.
    pub fft_size: usize,
    /// Cyclic prefix N_cp, samples.
    pub cp_samples: usize,
    /// Number of occupied subcarriers N_sc = round(B / Δf).
    pub subcarriers: usize,
    /// Carrier frequency f_c = c / λ_c, Hz.
    pub carrier_hz: f64,
    /// Data modulation.
    pub modulation: Modulation,
    /// Seed of the data symbols.
    pub seed: u64,
    /// The NR cell whose grid, per-symbol CPs and pulse slots replace the plain waveform
    /// (`[radar.nr]`); None: every symbol is `modulation` on every subcarrier with `cp_samples`.
    /// Rebuilt from the scene, never serialised.
    #[serde(skip)]
    pub nr: Option<Arc<NrIllumination>>,
}

impl Numerology {
    /// Resolves the numerology of `radar` for wavelength `λ_c` and its bandwidth: the scene's
    /// `radar.bandwidth_hz` if set, else the mission's `bandwidth_hz`.
    pub fn new(radar: &RadarConfig, bandwidth_hz: f64, wavelength_m: f64) -> Result<Self> {
        let sc = match radar.bandwidth_hz {
            Some(b) => radar.subcarriers_for("radar.bandwidth_hz", b)?,
            None => radar.subcarriers_for("params.bandwidth_hz", bandwidth_hz)?,
        };
        if !(wavelength_m.is_finite() && wavelength_m > 0.0) {
            return Err(RadarError::config("params.wavelength_m", "must be > 0"));
        }
        Ok(Self {
            subcarrier_spacing_hz: radar.subcarrier_spacing_hz,
            fft_size: radar.fft_size,
            cp_samples: radar.cp_samples,
            subcarriers: sc,
            carrier_hz: C_MPS / wavelength_m,
            modulation: radar.modulation,
            seed: radar.seed,
            nr: None,
        })
    }

    /// This numerology with the NR cell `nr` (its subcarriers must be this one's).
    pub fn with_nr(mut self, nr: Option<Arc<NrIllumination>>) -> Result<Self> {
        if let Some(ill) = &nr {
            let f = &ill.grid.frame;
            if f.subcarriers() != self.subcarriers
                || f.fft_size() != self.fft_size
                || f.base_cp_samples() != self.cp_samples
            {
                return Err(RadarError::config(
                    "radar.nr",
                    format!(
                        "the cell's {} subcarriers, FFT size {} and CP {} differ from the \
                         radar's {}, {} and {}",
                        f.subcarriers(),
                        f.fft_size(),
                        f.base_cp_samples(),
                        self.subcarriers,
                        self.fft_size,
                        self.cp_samples
                    ),
                ));
            }
        }
        self.nr = nr;
        Ok(self)
    }

    /// The sample (from the start of the BS's stream) at which symbol `m`'s useful part starts:
    /// `m (N + N_cp) + N_cp`, or the NR frame's, whose CPs differ per symbol.
    pub fn useful_start_sample(&self, m: u64) -> f64 {
        match &self.nr {
            None => m as f64 * self.symbol_samples() as f64 + self.cp_samples as f64,
            Some(ill) => ill.grid.frame.useful_start_sample(m) as f64,
        }
    }

    /// The first symbol of the pulse at nominal time `t_s` and the pulse's reference time:
    /// `(⌊t / T_sym⌋, t)`, or under NR the pulse slot of period ⌊t · PRF⌋ and the centre of its
    /// symbols.
    pub fn pulse_symbol(&self, t_s: f64) -> (u64, f64) {
        match &self.nr {
            None => ((t_s / self.symbol_s()).floor().max(0.0) as u64, t_s),
            Some(ill) => {
                let m = ill.pulse_symbol(t_s);
                (m, ill.pulse_centre_s(m))
            }
        }
    }

    /// Sample rate f_s = N Δf, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.fft_size as f64 * self.subcarrier_spacing_hz
    }

    /// Occupied bandwidth N_sc Δf, Hz.
    pub fn bandwidth_hz(&self) -> f64 {
        self.subcarriers as f64 * self.subcarrier_spacing_hz
    }

    /// Carrier wavelength c / f_c, m.
    pub fn wavelength_m(&self) -> f64 {
        C_MPS / self.carrier_hz
    }

    /// Samples per symbol including the CP.
    pub fn symbol_samples(&self) -> usize {
        self.fft_size + self.cp_samples
    }

    /// Symbol duration including the CP, s.
    pub fn symbol_s(&self) -> f64 {
        self.symbol_samples() as f64 / self.sample_rate_hz()
    }

    /// Useful symbol duration 1/Δf, s.
    pub fn useful_s(&self) -> f64 {
        self.fft_size as f64 / self.sample_rate_hz()
    }

    /// Bistatic excess range covered by the CP, m.
    pub fn cp_range_m(&self) -> f64 {
        self.cp_samples as f64 / self.sample_rate_hz() * C_MPS
    }

    /// Excess range per sample c / f_s, m.
    pub fn range_per_sample_m(&self) -> f64 {
        C_MPS / self.sample_rate_hz()
    }

    /// The signed subcarrier index of occupied subcarrier `i` (0..N_sc).
    pub fn subcarrier_index(&self, i: usize) -> i64 {
        i as i64 - (self.subcarriers / 2) as i64
    }

    /// FFT bin (0..N) of occupied subcarrier `i`.
    pub fn bin(&self, i: usize) -> usize {
        self.subcarrier_index(i).rem_euclid(self.fft_size as i64) as usize
    }

    /// The QAM data X_{m,k} of symbol `m` (N_sc values, unit mean power), reproducible from the
    /// seed alone in any order; under NR the cell's grid (zero where nothing is sent).
    pub fn symbol_data(&self, m: u64) -> Vec<Complex32> {
        if let Some(ill) = &self.nr {
            return ill
                .grid
                .symbol(m)
                .values
                .iter()
                .map(|v| Complex32::new(v.re as f32, v.im as f32))
                .collect();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x0FD3_A5A5_0000_0000);
        rng.set_stream(m);
        let bits = self.modulation.bits();
        let side = 1u32 << (bits / 2); // points per axis
        let norm = qam_norm(side);
        (0..self.subcarriers)
            .map(|_| {
                let w: u32 = rng.gen();
                let i = (w & (side - 1)) as f32;
                let q = ((w >> 16) & (side - 1)) as f32;
                let h = (side - 1) as f32;
                Complex32::new((2.0 * i - h) * norm, (2.0 * q - h) * norm)
            })
            .collect()
    }

    /// Mean of 1/|X|² over the constellation (1 for QPSK): the SNR loss factor of the
    /// reciprocal filter relative to the matched filter is 1 / this.
    pub fn mean_inverse_power(&self) -> f64 {
        let side = 1u32 << (self.modulation.bits() / 2);
        let norm = qam_norm(side) as f64;
        let h = (side - 1) as f64;
        let mut acc = 0.0;
        for i in 0..side {
            for q in 0..side {
                let re = (2.0 * i as f64 - h) * norm;
                let im = (2.0 * q as f64 - h) * norm;
                acc += 1.0 / (re * re + im * im);
            }
        }
        acc / (side * side) as f64
    }

    /// Places N_sc subcarrier values into an N-point spectrum (zeros elsewhere).
    pub fn place(&self, values: &[Complex64], spectrum: &mut [Complex64]) {
        spectrum.fill(Complex64::new(0.0, 0.0));
        for (i, v) in values.iter().enumerate() {
            spectrum[self.bin(i)] = *v;
        }
    }
}

/// Scale of an M-QAM alphabet with `side` points per axis to unit mean power.
fn qam_norm(side: u32) -> f32 {
    // mean of (2i − (side−1))² over i = (side² − 1)/3 per axis, two axes.
    let m = side as f64;
    (1.0 / (2.0 * (m * m - 1.0) / 3.0)).sqrt() as f32
}

/// Time-domain useful part of symbol `m`: `u_m[n]`, n = 0..N (unit mean power).
pub fn symbol_time_domain(
    num: &Numerology,
    data: &[Complex32],
    fft: &dyn rustfft::Fft<f64>,
) -> Vec<Complex64> {
    let mut spec = vec![Complex64::new(0.0, 0.0); num.fft_size];
    let scale = 1.0 / (num.subcarriers as f64).sqrt();
    for (i, x) in data.iter().enumerate() {
        spec[num.bin(i)] = Complex64::new(x.re as f64 * scale, x.im as f64 * scale);
    }
    fft.process(&mut spec);
    spec
}

#[cfg(test)]
mod tests {
    use super::*;
    use rustfft::FftPlanner;

    fn num(m: Modulation) -> Numerology {
        let r = RadarConfig {
            modulation: m,
            ..RadarConfig::default()
        };
        Numerology::new(&r, 150e6, 0.1).unwrap()
    }

    #[test]
    fn a_bad_bandwidth_names_where_it_came_from() {
        let scene_b = RadarConfig {
            bandwidth_hz: Some(300e6),
            ..RadarConfig::default()
        };
        let e = Numerology::new(&scene_b, 150e6, 0.1)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("radar.bandwidth_hz") && e.contains("245760000"),
            "{e}"
        );
        for b in [300e6, f64::NAN, -1.0, 10e3] {
            let e = Numerology::new(&RadarConfig::default(), b, 0.1)
                .unwrap_err()
                .to_string();
            assert!(e.contains("params.bandwidth_hz"), "{b}: {e}");
        }
        // the scene's bandwidth wins over the mission's
        let scene_b = RadarConfig {
            bandwidth_hz: Some(50e6),
            ..RadarConfig::default()
        };
        let n = Numerology::new(&scene_b, 300e6, 0.1).unwrap();
        assert!(
            (n.bandwidth_hz() - 50e6).abs() < 60e3,
            "{}",
            n.bandwidth_hz()
        );
    }

    #[test]
    fn default_numerology() {
        let n = num(Modulation::Qpsk);
        assert_eq!(n.subcarriers, 2500);
        assert!((n.sample_rate_hz() - 245.76e6).abs() < 1e-3);
        assert!((n.carrier_hz - 2.99792458e9).abs() < 1.0);
        assert!((n.cp_range_m() - 1249.1).abs() < 0.5, "{}", n.cp_range_m());
        assert_eq!(n.bin(0), 4096 - 1250);
        assert_eq!(n.bin(1250), 0);
    }

    #[test]
    fn data_is_reproducible_random_access_and_unit_power() {
        for m in [
            Modulation::Qpsk,
            Modulation::Qam16,
            Modulation::Qam64,
            Modulation::Qam256,
        ] {
            let n = num(m);
            let a = n.symbol_data(17);
            assert_eq!(a, n.symbol_data(17));
            assert_ne!(a, n.symbol_data(18));
            let p: f64 = a.iter().map(|x| x.norm_sqr() as f64).sum::<f64>() / a.len() as f64;
            assert!((p - 1.0).abs() < 0.06, "{m:?}: {p}");
        }
        assert!((num(Modulation::Qpsk).mean_inverse_power() - 1.0).abs() < 1e-6);
        assert!(num(Modulation::Qam16).mean_inverse_power() > 1.5);
    }

    #[test]
    fn time_domain_power_and_band() {
        let n = num(Modulation::Qpsk);
        let fft = FftPlanner::new().plan_fft_inverse(n.fft_size);
        let u = symbol_time_domain(&n, &n.symbol_data(3), fft.as_ref());
        let p: f64 = u.iter().map(|x| x.norm_sqr()).sum::<f64>() / u.len() as f64;
        assert!((p - 1.0).abs() < 1e-6, "{p}");
    }
}
