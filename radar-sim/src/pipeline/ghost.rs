//! The coherent ghosts of echoes beyond the cyclic prefix under an NR cell ([`GhostModel`],
//! for the exact sidelobe editing's [`crate::cfar::LookImages::ghosts`]).
//!
//! An echo beyond the CP leaves in each window the previous symbol's tail and only part of its
//! own symbol. Range compression multiplies each RE by the conjugate reference, so what it makes
//! of that interference is, on average over the data (drawn afresh every slot), the pilots'
//! share alone: the compression, on the pilots' REs, of the windows of the *pilots' own*
//! waveform at the echo's delay. The PRS, the SSB and the TRS are scrambled by the slot and the
//! pulse is always the same slot of the frame, so that share repeats from pulse to pulse and
//! focuses beside the echo like the echo itself; the data's share averages out like noise (the
//! predicted floor counts it). This module synthesises those windows for a few pulses per look
//! (at the source's delay in the look's middle pulse) and compresses them with the processor's
//! own range compression, over the main peak of the whole signal's echo: with `pilots` that is
//! the reference's own ghost, with `ideal` and `reconstructed` the part of theirs that repeats.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use rustfft::num_complex::{Complex32, Complex64};

use crate::cancel::SymbolWindow;
use crate::cfar::GhostProfile;
use crate::nr::grid::Role;
use crate::nr::{NrIllumination, Reference};
use crate::track::PulseMeta;

use super::{cp_overlap_factor, Processor};

/// Below this overlap factor the source's main peak, and so the ghost's scale, is not modelled.
const MIN_OVERLAP: f64 = 0.05;

/// The distinct pilot patterns of the pulses whose first symbols are `pulses` (the pilots of
/// the symbols a window may reach: the same pilots make the same ghost), each as its first
/// pulse's first symbol and its pulses' share of the slow-time weights `weights`.
fn patterns_of(
    proc: &Processor,
    ill: &NrIllumination,
    pulses: impl Iterator<Item = u64>,
    weights: &[f32],
) -> Vec<(u64, f64)> {
    use std::hash::{Hash, Hasher};
    let spp = proc.setup.scene.radar.symbols_per_pulse;
    let mut out: Vec<(u64, u64, f64)> = Vec::new();
    let mut total = 0.0;
    for (k, m0) in pulses.enumerate() {
        let first = m0.saturating_sub(SYMBOLS_BEFORE);
        let count = (m0 - first) as usize + spp + 1;
        let mut h = std::collections::hash_map::DefaultHasher::new();
        for sym in ill.grid.symbols(first, count) {
            for v in sym.pilots() {
                v.re.to_bits().hash(&mut h);
                v.im.to_bits().hash(&mut h);
            }
        }
        let key = h.finish();
        let w = weights.get(k).map_or(0.0, |w| f64::from(*w));
        total += w;
        match out.iter_mut().find(|(kk, _, _)| *kk == key) {
            Some(e) => e.2 += w,
            None => out.push((key, m0, w)),
        }
    }
    let total = if total > 0.0 { total } else { 1.0 };
    out.into_iter().map(|(_, m0, w)| (m0, w / total)).collect()
}

/// Pulses of a look whose pilots make its ghost. The PRS, the SSB and the TRS repeat with the
/// frame, but the PDSCH's DMRS lies on the PRBs the slot loads, drawn afresh every slot: no two
/// pulses' pilots need agree, and the ghost that repeats is their mean, estimated from this
/// many pulses spread over the look (`nr_cp_ghosts.rs` measures its fit).
pub const PATTERN_SAMPLES: usize = 4;

/// The pulses (indices into a look of `len`) whose pilots are sampled: [`PATTERN_SAMPLES`]
/// spread evenly, fewer in a shorter look.
fn sample_pulses(len: usize) -> impl Iterator<Item = usize> {
    let k = PATTERN_SAMPLES.min(len);
    (0..k).map(move |j| (2 * j + 1) * len / (2 * k))
}

