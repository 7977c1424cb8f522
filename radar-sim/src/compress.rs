//! Range compression of the (cancelled) symbol windows of a pulse: matched filter (× conj X) or
//! OFDM reciprocal filter (÷ X) per subcarrier, optional spectral weighting, coherent sum over
//! the pulse's symbols, and an upsampled range profile by zero-padded inverse FFT.
//!
//! Normalisation: a path `a·u(n − Δ)` gives a profile `p(x)` that peaks at `x = Δ` with value `a`
//! (reciprocal filter exactly; matched filter on average). Where the reference is zero (an empty
//! RE of an NR grid, or one the processor does not know) the RE is masked, and the profile is
//! normalised by the weights of the known REs of all the pulse's symbols. Profile sample j of a window starting
//! at j0 lies at delay `(j0 + j)/U` samples (periodic in N).

use std::sync::Arc;

use rustfft::num_complex::{Complex32, Complex64};
use rustfft::Fft;

use crate::cancel::SymbolWindow;
use crate::config::{RangeFilter, Weighting};
use crate::waveform::Numerology;

/// Range compressor for one numerology.
pub struct RangeCompressor {
    num: Numerology,
    filter: RangeFilter,
    weights: Vec<f64>,
    upsample: usize,
    ifft_up: Arc<dyn Fft<f32>>,
}

impl std::fmt::Debug for RangeCompressor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RangeCompressor")
            .field("filter", &self.filter)
            .field("upsample", &self.upsample)
            .finish_non_exhaustive()
    }
}

impl RangeCompressor {
    /// A compressor with `filter`, spectral `weighting` and upsampling factor `upsample`.
    pub fn new(
        num: &Numerology,
        filter: RangeFilter,
        weighting: Weighting,
        upsample: usize,
    ) -> Self {
        let ifft_up = crate::kernels::FftMaker::new().inverse(num.fft_size * upsample.max(1));
        Self {
            num: num.clone(),
            filter,
            weights: weighting.weights(num.subcarriers),
            upsample: upsample.max(1),
            ifft_up,
        }
    }

    /// The upsampling factor U.
    pub fn upsample(&self) -> usize {
        self.upsample
    }

    /// Length of the full periodic profile, N U.
    pub fn profile_len(&self) -> usize {
        self.num.fft_size * self.upsample
    }

    /// Compressed spectrum Z_i over the occupied subcarriers (N_sc values), normalised so that
    /// the profile is `Σ_i Z_i e^{j2πk_iΔ/N}`.
    pub fn spectrum(&self, windows: &[SymbolWindow]) -> Vec<Complex64> {
        let num = &self.num;
        let nsc = num.subcarriers;
        let wsum: f64 = self.weights.iter().sum();
        let full = windows
            .iter()
            .all(|w| w.data.iter().all(|x| x.re != 0.0 || x.im != 0.0));
        let mut z = vec![Complex64::new(0.0, 0.0); nsc];
        let filter = |x: Complex32| {
            let x = Complex64::new(x.re as f64, x.im as f64);
            match self.filter {
                RangeFilter::Matched => x.conj(),
                RangeFilter::Reciprocal => {
                    let p = x.norm_sqr();
                    if p > 0.0 {
                        x.conj() / p
                    } else {
                        Complex64::new(0.0, 0.0)
                    }
                }
            }
        };
        if full {
            let scale =
                (nsc as f64).sqrt() / (num.fft_size as f64 * windows.len().max(1) as f64 * wsum);
            for w in windows {
                for (i, zi) in z.iter_mut().enumerate() {
                    *zi += w.spectrum[num.bin(i)] * filter(w.data[i]) * (self.weights[i] * scale);
                }
            }
            return z;
        }
        // a mask (empty or unknown REs are zero): each subcarrier is the mean over the pulse's
        // symbols that know it, and the profile is normalised by the weights of the subcarriers
        // known in any of them (staggered comb symbols then fill the band evenly)
        let mut count = vec![0u32; nsc];
        for w in windows {
            for (c, x) in count.iter_mut().zip(w.data.iter()) {
                *c += u32::from(x.re != 0.0 || x.im != 0.0);
            }
        }
        let known: f64 = count
            .iter()
            .zip(&self.weights)
            .filter(|(c, _)| **c > 0)
            .map(|(_, w)| w)
            .sum();
        if known <= 0.0 {
            return z;
        }
        let base = (nsc as f64).sqrt() / (num.fft_size as f64 * known);
        let scales: Vec<f64> = count
            .iter()
            .zip(&self.weights)
            .map(|(c, w)| {
                if *c > 0 {
                    w * base / f64::from(*c)
                } else {
                    0.0
                }
            })
            .collect();
        for w in windows {
            for (i, zi) in z.iter_mut().enumerate() {
                *zi += w.spectrum[num.bin(i)] * filter(w.data[i]) * scales[i];
            }
        }
        z
    }

