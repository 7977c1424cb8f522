//! Echo synthesis: what the UAV records for each pulse.
//!
//! The BS transmits OFDM symbols back to back (CP first). The UAV's receiver keeps, for every
//! symbol it uses as (part of) a pulse, the N samples of the FFT window that its sync to the
//! direct path selects: the window of symbol m starts `D = floor(R_d f_s / c)` samples after the
//! symbol's useful part leaves the BS (the CP is discarded, as in every OFDM receiver).
//!
//! A path of range R (direct: |BS→UAV|; echo: |BS→obj| + |obj→UAV|) reaches window sample n
//! with the transmitted signal at `x = n − Δ`, `Δ = R f_s / c − D` samples (real-valued). The
//! continuous-time OFDM signal is the rectangular-windowed sum of subcarriers of 3GPP 38.211, so
//! the delayed signal is, exactly, `u_m(x)` while x lies in symbol m's interval [−N_cp, N) and the
//! neighbouring symbol's otherwise:
//! - paths with Δ ∈ (−1, N_cp] stay inside symbol m over the whole window: their delays are
//!   applied exactly in the frequency domain (`X_k e^{−j2πkΔ/N}` per subcarrier), all such paths
//!   summed before one inverse FFT;
//! - other paths (beyond the CP, or early) are split into per-symbol pieces, each computed
//!   exactly by its own inverse FFT.
//!
//! Amplitudes follow the bistatic radar equation (echo) and the Friis equation (direct path),
//! with the receive antenna gain towards the path's arrival direction and the carrier phase
//! `e^{−j2πR/λ}`. Thermal noise is complex white Gaussian with variance `k T0 F f_s` per sample.
//!
//! Motion: [`MotionModel::StopAndHop`] freezes the geometry at the pulse centre;
//! [`MotionModel::IntraPulse`] evaluates it at each symbol's window centre and applies each path's
//! Doppler shift `f_D = v·û / λ` within the window (exactly for split paths, by a Taylor series
//! whose truncation error is below 1e-10 of the path amplitude for in-CP paths).

use std::collections::HashMap;
use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use rustfft::num_complex::{Complex32, Complex64};
use rustfft::Fft;

use crate::antenna::Antenna;
use crate::config::{MotionModel, RadarConfig};
use crate::dsp::{direct_sums, phase_ramp};
use crate::error::{RadarError, Result};
use crate::scene::SceneObject;
use crate::track::{dist3, PulseMeta};
use crate::waveform::{Numerology, C_MPS};

#[cfg(target_arch = "x86_64")]
mod avx512;
mod path_sums;
mod split;
mod timing;

pub(crate) use path_sums::path_sums;

/// Which parts of the received signal to synthesise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Components {
    /// The direct path BS → UAV.
    pub direct: bool,
    /// The object echoes.
    pub echoes: bool,
    /// Thermal noise.
    pub noise: bool,
}

impl Components {
    /// Everything.
    pub const ALL: Components = Components {
        direct: true,
        echoes: true,
        noise: true,
    };
}

/// One propagation path within one symbol window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Path {
    /// Complex amplitude at the receiver (√W, carrier phase included).
    pub amp: Complex64,
    /// Delay Δ relative to the window start, samples.
    pub delay_samples: f64,
    /// Doppler shift within the window, Hz (0 under stop-and-hop).
    pub doppler_hz: f64,
}

/// How [`Synthesizer::synthesize_window`] treats paths that change symbol within the window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(not(test), allow(dead_code))]
enum SplitMethod {
    /// Corrections when more paths change symbol than the series has terms, else segments.
    Auto,
    /// One spectrum per segment between change points.
    Segments,
    /// Corrections from a shared basis ([`split`]).
    Corrections,
}

/// The path sums ([`path_sums`]) of a window's groups of paths, kept for the next window while
/// its paths are the same (the windows of one pulse under stop-and-hop share every path, so
/// their sums are computed once per pulse).
#[derive(Debug, Default)]
struct SumCache {
    /// The paths the sums belong to.
    paths: Vec<Path>,
    /// (the group's path indices, Taylor terms, its sums).
    sums: Vec<(Vec<usize>, usize, Vec<Complex64>)>,
}