/// A bound on the ghost's peak power over its mean power per profile sample. The mean is
/// `(1 − f²)/N_sc` of the main peak's power (an echo of power P leaves P (1 − f²) to the
/// neighbouring symbols, spread over the profile's N_sc independent samples, against the peak's
/// N_sc-fold coherent gain); the peak of the pilots' ghost measures 3.2–3.8 dB over that
/// (`nr_cp_ghosts.rs`), and 13 dB is where the largest of the profile's N_sc samples of a
/// Gaussian field would lie.
pub const GHOST_PEAK_OVER_MEAN: f64 = 20.0;

/// A ghost whose bound is under this share of the noise power per pixel is not modelled: it
/// moves no CFAR decision by more than noise's own spread, and most sources' ghosts are.
const NEGLIGIBLE_GHOST: f64 = 0.1;

/// Sources of one aperture whose ghosts are modelled, the strongest first (the editing takes
/// its sources in that order): each holds a table of N × `processing.upsample` values per
/// look (256 KiB at the defaults), so this bounds the aperture's tables, whatever
/// the scene (a cluttered one can have hundreds of strong peaks), to 64 × 4 × 256 KiB at 4
/// looks. No aperture of the main mission under NR reaches it (its debug log says when one does).
pub const MAX_GHOST_SOURCES: usize = 64;

/// Symbols before the pulse's first whose waveform a window may reach (an echo up to one whole
/// symbol beyond the CP).
const SYMBOLS_BEFORE: u64 = 2;

/// The pilots' waveform around one pulse: from symbol `first` on, the useful part (N samples,
/// unnormalised inverse FFT of the pilots at their bins) of each symbol, and what range
/// compression does with each of the pulse's windows.
struct PulseWaveforms {
    first: u64,
    /// Per symbol from `first`: the sample (of the BS's stream) where it starts, its CP first,
    /// and where its useful part starts.
    bounds: Vec<(i64, i64)>,
    useful: Vec<Vec<Complex64>>,
    /// Per symbol of the pulse, per subcarrier, what range compression multiplies that
    /// symbol's spectrum with (the filter of its reference, the taper, the normalisation) on
    /// the pilots' REs, zero on the others.
    filters: Vec<Vec<Complex64>>,
    /// The compressed spectrum (by `filters`) of the pulse's windows of the pilots made
    /// cyclic, at delay 0.
    cyclic0: Vec<Complex64>,
    /// The main peak of the whole signal's echo made cyclic, at delay 0, as the processor
    /// compresses it.
    peak0: Complex64,
}

/// The ghosts of the sources of one aperture's pulses, with the pilots' waveforms cached per
/// pattern.
pub(super) struct GhostModel<'a> {
    proc: &'a Processor,
    ill: &'a NrIllumination,
    pulses: &'a [PulseMeta],
    pulses_per_look: usize,
    /// Per look the distinct pilot patterns of its sampled pulses: a pulse that has it (its
    /// first symbol) and the share of the sampled pulses that have it.
    patterns: Vec<Vec<(u64, f64)>>,
    cache: Mutex<HashMap<u64, Arc<PulseWaveforms>>>,
    /// Sources whose ghosts were modelled ([`MAX_GHOST_SOURCES`] at most).
    modelled: std::sync::atomic::AtomicUsize,
}

impl<'a> GhostModel<'a> {
    /// The model of `pulses` (`looks` looks of `pulses_per_look`), or `None` without an NR
    /// cell.
    pub(super) fn new(
        proc: &'a Processor,
        pulses: &'a [PulseMeta],
        pulses_per_look: usize,
        looks: usize,
    ) -> Option<Self> {
        let ill = proc.setup.num.nr.as_deref()?;
        if pulses_per_look == 0 {
            return None;
        }
        let patterns = (0..looks)
            .map(|l| {
                let start = (l * pulses_per_look).min(pulses.len());
                let end = (start + pulses_per_look).min(pulses.len());
                let look = &pulses[start..end];
                let sampled = sample_pulses(look.len()).map(|k| look[k].symbol);
                patterns_of(proc, ill, sampled, &[1.0; PATTERN_SAMPLES])
            })
            .collect();
        Some(Self {
            proc,
            ill,
            pulses,
            pulses_per_look,
            patterns,
            cache: Mutex::new(HashMap::new()),
            modelled: std::sync::atomic::AtomicUsize::new(0),
        })
    }

