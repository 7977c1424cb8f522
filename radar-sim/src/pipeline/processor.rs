//! The [`Processor`] of one setup: construction, noise and power predictions.

use std::sync::Arc;

use rustfft::Fft;

use crate::cancel::Canceller;
use crate::compress::RangeCompressor;
use crate::config::RangeFilter;
use crate::error::Result;
use crate::scene::SceneObject;
use crate::synth::Synthesizer;
use crate::track::PulseMeta;

use super::RadarSetup;

/// Coherent amplitude factor of a path `delay_samples` into a CP-free window of `n` samples
/// with `cp` samples of cyclic prefix: the fraction of the window that still holds the
/// symbol's own data, `max(0, 1 − (max(Δ − N_cp, 0) + max(−Δ, 0)) / N)` (the rest carries the
/// neighbouring symbol, uncorrelated with the reference).
pub fn cp_overlap_factor(delay_samples: f64, n: usize, cp: usize) -> f64 {
    let spill = (delay_samples - cp as f64).max(0.0) + (-delay_samples).max(0.0);
    (1.0 - spill / n as f64).max(0.0)
}

/// The processor of one setup.
pub struct Processor {
    pub(super) setup: RadarSetup,
    pub(super) canceller: Canceller,
    pub(super) compressor: RangeCompressor,
    pub(super) fft: Arc<dyn Fft<f64>>,
    pub(super) ifft: Arc<dyn Fft<f64>>,
    pub(super) link: Synthesizer,
    /// Under NR, the profile noise factor of the reference's mask (see
    /// [`Processor::profile_noise_var`]).
    pub(super) nr_noise_factor: Option<f64>,
}

impl std::fmt::Debug for Processor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Processor")
            .field("canceller", &self.canceller)
            .field("compressor", &self.compressor)
            .finish_non_exhaustive()
    }
}

impl Processor {
    /// A processor for `setup`.
    pub fn new(setup: RadarSetup) -> Result<Self> {
        let pc = &setup.scene.processing;
        let canceller = Canceller::new(pc, &setup.num)?;
        let compressor =
            RangeCompressor::new(&setup.num, pc.range_filter, pc.range_weighting, pc.upsample);
        let mut planner = crate::kernels::FftMaker::new();
        let fft = planner.forward(setup.num.fft_size);
        let ifft = planner.inverse(setup.num.fft_size);
        let link = setup.synthesizer(Vec::new())?;
        let nr_noise_factor = match setup.num.nr.as_deref() {
            Some(ill) => Some(Self::nr_noise_factor(
                ill,
                setup.scene.radar.reference,
                pc.range_filter,
                &pc.range_weighting.weights(setup.num.subcarriers),
            )?),
            None => None,
        };
        Ok(Self {
            nr_noise_factor,
            setup,
            canceller,
            compressor,
            fft,
            ifft,
            link,
        })
    }

    /// The setup.
    pub fn setup(&self) -> &RadarSetup {
        &self.setup
    }

    /// The range compressor.
    pub fn compressor(&self) -> &RangeCompressor {
        &self.compressor
    }

    /// Variance of one profile sample from thermal noise, W. Under NR, with the mean noise
    /// factor of the reference's known REs over the first pulses (fewer known REs: more noise
    /// per profile sample, since the profile is normalised by them).
    pub fn profile_noise_var(&self) -> f64 {
        let num = &self.setup.num;
        if let Some(f) = self.nr_noise_factor {
            return self.link.noise_power_w() * num.subcarriers as f64 / num.fft_size as f64 * f;
        }
        let pc = &self.setup.scene.processing;
        let w = pc.range_weighting.weights(num.subcarriers);
        let s1: f64 = w.iter().sum();
        let s2: f64 = w.iter().map(|x| x * x).sum();
        let f2 = match pc.range_filter {
            RangeFilter::Matched => 1.0,
            RangeFilter::Reciprocal => num.mean_inverse_power(),
        };
        let spp = self.setup.scene.radar.symbols_per_pulse as f64;
        self.link.noise_power_w() * f2 * s2 * num.subcarriers as f64
            / (num.fft_size as f64 * spp * s1 * s1)
    }