impl SumCache {
    /// The path sums of `paths[group]` with `terms` terms, computed unless kept.
    fn get(
        &mut self,
        paths: &[Path],
        group: &[usize],
        terms: usize,
        k0: f64,
        n: usize,
        nsc: usize,
    ) -> &[Complex64] {
        if self.paths != paths {
            self.paths = paths.to_vec();
            self.sums.clear();
        }
        let pos = match self
            .sums
            .iter()
            .position(|(g, t, _)| g == group && *t == terms)
        {
            Some(pos) => pos,
            None => {
                let refs: Vec<&Path> = group.iter().map(|&i| &paths[i]).collect();
                let acc = path_sums(&refs, terms, k0, n, nsc);
                self.sums.push((group.to_vec(), terms, acc));
                self.sums.len() - 1
            }
        };
        &self.sums[pos].2
    }
}

/// The echo synthesiser for one scene and radar.
pub struct Synthesizer {
    num: Numerology,
    motion: MotionModel,
    antenna: Antenna,
    bs_sector: Option<crate::antenna::SectorAntenna>,
    bs_m: [f64; 3],
    objects: Vec<SceneObject>,
    eirp_w: f64,
    noise_w: f64,
    thermal_noise: bool,
    direct_path: bool,
    seed: u64,
    symbols_per_pulse: usize,
    ifft: Arc<dyn Fft<f64>>,
    /// Terms of the split-path series ([`split`]) and its weights ε_q J_q(πk_i/N), q-major.
    split_terms: usize,
    split_weights: Vec<f64>,
}

impl std::fmt::Debug for Synthesizer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Synthesizer")
            .field("num", &self.num)
            .field("objects", &self.objects.len())
            .finish_non_exhaustive()
    }
}

/// Phase factor e^{−j2π·frac(x)} of a cycle count x (f64, reduced first for accuracy).
fn cis_cycles(x: f64) -> Complex64 {
    let f = x - x.floor();
    Complex64::from_polar(1.0, -std::f64::consts::TAU * f)
}

impl Synthesizer {
    /// A synthesiser for `objects` seen by `radar` with numerology `num`, BS at `bs_m` (x, y, H_b),
    /// receive antenna `antenna`.
    pub fn new(
        num: Numerology,
        radar: &RadarConfig,
        antenna: Antenna,
        bs_m: [f64; 3],
        objects: Vec<SceneObject>,
    ) -> Result<Self> {
        radar.validate()?;
        if num.fft_size != radar.fft_size || num.cp_samples != radar.cp_samples {
            return Err(RadarError::config(
                "radar.fft_size",
                "numerology and radar config disagree",
            ));
        }
        let ifft = crate::kernels::FftMaker::new().inverse(num.fft_size);
        let split_terms = split::series_terms(
            std::f64::consts::PI * split::max_index(&num) / num.fft_size as f64,
        );
        let split_weights = split::basis_weights(&num, split_terms);
        Ok(Self {
            split_terms,
            split_weights,
            motion: radar.motion,
            antenna,
            bs_sector: radar.bs_antenna.as_ref().map(|a| a.sector(bs_m)),
            bs_m,
            objects,
            eirp_w: radar.tx_power_w
                * 10f64.powf((radar.tx_gain_dbi - radar.system_loss_db) / 10.0),
            noise_w: radar.noise_power_w(),
            thermal_noise: radar.thermal_noise,
            direct_path: radar.direct_path,
            seed: radar.seed,
            symbols_per_pulse: radar.symbols_per_pulse,
            ifft,
            num,
        })
    }

    /// The numerology.
    pub fn numerology(&self) -> &Numerology {
        &self.num
    }

    /// The scene objects.
    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    /// Noise variance per complex sample, W.
    pub fn noise_power_w(&self) -> f64 {
        self.noise_w
    }

    /// Complex samples per pulse (symbols per pulse × N).
    pub fn samples_per_pulse(&self) -> usize {
        self.symbols_per_pulse * self.num.fft_size
    }

    /// Received direct-path power for a UAV at `pos` with `heading`, W (the BS's sector pattern
    /// towards the UAV included, under `[radar.bs_antenna]`).
    pub fn direct_power_w(&self, pos: [f64; 3], heading: [f64; 2]) -> f64 {
        let r = dist3(pos, self.bs_m);
        let lam = self.num.wavelength_m();
        let g = self.antenna.gain_towards(pos, heading, self.bs_m);
        let p = self.eirp_w * g * lam * lam / (4.0 * std::f64::consts::PI * r).powi(2);
        match &self.bs_sector {
            None => p,
            Some(s) => p * s.gain_towards(self.bs_m, pos),
        }
    }