    /// The profile at fractional delay `delay` (samples), evaluated exactly from `z`:
    /// `Σ_i z_i e^{j2π k_i Δ/N}` by phasor recurrence, eight subcarriers in SIMD lanes.
    pub fn evaluate(&self, z: &[Complex64], delay: f64) -> Complex64 {
        crate::dsp::ramp_sum(
            z,
            self.num.subcarrier_index(0) as f64,
            self.num.fft_size,
            delay,
        )
    }

    /// The upsampled profile window: samples j = j0 .. j0 + len at delays (j0 + j)/U (periodic).
    pub fn profile_window(&self, z: &[Complex64], j0: i64, len: usize) -> Vec<Complex32> {
        thread_local! {
            // the N·U buffer is large (256 KiB at the defaults): reuse it per thread instead of
            // mapping fresh pages for every pulse
            static BUF: std::cell::RefCell<Vec<Complex32>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        let nu = self.profile_len();
        BUF.with(|b| {
            let mut buf = b.borrow_mut();
            buf.clear();
            buf.resize(nu, Complex32::new(0.0, 0.0));
            for (i, v) in z.iter().enumerate() {
                let k = self.num.subcarrier_index(i).rem_euclid(nu as i64) as usize;
                buf[k] = Complex32::new(v.re as f32, v.im as f32);
            }
            self.ifft_up.process(&mut buf);
            let start = j0.rem_euclid(nu as i64) as usize;
            (0..len).map(|j| buf[(start + j) % nu]).collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RadarConfig;

    #[test]
    fn point_path_peaks_at_its_delay_with_its_amplitude() {
        let r = RadarConfig::default();
        let num = Numerology::new(&r, 150e6, 0.1).unwrap();
        let data = Arc::new(num.symbol_data(9));
        let a = Complex64::new(0.3, -0.2);
        let delay = 123.375;
        let n = num.fft_size as f64;
        let mut spec = vec![Complex64::new(0.0, 0.0); num.fft_size];
        for i in 0..num.subcarriers {
            let k = num.subcarrier_index(i) as f64;
            let x = data[i];
            spec[num.bin(i)] = a * Complex64::new(x.re as f64, x.im as f64) * n
                / (num.subcarriers as f64).sqrt()
                * Complex64::from_polar(1.0, -std::f64::consts::TAU * k * delay / n);
        }
        let w = SymbolWindow {
            spectrum: spec,
            data,
            t_s: 0.0,
            dp_delay_samples: 0.0,
        };
        for filter in [RangeFilter::Matched, RangeFilter::Reciprocal] {
            let c = RangeCompressor::new(&num, filter, Weighting::None, 8);
            let z = c.spectrum(std::slice::from_ref(&w));
            assert!((c.evaluate(&z, delay) - a).norm() < 1e-6);
            let prof = c.profile_window(&z, 980, 20); // delays 122.5 .. 125
            let peak = prof
                .iter()
                .enumerate()
                .max_by(|x, y| x.1.norm().total_cmp(&y.1.norm()))
                .unwrap();
            assert_eq!(peak.0, 7); // 987 / 8 = 123.375
            assert!(
                (peak.1.re as f64 - a.re).abs() < 1e-5 && (peak.1.im as f64 - a.im).abs() < 1e-5
            );
        }
    }
}