    /// Per look the ghost of a point at ground position `q_m` whose peak in the multilook image
    /// is `peak` (in units of the noise), at the look's middle pulse's delay, the mean over the
    /// look's pilot patterns: `None` in a look where its echo lies within every window's CP (or
    /// too far beyond it to be seen at all), or where the ghost's bound
    /// ([`GHOST_PEAK_OVER_MEAN`]) puts it under [`NEGLIGIBLE_GHOST`] of the noise; none at all
    /// past the aperture's first [`MAX_GHOST_SOURCES`] sources that have one.
    pub(super) fn profiles(&self, q_m: [f64; 2], peak: f64) -> Vec<Option<GhostProfile>> {
        let num = &self.proc.setup.num;
        let geom = self.proc.setup.geometry();
        // per look the source's delay in the middle pulse, where its ghost may matter
        let delays: Vec<Option<f64>> = (0..self.patterns.len())
            .map(|l| {
                let start = l * self.pulses_per_look;
                let end = (start + self.pulses_per_look).min(self.pulses.len());
                let look = self.pulses.get(start..end)?;
                let p = look.get(look.len() / 2)?;
                let delay = geom.delay_samples(q_m, p.pos_m, p.window_delay_samples);
                let f = cp_overlap_factor(delay, num.fft_size, num.cp_samples);
                let bound = GHOST_PEAK_OVER_MEAN * (1.0 - f * f) / num.subcarriers as f64;
                (peak * bound >= NEGLIGIBLE_GHOST).then_some(delay)
            })
            .collect();
        if delays.iter().all(Option::is_none) {
            return Vec::new();
        }
        let n = self
            .modelled
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if n >= MAX_GHOST_SOURCES {
            if n == MAX_GHOST_SOURCES {
                tracing::debug!(
                    max = MAX_GHOST_SOURCES,
                    "ghosts of the aperture's weaker sources not modelled"
                );
            }
            return Vec::new();
        }
        self.patterns
            .iter()
            .zip(delays)
            .map(|(patterns, delay)| self.mean_profile(patterns, delay?))
            .collect()
    }

    /// The weighted mean over `patterns` of the ghosts of an echo `delay` samples into the
    /// windows.
    fn mean_profile(&self, patterns: &[(u64, f64)], delay: f64) -> Option<GhostProfile> {
        let mut mean: Option<(Vec<Complex64>, i64)> = None;
        for (m0, share) in patterns {
            let (zg, d) = self.ghost_spectrum(*m0, delay)?;
            match &mut mean {
                None => mean = Some((zg.iter().map(|v| v * share).collect(), d)),
                Some((acc, _)) => acc.iter_mut().zip(&zg).for_each(|(a, v)| *a += v * share),
            }
        }
        let (zg, d) = mean?;
        // tabulated as the processor's range profiles are: N U samples from the echo's delay
        let c = &self.proc.compressor;
        let u = c.upsample();
        let table = c.profile_window(&zg, d * u as i64, c.profile_len());
        Some(GhostProfile::from_table(table, u))
    }