    /// Received echo power of `obj` for a UAV at `pos` with `heading`, W (the BS's sector
    /// pattern towards the object included, under `[radar.bs_antenna]`).
    pub fn echo_power_w(&self, obj: &SceneObject, pos: [f64; 3], heading: [f64; 2]) -> f64 {
        let p = [obj.x_m, obj.y_m, 0.0];
        let rt = dist3(self.bs_m, p);
        let rr = dist3(p, pos);
        let lam = self.num.wavelength_m();
        let g = self.antenna.gain_towards(pos, heading, p);
        let four_pi3 = (4.0 * std::f64::consts::PI).powi(3);
        let pw = self.eirp_w * g * obj.rcs_m2 * lam * lam / (four_pi3 * rt * rt * rr * rr);
        match &self.bs_sector {
            None => pw,
            Some(s) => pw * s.gain_towards(self.bs_m, p),
        }
    }

    /// The paths of one symbol window for a UAV at `pos` moving with `vel`, window delay `d`.
    pub fn paths(
        &self,
        pos: [f64; 3],
        vel: [f64; 3],
        heading: [f64; 2],
        window_delay_samples: i64,
        comps: Components,
    ) -> Vec<Path> {
        let fs = self.num.sample_rate_hz();
        let lam = self.num.wavelength_m();
        let intra = self.motion == MotionModel::IntraPulse;
        let doppler = |p: [f64; 3]| -> f64 {
            if !intra {
                return 0.0;
            }
            let d = [p[0] - pos[0], p[1] - pos[1], p[2] - pos[2]];
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            (vel[0] * d[0] + vel[1] * d[1] + vel[2] * d[2]) / (n * lam)
        };
        let d0 = window_delay_samples as f64;
        let mut out = Vec::with_capacity(self.objects.len() + 1);
        if comps.direct && self.direct_path {
            let r = dist3(pos, self.bs_m);
            let p = self.direct_power_w(pos, heading);
            out.push(Path {
                amp: cis_cycles(r / lam) * p.sqrt(),
                delay_samples: r * fs / C_MPS - d0,
                doppler_hz: doppler(self.bs_m),
            });
        }
        if comps.echoes {
            for o in &self.objects {
                let q = [o.x_m, o.y_m, 0.0];
                let r = dist3(self.bs_m, q) + dist3(q, pos);
                let p = self.echo_power_w(o, pos, heading);
                out.push(Path {
                    amp: cis_cycles(r / lam) * Complex64::from_polar(p.sqrt(), o.phase_rad),
                    delay_samples: r * fs / C_MPS - d0,
                    doppler_hz: doppler(q),
                });
            }
        }
        out
    }

    /// Synthesises the window of symbol `m` (N samples) from `paths` into `out` (added).
    /// `data(m)` returns the QAM data of symbol m (None before the BS starts transmitting).
    ///
    /// Exact for every delay: window sample k of a path with delay Δ carries symbol
    /// m + j(k), j(k) = ⌊(k − Δ + N_cp)/N_s⌋, whose useful part is
    /// `u(x) = Σ_i Y^{(j)}_i e^{j2πk_i x/N}` at x = k − Δ (Y^{(j)} the data with the phase of
    /// the j CPs in between). A path changes symbol at most once in a window, so the window
    /// splits into segments between the paths' change points; within a segment the received
    /// signal is the inverse DFT of one spectrum `Z_i = Σ_p a_p Y^{(j_p)}_i e^{−j2πk_iΔ_p/N}`.
    /// Z starts from all paths' first pieces (summed by phasor recurrence, paths in SIMD lanes),
    /// is updated path by path at each change point, and each segment is evaluated by an inverse
    /// FFT (long segments) or by direct sums over the subcarriers (short ones). Paths inside
    /// the CP never change symbol: then this is one IFFT of one spectrum. Doppler within the
    /// window enters by a Taylor series in (k − N/2)/f_s (truncation < 1e-12 of the amplitude).
    ///
    /// Many split paths (more than the terms of the `split` module's series) are instead each taken as
    /// their longer piece's symbol in the one spectrum, plus a correction over the shorter side
    /// from a basis shared by all paths of the same pair of symbols (the `split` module): about Q
    /// transforms per window instead of one per split path.
    pub fn synthesize_window(
        &self,
        m: i64,
        paths: &[Path],
        data: &mut dyn FnMut(i64) -> Option<Arc<Vec<Complex32>>>,
        out: &mut [Complex64],
    ) {
        let mut sums = SumCache::default();
        self.synthesize_window_by(m, paths, data, out, SplitMethod::Auto, &mut sums);
    }

