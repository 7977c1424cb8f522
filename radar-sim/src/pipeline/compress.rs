//! Cancellation and range compression of one aperture's pulses ([`Processor::compress`]).

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::{Complex32, Complex64};

use crate::backproject::{profile_windows, BpPulse, Grid};
use crate::cancel::{CancelStats, SymbolWindow};
use crate::config::CancellerKind;
use crate::error::{RadarError, Result};
use crate::track::PulseMeta;
use crate::waveform::C_MPS;

use super::{Compressed, Processor};

/// One batch's output: per-pulse profile windows, kept spectra, canceller metrics.
type BatchOut = (Vec<Vec<Complex32>>, Vec<Vec<Complex64>>, CancelStats);

impl Processor {
    /// Cancels and range-compresses `pulses` (IQ: pulses × samples) for imaging on `grid`.
    /// `looks` gives the pulses per look (ECA batches never cross looks).
    pub fn compress(
        &self,
        grid: &Grid,
        pulses: &[PulseMeta],
        iq: &[Complex32],
        pulses_per_look: usize,
        target_m: Option<[f64; 2]>,
        keep_spectra: bool,
    ) -> Result<Compressed> {
        let num = &self.setup.num;
        let spp = self.setup.scene.radar.symbols_per_pulse;
        let n = num.fft_size;
        if iq.len() != pulses.len() * spp * n {
            return Err(RadarError::Shape {
                what: "IQ frame".into(),
                expected: format!("{} pulses × {} samples", pulses.len(), spp * n),
                found: format!("{} samples", iq.len()),
            });
        }
        let geom = self.setup.geometry();
        let raw: Vec<([f64; 3], i64)> = pulses
            .iter()
            .map(|p| (p.pos_m, p.window_delay_samples))
            .collect();
        let (j0s, m) = profile_windows(&geom, grid, &raw);
        let pc = &self.setup.scene.processing;
        let batch = match pc.canceller {
            CancellerKind::None => 1,
            CancellerKind::EcaB => pc.batch_pulses,
            CancellerKind::Eca => pulses_per_look.max(1),
        };
        // batches never cross looks
        let ppl = pulses_per_look.max(1);
        let mut ranges = Vec::new();
        let mut s = 0;
        while s < pulses.len() {
            let look_end = ((s / ppl) + 1) * ppl;
            let e = (s + batch).min(look_end).min(pulses.len());
            ranges.push(s..e);
            s = e;
        }
        let fs = num.sample_rate_hz();
        let results: Vec<Result<BatchOut>> = ranges
            .par_iter()
            .map(|r| {
                let mut windows = Vec::with_capacity(r.len() * spp);
                for (k, p) in pulses[r.clone()].iter().enumerate() {
                    let rd = crate::track::dist3(p.pos_m, self.setup.bs_m);
                    let dp = rd * fs / C_MPS - p.window_delay_samples as f64;
                    let specs: Vec<Vec<Complex64>> = (0..spp)
                        .map(|s| {
                            let off = ((r.start + k) * spp + s) * n;
                            let mut spec: Vec<Complex64> = iq[off..off + n]
                                .iter()
                                .map(|v| Complex64::new(v.re as f64, v.im as f64))
                                .collect();
                            self.fft.process(&mut spec);
                            spec
                        })
                        .collect();
                    let refs = self.pulse_reference(p.symbol, &specs, dp);
                    for (s, (spec, data)) in specs.into_iter().zip(refs).enumerate() {
                        let m_sym = p.symbol + s as u64;
                        windows.push(SymbolWindow {
                            spectrum: spec,
                            data: Arc::new(data),
                            t_s: (num.useful_start_sample(m_sym) + p.window_delay_samples as f64)
                                / fs,
                            dp_delay_samples: dp,
                        });
                    }
                }
                let mid = &pulses[(r.start + r.end) / 2];
                let td =
                    target_m.map(|t| geom.delay_samples(t, mid.pos_m, mid.window_delay_samples));
                let stats = self.canceller.cancel_batch(
                    &mut windows,
                    td,
                    self.fft.as_ref(),
                    self.ifft.as_ref(),
                )?;
                let mut profs = Vec::with_capacity(r.len());
                let mut specs = Vec::new();
                for (k, pi) in r.clone().enumerate() {
                    let z = self.compressor.spectrum(&windows[k * spp..(k + 1) * spp]);
                    profs.push(self.compressor.profile_window(&z, j0s[pi], m));
                    if keep_spectra {
                        specs.push(z);
                    }
                }
                Ok((profs, specs, stats))
            })
            .collect();
        let mut profiles = Vec::with_capacity(pulses.len() * m);
        let mut spectra = keep_spectra.then(Vec::new);
        let mut cancel = CancelStats::default();
        for r in results {
            let (p, z, st) = r?;
            for v in p {
                profiles.extend_from_slice(&v);
            }
            if let Some(s) = spectra.as_mut() {
                s.extend(z);
            }
            cancel.add(&st);
        }
        let mut bp = Vec::with_capacity(pulses.len());
        for (k, (p, j0)) in pulses.iter().zip(&j0s).enumerate() {
            let w = self.look_weights(ppl.min(pulses.len()));
            bp.push(BpPulse {
                pos_m: p.pos_m,
                window_delay_samples: p.window_delay_samples,
                j0: *j0,
                weight: w.get(k % ppl).copied().unwrap_or(1.0),
            });
        }
        Ok(Compressed {
            pulses: bp,
            profiles,
            m,
            spectra,
            cancel,
        })
    }
}
