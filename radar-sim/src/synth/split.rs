//! Paths that change symbol within a window, by corrections in the time domain.
//!
//! A path p that moves from symbol m + j0 to m + j1 at window sample s_p is synthesised as its
//! longer piece's symbol over the whole window (in the spectrum that one inverse FFT evaluates)
//! plus a correction over the shorter side: `± a_p φ_p(k) g(k − Δ_p)` for k in [s_p, N) or
//! [0, s_p), where `g(x) = Σ_i D_i e^{j2πk_i x/N}`, `D = Y^{(j1)} − Y^{(j0)}` and φ_p the
//! Doppler factor. Every path of one transition (j0, j1) shifts the same g: with
//! Δ_p = I_p + f_p (I_p an integer, |f_p| ≤ 1/2),
//!
//! `g(n − f) = Σ_q (−j2πfK/N)^q / q! · G_q(n)`, `G_q(n) = Σ_i D_i (k_i/K)^q e^{j2πk_i n/N}`
//!
//! (K the largest |k_i|), so Q inverse FFTs per transition give every path's correction at Q
//! multiply-adds per sample: exact up to the series' truncation, below 1e-16 of Σ_i |D_i|
//! (Q ≈ 16–20). The method of the segment spectra (one transform per change point) costs about
//! one N-point transform per split path; this one about Q transforms per window, whatever the
//! number of paths.

use std::ops::Range;

use rustfft::num_complex::Complex64;
use rustfft::Fft;

use super::Path;
use crate::waveform::Numerology;

/// Truncation bound of the series in the fraction of the delay, relative to Σ_i |D_i|.
const TAIL: f64 = 1e-16;

/// Terms of the series for |2πfK/N| ≤ `x_max`: the least Q with x_max^Q / Q! · e^{x_max} below
/// [`TAIL`] (at most 40).
pub(super) fn series_terms(x_max: f64) -> usize {
    let mut q = 1usize;
    let mut term = x_max; // x^q / q!
    while q < 40 && term * x_max.exp() >= TAIL {
        q += 1;
        term *= x_max / q as f64;
    }
    q
}

/// The largest |k_i| of the occupied subcarriers, K.
pub(super) fn max_index(num: &Numerology) -> f64 {
    let lo = num.subcarrier_index(0);
    let hi = num.subcarrier_index(num.subcarriers - 1);
    lo.unsigned_abs().max(hi.unsigned_abs()).max(1) as f64
}

/// One path's correction: sign ±1, the samples it covers.
pub(super) struct Correction<'a> {
    /// The path.
    pub path: &'a Path,
    /// +1: the path's later symbol over `range` (its earlier one is in the spectrum); −1: the
    /// reverse.
    pub sign: f64,
    /// Window samples corrected.
    pub range: Range<usize>,
}

/// The basis G_q(n), q < `terms`, of the difference spectrum `d` (N_sc values), q-major.
pub(super) fn basis(
    num: &Numerology,
    ifft: &dyn Fft<f64>,
    d: &[Complex64],
    terms: usize,
) -> Vec<Complex64> {
    let n = num.fft_size;
    let kmax = max_index(num);
    let mut out = vec![Complex64::new(0.0, 0.0); terms * n];
    let mut weighted: Vec<Complex64> = d.to_vec();
    let ratio: Vec<f64> = (0..d.len())
        .map(|i| num.subcarrier_index(i) as f64 / kmax)
        .collect();
    for q in 0..terms {
        let g = &mut out[q * n..(q + 1) * n];
        for (i, v) in weighted.iter().enumerate() {
            g[num.bin(i)] = *v;
        }
        ifft.process(g);
        for (v, r) in weighted.iter_mut().zip(&ratio) {
            *v *= *r;
        }
    }
    out
}

/// Adds each correction to `out` from the basis `g` (of [`basis`], `terms` terms).
pub(super) fn apply(
    num: &Numerology,
    g: &[Complex64],
    terms: usize,
    corrections: &[Correction<'_>],
    out: &mut [Complex64],
) {
    let n = num.fft_size;
    let fs = num.sample_rate_hz();
    let w = std::f64::consts::TAU * max_index(num) / n as f64;
    let mut acc = vec![Complex64::new(0.0, 0.0); n];
    for c in corrections {
        let p = c.path;
        let len = c.range.end - c.range.start;
        if len == 0 {
            continue;
        }
        let whole = p.delay_samples.round();
        let frac = p.delay_samples - whole;
        // the first basis sample: (range.start − I_p) mod N
        let first = (c.range.start as i64 - whole as i64).rem_euclid(n as i64) as usize;
        let acc = &mut acc[..len];
        acc.fill(Complex64::new(0.0, 0.0));
        // coefficient of G_q: sign · a_p (−j2πfK/N)^q / q!
        let mut coef = p.amp * c.sign;
        let step = Complex64::new(0.0, -w * frac);
        for q in 0..terms {
            let gq = &g[q * n..(q + 1) * n];
            // the basis samples first.., wrapping at N
            let head = (n - first).min(len);
            let (a0, a1) = acc.split_at_mut(head);
            for (a, v) in a0.iter_mut().zip(&gq[first..first + head]) {
                *a += coef * v;
            }
            for (a, v) in a1.iter_mut().zip(gq) {
                *a += coef * v;
            }
            coef = coef * step / (q + 1) as f64;
        }
        let dst = &mut out[c.range.clone()];
        if p.doppler_hz == 0.0 {
            for (o, a) in dst.iter_mut().zip(acc.iter()) {
                *o += a;
            }
        } else {
            // e^{j2πf_D(k − N/2)/f_s}, by blocks of 64 from exact phasors
            let k0 = c.range.start as f64 - n as f64 / 2.0;
            let cyc = |k: f64| {
                let x = p.doppler_hz * k / fs;
                Complex64::from_polar(1.0, std::f64::consts::TAU * (x - x.floor()))
            };
            let inner: Vec<Complex64> = (0..64).map(|r| cyc(r as f64)).collect();
            for (b, (ob, ab)) in dst.chunks_mut(64).zip(acc.chunks(64)).enumerate() {
                let outer = cyc(k0 + (b * 64) as f64);
                for ((o, a), i) in ob.iter_mut().zip(ab).zip(&inner) {
                    *o += a * outer * i;
                }
            }
        }
    }
}