    /// The ghost's compressed spectrum of an echo `delay` samples into the windows of the
    /// pulse whose first symbol is `m0`, over the main peak's value times the overlap factor,
    /// and the whole delay the spectrum is relative to.
    fn ghost_spectrum(&self, m0: u64, delay: f64) -> Option<(Vec<Complex64>, i64)> {
        let num = &self.proc.setup.num;
        let frame = &self.ill.grid.frame;
        let n = num.fft_size;
        let spp = self.proc.setup.scene.radar.symbols_per_pulse;
        let spills = (0..spp as u64).any(|s| {
            let cp = frame.cp_samples(m0 + s) as f64;
            delay < 0.0 || delay > cp
        });
        let f_model = cp_overlap_factor(delay, n, num.cp_samples);
        if !spills || f_model < MIN_OVERLAP {
            return None;
        }
        let wave = self.waveforms(m0)?;
        if wave.peak0.norm() <= 0.0 {
            return None;
        }
        let d = delay.round() as i64;
        // range compression is linear in the windows' spectra: each symbol's per-subcarrier
        // multipliers are the pattern's
        let mut z = vec![Complex64::default(); num.subcarriers];
        let mut y = vec![Complex64::default(); n];
        for (s, filter) in wave.filters.iter().enumerate() {
            let own_start = wave.bounds.get((m0 - wave.first) as usize + s)?.1;
            // the window's samples: the BS's stream d samples earlier, whichever symbol holds it
            y.fill(Complex64::default());
            wave.fill(own_start - d, &mut y);
            self.proc.fft.process(&mut y);
            for (i, (zi, m)) in z.iter_mut().zip(filter).enumerate() {
                *zi += y[num.bin(i)] * m;
            }
        }
        // less what the exact response already holds: the range response of the same echo
        // made cyclic (the delay-0 one delayed: e^{−j2πk_i d/N} by recurrence over k), times the
        // overlap factor of `pulse_gains`
        let scale = 1.0 / (wave.peak0 * f_model);
        let cycles = |k: i64| (k as f64 * d as f64 / n as f64).fract();
        let step = Complex64::from_polar(1.0, -std::f64::consts::TAU * cycles(1));
        let mut ramp = Complex64::from_polar(
            f_model,
            -std::f64::consts::TAU * cycles(num.subcarrier_index(0)),
        );
        for (zi, b) in z.iter_mut().zip(&wave.cyclic0) {
            *zi = (*zi - b * ramp) * scale;
            ramp *= step;
        }
        Some((z, d))
    }

    /// A window of time samples `t` with the reference `data`, transformed.
    fn window(&self, mut t: Vec<Complex64>, data: Arc<Vec<Complex32>>) -> SymbolWindow {
        self.proc.fft.process(&mut t);
        SymbolWindow {
            spectrum: t,
            data,
            t_s: 0.0,
            dp_delay_samples: 0.0,
        }
    }

