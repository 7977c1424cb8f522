//! Paths that change symbol within a window, by corrections in the time domain.
//!
//! A path p that moves from symbol m + j0 to m + j1 at window sample s_p is synthesised as its
//! longer piece's symbol over the whole window (in the spectrum that one inverse FFT evaluates)
//! plus a correction over the shorter side: `± a_p φ_p(k) g(k − Δ_p)` for k in [s_p, N) or
//! [0, s_p), where `g(x) = Σ_i D_i e^{j2πk_i x/N}`, `D = Y^{(j1)} − Y^{(j0)}` and φ_p the
//! Doppler factor. Every path of one transition (j0, j1) shifts the same g: with
//! Δ_p = I_p + f_p (I_p an integer, |f_p| ≤ 1/2), the Jacobi–Anger expansion of each
//! subcarrier's fractional delay in Chebyshev polynomials of t = 2f_p ∈ [−1, 1] gives
//!
//! `g(n − f) = Σ_q T_q(2f) G_q(n)`, `G_q(n) = Σ_i D_i ε_q (−j)^q J_q(πk_i/N) e^{j2πk_i n/N}`
//!
//! (ε_0 = 1, ε_q = 2, J_q the Bessel functions), so Q inverse FFTs per transition give every
//! path's correction at Q multiply-adds per sample: exact up to the series' truncation,
//! `2 Σ_{q≥Q} |J_q(x)| ≤ 2 Σ_{q≥Q} (x/2)^q/q!` (x = πK/N, K the largest |k_i|), below 1e-16
//! of Σ_i |D_i| (Q ≈ 15 for x ≈ 0.96; a Taylor series in f needs about 19 for the same bound).
//! The method of the segment spectra (one transform per change point) costs about one N-point
//! transform per split path; this one about Q transforms per window, whatever the number of
//! paths.

use std::ops::Range;

use rustfft::num_complex::Complex64;
use rustfft::Fft;

use super::Path;
use crate::waveform::Numerology;

/// Truncation bound of the series, relative to Σ_i |D_i|.
const TAIL: f64 = 1e-16;

/// The tail bound `2 Σ_{q≥Q} (x/2)^q / q!` of the series cut after `q_terms` terms, for
/// |πk_i/N| ≤ `x_max`.
pub(super) fn series_tail(x_max: f64, q_terms: usize) -> f64 {
    let h = x_max / 2.0;
    let mut term = (1..=q_terms).fold(1.0, |t, q| t * h / q as f64); // h^Q / Q!
    let mut sum = 0.0;
    for q in q_terms + 1..q_terms + 40 {
        sum += term;
        term *= h / q as f64;
    }
    2.0 * sum
}

/// Terms of the series for |πk_i/N| ≤ `x_max`: the least Q whose [`series_tail`] is below
/// [`TAIL`] (at most 40).
pub(super) fn series_terms(x_max: f64) -> usize {
    let mut q = 1usize;
    while q < 40 && series_tail(x_max, q) >= TAIL {
        q += 1;
    }
    q
}

/// `ε_q J_q(x)` for q < `terms` (ε_0 = 1, ε_q = 2), by the power series (|x| ≤ π/2 here:
/// alternating terms of decreasing size, accurate to rounding).
pub(super) fn bessel_weights(x: f64, terms: usize) -> Vec<f64> {
    let h = x / 2.0;
    let mut lead = 1.0; // h^q / q!
    (0..terms)
        .map(|q| {
            if q > 0 {
                lead *= h / q as f64;
            }
            // J_q(x) = Σ_m (−1)^m h^{2m+q} / (m! (m+q)!)
            let (mut t, mut sum) = (lead, lead);
            for m in 1..40 {
                t *= -h * h / (m as f64 * (m + q) as f64);
                sum += t;
                if t.abs() <= 1e-19 * sum.abs() {
                    break;
                }
            }
            if q == 0 {
                sum
            } else {
                2.0 * sum
            }
        })
        .collect()
}

/// The weights `ε_q J_q(πk_i/N)` of the basis, q-major (`terms` × N_sc).
pub(super) fn basis_weights(num: &Numerology, terms: usize) -> Vec<f64> {
    let n = num.fft_size as f64;
    let per_sc: Vec<Vec<f64>> = (0..num.subcarriers)
        .map(|i| {
            bessel_weights(
                std::f64::consts::PI * num.subcarrier_index(i) as f64 / n,
                terms,
            )
        })
        .collect();
    (0..terms)
        .flat_map(|q| per_sc.iter().map(move |w| w[q]))
        .collect()
}

