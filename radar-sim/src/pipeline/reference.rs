//! What the processor takes as the transmitted signal of each symbol (`radar.reference`):
//! - `ideal`: every value the BS sent (without `[radar.nr]` the seeded QAM data);
//! - `pilots`: the reference signals' REs (PSS, SSS, PBCH DMRS, TRS, PRS, PDSCH DMRS) with the
//!   others zero, so that the canceller's basis and range compression see only them (a per-symbol
//!   mask: [`crate::compress::RangeCompressor::spectrum`] averages each subcarrier over the
//!   pulse's symbols that know it and normalises by the subcarriers known, so the PRS's
//!   staggered comb offsets fill the band evenly and its comb alias cancels over a full
//!   staggering cycle);
//! - `reconstructed`: the pilots, and each data RE decided hard from the UAV's own recording of
//!   the pulse: the direct path's complex gain ĝ is the least-squares fit over the pulse's pilot
//!   REs of `Y_i = ĝ (N/√N_sc) X_i e^{−j2πk_iΔ_d/N}` (Δ_d the direct path's delay in the window
//!   from navigation), each RE is divided by that channel and decided
//!   ([`crate::nr::NrGrid::reconstruct`]). Echoes and noise are in the recording: a wrong
//!   decision is a wrong reference value.

use rustfft::num_complex::{Complex32, Complex64};

use crate::config::RangeFilter;
use crate::error::{RadarError, Result};
use crate::nr::grid::{NrSymbol, Role};
use crate::nr::{NrIllumination, Reference};

use super::Processor;

/// Pulses sampled for the mask's noise factor and the pilot check.
const SAMPLED_PULSES: u64 = 64;

fn c32(v: &[Complex64]) -> Vec<Complex32> {
    v.iter()
        .map(|x| Complex32::new(x.re as f32, x.im as f32))
        .collect()
}

/// Whether RE `r` is known to the processor under `reference`.
fn known(reference: Reference, r: Role) -> bool {
    match reference {
        Reference::Pilots => r == Role::Pilot,
        Reference::Ideal | Reference::Reconstructed => r != Role::Empty,
    }
}

impl Processor {
    /// The first symbol of pulse `q` of the cell's pulse plan.
    fn pulse_start(ill: &NrIllumination, q: u64) -> u64 {
        let p = &ill.pulse;
        (q * p.period_slots + p.slot) * ill.grid.frame.symbols_per_slot() as u64
            + p.first_symbol as u64
    }

    /// Under NR, the profile noise factor `mean_q Σ_i w_i² (Σ_{s knows i} |f_{s,i}|²) / c_i² /
    /// (Σ_{i: c_i > 0} w_i)²` over the first [`SAMPLED_PULSES`] pulses (f the range filter, w
    /// the range weights, c_i the pulse's symbols that know subcarrier i: range compression
    /// averages over them), so that a profile sample's noise variance is `σ² N_sc / N` times it
    /// (without NR: `f̄² Σw² / (S (Σw)²)` exactly, S symbols per pulse). Refuses `pilots` and
    /// `reconstructed` when a sampled pulse holds no pilot (nothing to compress, or to
    /// equalise the direct path with).
    pub(super) fn nr_noise_factor(
        ill: &NrIllumination,
        reference: Reference,
        filter: RangeFilter,
        weights: &[f64],
    ) -> Result<f64> {
        let nsc = weights.len();
        let mut acc = 0.0;
        for q in 0..SAMPLED_PULSES {
            let m0 = Self::pulse_start(ill, q);
            // per subcarrier: symbols that know it, and Σ |f|² over them
            let (mut count, mut f2) = (vec![0u32; nsc], vec![0.0f64; nsc]);
            let mut pilots = 0usize;
            for s in 0..ill.pulse.symbols as u64 {
                let sym = ill.grid.symbol(m0 + s);
                for (i, (v, r)) in sym.values.iter().zip(&sym.roles).enumerate().take(nsc) {
                    pilots += usize::from(*r == Role::Pilot);
                    if known(reference, *r) {
                        let p = v.norm_sqr();
                        count[i] += 1;
                        f2[i] += match filter {
                            RangeFilter::Matched => p,
                            RangeFilter::Reciprocal => 1.0 / p,
                        };
                    }
                }
            }
            if reference != Reference::Ideal && pilots == 0 {
                return Err(RadarError::config(
                    "radar.reference",
                    format!(
                        "pulse {q} (symbols from {m0}) holds no reference signal: \"pilots\" \
                         has nothing to compress and \"reconstructed\" nothing to equalise the \
                         direct path with; send the PRS in the pulse's slot or put the pulse \
                         on a DMRS symbol (radar.nr.pulse_first_symbol)"
                    ),
                ));
            }
            let (mut s1, mut s2) = (0.0, 0.0);
            for ((c, f), w) in count.iter().zip(&f2).zip(weights) {
                if *c > 0 {
                    let c = f64::from(*c);
                    s1 += w;
                    s2 += w * w * f / (c * c);
                }
            }
            if s1 > 0.0 {
                acc += s2 / (s1 * s1);
            }
        }
        Ok(acc / SAMPLED_PULSES as f64)
    }

    /// The reference of the pulse whose windows start at symbol `m0`, one per window (N_sc
    /// values), from their received spectra `spectra` (N bins each, unnormalised forward FFT of
    /// the windows) and the direct path's delay in the window from navigation,
    /// `dp_delay_samples`.
    pub fn pulse_reference(
        &self,
        m0: u64,
        spectra: &[Vec<Complex64>],
        dp_delay_samples: f64,
    ) -> Vec<Vec<Complex32>> {
        let num = &self.setup.num;
        let reference = self.setup.scene.radar.reference;
        let Some(ill) = num.nr.as_deref().filter(|_| reference != Reference::Ideal) else {
            return (0..spectra.len() as u64)
                .map(|s| num.symbol_data(m0 + s))
                .collect();
        };
        let symbols: Vec<NrSymbol> = ill.grid.symbols(m0, spectra.len());
        if reference == Reference::Pilots {
            return symbols.iter().map(|s| c32(&s.pilots())).collect();
        }
        // the direct path's channel on each subcarrier, up to its gain: (N/√N_sc) e^{−j2πkΔ/N}
        let n = num.fft_size as f64;
        let c = n / (num.subcarriers as f64).sqrt();
        let ramp: Vec<Complex64> = (0..num.subcarriers)
            .map(|i| {
                let k = num.subcarrier_index(i) as f64;
                let cycles = (k * dp_delay_samples / n).fract();
                Complex64::from_polar(c, -std::f64::consts::TAU * cycles)
            })
            .collect();
        let (mut num_acc, mut den) = (Complex64::default(), 0.0);
        for (sym, spec) in symbols.iter().zip(spectra) {
            for (i, (v, r)) in sym.values.iter().zip(&sym.roles).enumerate() {
                if *r == Role::Pilot {
                    let b = v * ramp[i];
                    num_acc += spec[num.bin(i)] * b.conj();
                    den += b.norm_sqr();
                }
            }
        }
        if den <= 0.0 || num_acc.norm() == 0.0 {
            // no pilot to equalise with: only the pilots are known
            return symbols.iter().map(|s| c32(&s.pilots())).collect();
        }
        let g = num_acc / den;
        symbols
            .iter()
            .zip(spectra)
            .map(|(sym, spec)| {
                let eq: Vec<Complex64> = (0..num.subcarriers)
                    .map(|i| spec[num.bin(i)] / (g * ramp[i]))
                    .collect();
                c32(&ill.grid.reconstruct(sym, &eq))
            })
            .collect()
    }
}