    /// The pilots' waveform around the pulse whose first symbol is `m0` (cached).
    fn waveforms(&self, m0: u64) -> Option<Arc<PulseWaveforms>> {
        if let Some(w) = self.cache.lock().ok()?.get(&m0) {
            return Some(w.clone());
        }
        let num = &self.proc.setup.num;
        let spp = self.proc.setup.scene.radar.symbols_per_pulse;
        let first = m0.saturating_sub(SYMBOLS_BEFORE);
        // through the symbol after the pulse's last (an echo earlier than the window)
        let count = (m0 - first) as usize + spp + 1;
        let symbols = self.ill.grid.symbols(first, count);
        let useful: Vec<Vec<Complex64>> = symbols
            .iter()
            .map(|sym| {
                let mut buf = vec![Complex64::default(); num.fft_size];
                for (i, v) in sym.pilots().iter().enumerate() {
                    buf[num.bin(i)] = *v;
                }
                self.proc.ifft.process(&mut buf);
                buf
            })
            .collect();
        let own = (m0 - first) as usize;
        let pulse = &symbols[own..][..spp];
        // the processor's reference of each window (`ideal` and `reconstructed`: every value,
        // as `pulse_reference` takes them without a recording)
        let pilots_only = self.proc.setup.scene.radar.reference == Reference::Pilots;
        let references: Vec<Arc<Vec<Complex32>>> = pulse
            .iter()
            .enumerate()
            .map(|(s, sym)| {
                Arc::new(if pilots_only {
                    sym.pilots()
                        .iter()
                        .map(|v| Complex32::new(v.re as f32, v.im as f32))
                        .collect()
                } else {
                    num.symbol_data(m0 + s as u64)
                })
            })
            .collect();
        let frame = &self.ill.grid.frame;
        let bounds: Vec<(i64, i64)> = (first..first + count as u64)
            .map(|m| {
                (
                    frame.symbol_start_sample(m) as i64,
                    frame.useful_start_sample(m) as i64,
                )
            })
            .collect();
        // the main peak of the whole signal's echo made cyclic (the data's and the pilots')
        let cyclic: Vec<SymbolWindow> = pulse
            .iter()
            .zip(&references)
            .map(|(sym, r)| {
                let mut t = vec![Complex64::default(); num.fft_size];
                for (i, v) in sym.values.iter().enumerate() {
                    t[num.bin(i)] = *v;
                }
                self.proc.ifft.process(&mut t);
                self.window(t, r.clone())
            })
            .collect();
        let peak0 = self
            .proc
            .compressor
            .evaluate(&self.proc.compressor.spectrum(&cyclic), 0.0);
        // symbol s's multipliers on the pilots' REs: the compression of a unit spectrum in
        // window s alone (the data's REs multiply the pilots' leakage by a reference value
        // drawn afresh each slot: nothing that repeats)
        let filters: Vec<Vec<Complex64>> = pulse
            .iter()
            .enumerate()
            .map(|(s, sym)| {
                let unit: Vec<SymbolWindow> = cyclic
                    .iter()
                    .enumerate()
                    .map(|(t, w)| SymbolWindow {
                        spectrum: vec![
                            Complex64::new(f64::from(u8::from(t == s)), 0.0);
                            num.fft_size
                        ],
                        ..w.clone()
                    })
                    .collect();
                let mut m = self.proc.compressor.spectrum(&unit);
                for (v, r) in m.iter_mut().zip(&sym.roles) {
                    if *r != Role::Pilot {
                        *v = Complex64::default();
                    }
                }
                m
            })
            .collect();
        // the pilots' share of the cyclic echo's compressed spectrum (FFT of the unnormalised
        // inverse FFT: N times the values)
        let n = num.fft_size as f64;
        let cyclic0 = (0..num.subcarriers)
            .map(|i| {
                pulse
                    .iter()
                    .zip(&filters)
                    .map(|(sym, f)| f[i] * sym.values[i] * n)
                    .sum()
            })
            .collect();
        let w = Arc::new(PulseWaveforms {
            first,
            bounds,
            useful,
            filters,
            cyclic0,
            peak0,
        });
        if let Ok(mut c) = self.cache.lock() {
            c.insert(m0, w.clone());
        }
        Some(w)
    }
}

impl Processor {
    /// Under an NR cell, the coherent ghost (the pilots' share) of an echo `delay_samples`
    /// into the windows of the pulses whose first symbols are `first_symbols` (their mean,
    /// unweighted; the processor takes [`PATTERN_SAMPLES`] pulses per look): `g(x)` at `x`
    /// samples from the echo's delay, relative to its main peak times the overlap factor
    /// [`cp_overlap_factor`] (see the module doc). `None` without an NR cell, or where the echo
    /// lies within every window's CP.
    pub fn pilot_ghost(&self, first_symbols: &[u64], delay_samples: f64) -> Option<GhostProfile> {
        let model = GhostModel::new(self, &[], 1, 0)?;
        let ones = vec![1.0; first_symbols.len()];
        let patterns = patterns_of(self, model.ill, first_symbols.iter().copied(), &ones);
        model.mean_profile(&patterns, delay_samples)
    }
}

impl PulseWaveforms {
    /// The pilots' waveform at samples `a0 ..` of the BS's stream into `out` (zero before the
    /// first cached symbol and after the last).
    fn fill(&self, a0: i64, out: &mut [Complex64]) {
        let a1 = a0 + out.len() as i64;
        for (j, ((start, useful_start), u)) in self.bounds.iter().zip(&self.useful).enumerate() {
            let n = u.len() as i64;
            let end = self.bounds.get(j + 1).map_or(useful_start + n, |b| b.0);
            let (lo, hi) = (a0.max(*start), a1.min(end));
            for a in lo..hi {
                out[(a - a0) as usize] = u[(a - useful_start).rem_euclid(n) as usize];
            }
        }
    }
}