/// Writes the N_sc values `v` to their FFT bins of `dst` (N values, subcarrier i at bin
/// (i − N_sc/2) mod N as [`Numerology::bin`]) and zeroes the other bins.
pub(super) fn to_bins(v: &[Complex64], dst: &mut [Complex64]) {
    let n = dst.len();
    let neg = v.len() / 2; // subcarriers below the centre: bins N − N_sc/2 .. N
    let (lo, hi) = v.split_at(neg);
    dst[..hi.len()].copy_from_slice(hi);
    dst[hi.len()..n - neg].fill(Complex64::new(0.0, 0.0));
    dst[n - neg..].copy_from_slice(lo);
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

/// The basis G_q(n), q < `terms`, of the difference spectrum `d` (N_sc values), q-major;
/// `weights` from [`basis_weights`].
pub(super) fn basis(
    n: usize,
    ifft: &dyn Fft<f64>,
    d: &[Complex64],
    weights: &[f64],
    terms: usize,
) -> Vec<Complex64> {
    let nsc = d.len();
    let mut out = vec![Complex64::new(0.0, 0.0); terms * n];
    let mut weighted = vec![Complex64::new(0.0, 0.0); nsc];
    // (−j)^q
    let rot = [
        Complex64::new(1.0, 0.0),
        Complex64::new(0.0, -1.0),
        Complex64::new(-1.0, 0.0),
        Complex64::new(0.0, 1.0),
    ];
    for q in 0..terms {
        let r = rot[q % 4];
        for ((o, v), w) in weighted
            .iter_mut()
            .zip(d)
            .zip(&weights[q * nsc..(q + 1) * nsc])
        {
            *o = v * (r * *w);
        }
        let g = &mut out[q * n..(q + 1) * n];
        to_bins(&weighted, g);
        ifft.process(g);
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
    let mut acc = vec![Complex64::new(0.0, 0.0); n];
    let mut coefs = vec![Complex64::new(0.0, 0.0); terms];
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
        // coefficient of G_q: sign · a_p T_q(2f)
        let t = 2.0 * frac;
        let a = p.amp * c.sign;
        let (mut t0, mut t1) = (1.0, t);
        for (q, cq) in coefs.iter_mut().enumerate() {
            *cq = a * if q == 0 { 1.0 } else { t1 };
            if q > 0 {
                (t0, t1) = (t1, 2.0 * t * t1 - t0);
            }
        }
        // the basis samples first.., wrapping at N
        let head = (n - first).min(len);
        let (a0, a1) = acc.split_at_mut(head);
        mac_terms(a0, g, n, first, &coefs);
        mac_terms(a1, g, n, 0, &coefs);
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

/// `acc[k] += Σ_q c_q g_q[first + k]` (g: the q-major basis, N samples per term; first +
/// acc.len() ≤ N), in an AVX-512 or AVX2+FMA copy chosen at run time.
fn mac_terms(acc: &mut [Complex64], g: &[Complex64], n: usize, first: usize, coefs: &[Complex64]) {
    #[inline(always)]
    fn kernel(acc: &mut [Complex64], g: &[Complex64], n: usize, first: usize, coefs: &[Complex64]) {
        let len = acc.len();
        for (q, c) in coefs.iter().enumerate() {
            let gq = &g[q * n + first..q * n + first + len];
            for (a, v) in acc.iter_mut().zip(gq) {
                a.re += c.re * v.re - c.im * v.im;
                a.im += c.re * v.im + c.im * v.re;
            }
        }
    }
    if acc.is_empty() {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f")]
        fn k512(a: &mut [Complex64], g: &[Complex64], n: usize, f: usize, c: &[Complex64]) {
            kernel(a, g, n, f, c)
        }
        #[target_feature(enable = "avx2,fma")]
        fn k256(a: &mut [Complex64], g: &[Complex64], n: usize, f: usize, c: &[Complex64]) {
            kernel(a, g, n, f, c)
        }
        if crate::kernels::avx512() {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { k512(acc, g, n, first, coefs) };
        }
        if crate::kernels::avx2_fma() {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            return unsafe { k256(acc, g, n, first, coefs) };
        }
    }
    kernel(acc, g, n, first, coefs)
}