    /// [`Self::synthesize_window`] with the method for split paths chosen by `method`.
    fn synthesize_window_by(
        &self,
        m: i64,
        paths: &[Path],
        data: &mut dyn FnMut(i64) -> Option<Arc<Vec<Complex32>>>,
        out: &mut [Complex64],
        method: SplitMethod,
        sums: &mut SumCache,
    ) {
        if paths.is_empty() {
            return;
        }
        let num = &self.num;
        let n = num.fft_size;
        let nsc = num.subcarriers;
        let fs = num.sample_rate_hz();
        let centre = n as f64 / 2.0;
        let k0 = num.subcarrier_index(0);
        // Taylor terms of the Doppler factor
        let xmax = paths
            .iter()
            .map(|p| std::f64::consts::TAU * p.doppler_hz.abs() * centre / fs)
            .fold(0.0, f64::max);
        let mut terms = 1usize;
        let mut bound = 1.0;
        while terms < 16 {
            bound *= xmax / terms as f64;
            if bound < 1e-12 {
                break;
            }
            terms += 1;
        }
        let timing = timing::WindowTiming::new(num.nr.as_deref(), m, n, num.cp_samples);
        // Y^{(j)}_i = X^{m+j}_i e^{−j2π k_i o_j / N} / √N_sc (zero before the first symbol), o_j
        // the offset of symbol m + j's useful part from symbol m's (j (N + N_cp) without NR)
        let scale = 1.0 / (nsc as f64).sqrt();
        let mut ys: Vec<(i64, Vec<Complex64>)> = Vec::new();
        let mut y_of = |j: i64, ys: &mut Vec<(i64, Vec<Complex64>)>| -> usize {
            if let Some(pos) = ys.iter().position(|(jj, _)| *jj == j) {
                return pos;
            }
            let v = match data(m + j) {
                Some(x) => {
                    let mut w = vec![Complex64::new(scale, 0.0); nsc];
                    if j != 0 {
                        let cp = timing.phase_offset(j, n, num.cp_samples);
                        phase_ramp(cp as f64, k0 as f64, n, &mut w);
                        w.iter_mut().for_each(|v| *v *= scale);
                    }
                    x.iter()
                        .zip(w)
                        .map(|(xv, w)| Complex64::new(xv.re as f64, xv.im as f64) * w)
                        .collect()
                }
                None => vec![Complex64::new(0.0, 0.0); nsc],
            };
            ys.push((j, v));
            ys.len() - 1
        };
        // each path's first piece and its change point (if any)
        let j_of = |k: f64, d: f64| timing.j_of(k - d);
        let mut groups: Vec<(i64, Vec<usize>)> = Vec::new(); // (base symbol, path indices)
        let mut events: Vec<(usize, &Path, i64, i64)> = Vec::new(); // (first sample, path, j0, j1)
        let pieces: Vec<(i64, i64, usize)> = paths
            .iter()
            .map(|p| {
                let d = p.delay_samples;
                let (j0, j1) = (j_of(0.0, d), j_of((n - 1) as f64, d));
                let s = if j1 == j0 {
                    n
                } else {
                    timing.change_at(d, j1).ceil().clamp(0.0, n as f64) as usize
                };
                (j0, j1, s)
            })
            .collect();
        let split_terms = self.split_terms;
        let corrected = match method {
            SplitMethod::Auto => pieces.iter().filter(|(j0, j1, _)| j0 != j1).count() > split_terms,
            SplitMethod::Segments => false,
            SplitMethod::Corrections => true,
        };
        // (j0, j1) → the corrections of the paths of that transition
        let mut corrections: Vec<((i64, i64), Vec<split::Correction<'_>>)> = Vec::new();
        for (pi, (p, &(j0, j1, s))) in paths.iter().zip(&pieces).enumerate() {
            let (base, corr) = if j1 == j0 {
                (j0, None)
            } else if !corrected {
                events.push((s, p, j0, j1));
                (j0, None)
            } else if 2 * s >= n {
                (j0, Some((1.0, s..n)))
            } else {
                (j1, Some((-1.0, 0..s)))
            };
            match groups.iter_mut().find(|(j, _)| *j == base) {
                Some((_, g)) => g.push(pi),
                None => groups.push((base, vec![pi])),
            }
            if let Some((sign, range)) = corr {
                let c = split::Correction {
                    path: p,
                    sign,
                    range,
                };
                match corrections.iter_mut().find(|(key, _)| *key == (j0, j1)) {
                    Some((_, v)) => v.push(c),
                    None => corrections.push(((j0, j1), vec![c])),
                }
            }
        }
        events.sort_by_key(|e| e.0);
        for ((j0, j1), cs) in &corrections {
            let (a, b) = (y_of(*j1, &mut ys), y_of(*j0, &mut ys));
            let d: Vec<Complex64> = ys[a]
                .1
                .iter()
                .zip(&ys[b].1)
                .map(|(y1, y0)| y1 - y0)
                .collect();
            let g = split::basis(n, self.ifft.as_ref(), &d, &self.split_weights, split_terms);
            split::apply(num, &g, split_terms, cs, out);
        }
        // initial spectra Z_q
        let mut z = vec![Complex64::new(0.0, 0.0); nsc * terms];
        for (j, g) in &groups {
            let yi = y_of(*j, &mut ys);
            let y = &ys[yi].1;
            let acc = sums.get(paths, g, terms, k0 as f64, n, nsc);
            for q in 0..terms {
                for ((zv, a), yv) in z[q * nsc..(q + 1) * nsc]
                    .iter_mut()
                    .zip(&acc[q * nsc..(q + 1) * nsc])
                    .zip(y)
                {
                    *zv += a * yv;
                }
            }
        }
        let mut spec = vec![Complex64::new(0.0, 0.0); n];
        let mut ramp_buf = vec![Complex64::new(0.0, 0.0); nsc];
        let mut lo = 0usize;
        let mut ev = events.iter().peekable();
        loop {
            let hi = ev.peek().map_or(n, |e| e.0);
            if hi > lo {
                self.eval_segment(&z, terms, lo..hi, &mut spec, out);
                lo = hi;
            }
            let Some(&(_, p, j0, j1)) = ev.next() else {
                break;
            };
            // path p moves from symbol m + j0 to m + j1: Z_q += c_q (Y^{(j1)} − Y^{(j0)}) E_p
            let (a, b) = (y_of(j1, &mut ys), y_of(j0, &mut ys));
            phase_ramp(p.delay_samples, k0 as f64, n, &mut ramp_buf);
            let mut c = p.amp;
            for q in 0..terms {
                for (((zv, e), y1), y0) in z[q * nsc..(q + 1) * nsc]
                    .iter_mut()
                    .zip(&ramp_buf)
                    .zip(&ys[a].1)
                    .zip(&ys[b].1)
                {
                    *zv += c * (y1 - y0) * e;
                }
                c *= p.doppler_hz / (q + 1) as f64;
            }
        }
    }

    /// Adds `Σ_q (j2π(k − N/2)/f_s)^q Σ_i Z_q(i) e^{j2πk_i k/N}` for k in `ks` to `out`.
    fn eval_segment(
        &self,
        z: &[Complex64],
        terms: usize,
        ks: std::ops::Range<usize>,
        spec: &mut [Complex64],
        out: &mut [Complex64],
    ) {
        let num = &self.num;
        let n = num.fft_size;
        let nsc = num.subcarriers;
        let fs = num.sample_rate_hz();
        let centre = n as f64 / 2.0;
        let len = ks.end - ks.start;
        // direct sums cost len·N_sc per term, an inverse FFT about 2 N log2 N
        let direct = len * nsc < 2 * n * (usize::BITS - n.leading_zeros()) as usize;
        for q in 0..terms {
            let zq = &z[q * nsc..(q + 1) * nsc];
            let vals: Vec<Complex64> = if direct {
                direct_sums(zq, num.subcarrier_index(0), n, ks.clone())
            } else {
                split::to_bins(zq, spec);
                self.ifft.process(spec);
                spec[ks.clone()].to_vec()
            };
            for (k, v) in ks.clone().zip(vals) {
                let f = if q == 0 {
                    Complex64::new(1.0, 0.0)
                } else {
                    Complex64::new(0.0, std::f64::consts::TAU * (k as f64 - centre) / fs)
                        .powu(q as u32)
                };
                out[k] += v * f;
            }
        }
    }

    /// Synthesises one pulse (symbols_per_pulse × N samples, symbol-major) into `out`.
    pub fn synthesize_pulse(
        &self,
        pulse: &PulseMeta,
        comps: Components,
        out: &mut [Complex32],
    ) -> Result<()> {
        let n = self.num.fft_size;
        let s_count = self.symbols_per_pulse;
        if out.len() != s_count * n {
            return Err(RadarError::Shape {
                what: format!("pulse {} buffer", pulse.index),
                expected: format!("{} samples", s_count * n),
                found: format!("{}", out.len()),
            });
        }
        let fs = self.num.sample_rate_hz();
        let mut cache: HashMap<i64, Arc<Vec<Complex32>>> = HashMap::new();
        let num = &self.num;
        if let Some(ill) = num.nr.as_deref() {
            // the pulse's symbols and the one before (which beyond-CP echoes reach), each slot's
            // reference signals generated once
            let first = (pulse.symbol as i64 - 1).max(0);
            let last = pulse.symbol as i64 + s_count as i64;
            for (m, sym) in
                (first..last).zip(ill.grid.symbols(first as u64, (last - first) as usize))
            {
                let v = sym
                    .values
                    .iter()
                    .map(|v| Complex32::new(v.re as f32, v.im as f32))
                    .collect();
                cache.insert(m, Arc::new(v));
            }
        }
        let mut data = |m: i64| -> Option<Arc<Vec<Complex32>>> {
            if m < 0 {
                return None;
            }
            Some(
                cache
                    .entry(m)
                    .or_insert_with(|| Arc::new(num.symbol_data(m as u64)))
                    .clone(),
            )
        };
        let mut buf = vec![Complex64::new(0.0, 0.0); n];
        let mut sums = SumCache::default();
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x5EED_0000_0000_0001);
        rng.set_stream(pulse.index as u64);
        let sigma = (self.noise_w / 2.0).sqrt();
        for s in 0..s_count {
            let m = pulse.symbol as i64 + s as i64;
            let (pos, vel) = match self.motion {
                MotionModel::StopAndHop => (pulse.pos_m, pulse.vel_mps),
                MotionModel::IntraPulse => {
                    // window centre of symbol m in BS time, relative to the pulse's reference time
                    let t = (self.num.useful_start_sample(m as u64)
                        + pulse.window_delay_samples as f64
                        + n as f64 / 2.0)
                        / fs;
                    let dt = t - pulse.t_s;
                    let v = pulse.vel_mps;
                    (
                        [
                            pulse.pos_m[0] + v[0] * dt,
                            pulse.pos_m[1] + v[1] * dt,
                            pulse.pos_m[2] + v[2] * dt,
                        ],
                        v,
                    )
                }
            };
            let paths = self.paths(pos, vel, pulse.heading, pulse.window_delay_samples, comps);
            buf.fill(Complex64::new(0.0, 0.0));
            self.synthesize_window_by(m, &paths, &mut data, &mut buf, SplitMethod::Auto, &mut sums);
            let dst = &mut out[s * n..(s + 1) * n];
            if comps.noise && self.thermal_noise {
                for (o, v) in dst.iter_mut().zip(&buf) {
                    let a: f64 = StandardNormal.sample(&mut rng);
                    let b: f64 = StandardNormal.sample(&mut rng);
                    *o = Complex32::new((v.re + sigma * a) as f32, (v.im + sigma * b) as f32);
                }
            } else {
                for (o, v) in dst.iter_mut().zip(&buf) {
                    *o = Complex32::new(v.re as f32, v.im as f32);
                }
            }
        }
        Ok(())
    }

    /// Synthesises a frame of pulses (pulses × samples, row-major), in parallel over pulses.
    pub fn synthesize_frame(
        &self,
        pulses: &[PulseMeta],
        comps: Components,
    ) -> Result<Vec<Complex32>> {
        let spp = self.samples_per_pulse();
        let mut out = vec![Complex32::new(0.0, 0.0); pulses.len() * spp];
        out.par_chunks_mut(spp)
            .zip(pulses.par_iter())
            .try_for_each(|(dst, p)| self.synthesize_pulse(p, comps, dst))?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