    /// Slow-time weights of a look of `n` pulses.
    pub fn look_weights(&self, n: usize) -> Vec<f32> {
        self.setup
            .scene
            .processing
            .azimuth_weighting
            .weights(n)
            .into_iter()
            .map(|w| w as f32)
            .collect()
    }

    /// Per-look noise variance of an image pixel, W.
    pub fn look_noise_var(&self, n: usize) -> f64 {
        let w = self.look_weights(n);
        self.profile_noise_var() * w.iter().map(|x| (*x as f64).powi(2)).sum::<f64>()
    }

    /// Expected per-look image SNR of `obj` over `pulses` (one look), dB:
    /// (Σ w f √P)² / (Σ w² σ_p²), with f the [`cp_overlap_factor`] of the echo's delay in the
    /// pulse's window (1 inside the cyclic prefix; an echo beyond it shares the window with the
    /// previous symbol and loses that fraction of its coherent gain).
    pub fn expected_snr_db(&self, obj: &SceneObject, pulses: &[PulseMeta]) -> f64 {
        let w = self.look_weights(pulses.len());
        let geom = self.setup.geometry();
        let (n, cp) = (self.setup.num.fft_size, self.setup.num.cp_samples);
        let amp: f64 = pulses
            .iter()
            .zip(&w)
            .map(|(p, w)| {
                let delay = geom.delay_samples(obj.pos_m(), p.pos_m, p.window_delay_samples);
                *w as f64
                    * cp_overlap_factor(delay, n, cp)
                    * self.link.echo_power_w(obj, p.pos_m, p.heading).sqrt()
            })
            .sum();
        10.0 * (amp * amp / self.look_noise_var(pulses.len())).log10()
    }

    /// [`Self::expected_snr_db`] of `obj` in each of the `looks` looks of `pulses`
    /// (`pulses_per_look` each), dB.
    pub fn look_snrs_db(
        &self,
        obj: &SceneObject,
        pulses: &[PulseMeta],
        pulses_per_look: usize,
        looks: usize,
    ) -> Vec<f64> {
        (0..looks)
            .map(|l| {
                self.expected_snr_db(obj, &pulses[l * pulses_per_look..(l + 1) * pulses_per_look])
            })
            .collect()
    }

    /// The mean over looks of the linear per-look SNR of [`Self::look_snrs_db`] (what the closed
    /// loop reports for an object at its aperture), linear.
    pub fn mean_look_snr(look_snrs_db: &[f64]) -> f64 {
        look_snrs_db
            .iter()
            .map(|db| 10f64.powf(db / 10.0))
            .sum::<f64>()
            / look_snrs_db.len().max(1) as f64
    }

    /// Predicted echo power per sample at the receiver, W: the link budget of `objects`
    /// summed, mean over `pulses`.
    pub fn echo_power_w(&self, objects: &[SceneObject], pulses: &[PulseMeta]) -> f64 {
        if pulses.is_empty() {
            return 0.0;
        }
        pulses
            .iter()
            .map(|p| {
                objects
                    .iter()
                    .map(|o| self.link.echo_power_w(o, p.pos_m, p.heading))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / pulses.len() as f64
    }

    /// Predicted power per sample of the echoes' inter-symbol interference, W, mean over
    /// `pulses`: an echo with [`cp_overlap_factor`] f < 1 leaves `P (1 − f²)` of its power
    /// uncorrelated with the reference (the neighbouring symbol's data), which range
    /// compression spreads like white noise, raising the image's floor.
    pub fn isi_power_w(&self, objects: &[SceneObject], pulses: &[PulseMeta]) -> f64 {
        if pulses.is_empty() {
            return 0.0;
        }
        let geom = self.setup.geometry();
        let (n, cp) = (self.setup.num.fft_size, self.setup.num.cp_samples);
        pulses
            .iter()
            .map(|p| {
                objects
                    .iter()
                    .map(|o| {
                        let delay = geom.delay_samples(o.pos_m(), p.pos_m, p.window_delay_samples);
                        let f = cp_overlap_factor(delay, n, cp);
                        self.link.echo_power_w(o, p.pos_m, p.heading) * (1.0 - f * f)
                    })
                    .sum::<f64>()
            })
            .sum::<f64>()
            / pulses.len() as f64
    }

    /// Thermal noise power per complex sample at the receiver, W.
    pub fn noise_power_w(&self) -> f64 {
        self.link.noise_power_w()
    }
}
