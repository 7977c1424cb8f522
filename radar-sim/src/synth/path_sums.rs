//! The path sums kernel: the spectrum of a set of delayed (and Doppler-shifted) paths on the
//! occupied subcarriers, summed in SIMD lanes, with AVX-512 and AVX2+FMA copies chosen at run
//! time.

use rustfft::num_complex::Complex64;

use super::Path;

/// Lanes of the SIMD kernels (f64: one AVX-512 register, two AVX2 registers).
pub(super) const LANES: usize = 8;

/// The path sums `acc[q·N_sc + i] = Σ_j c_{q,j} e^{−j2π k_i Δ_j/N}` over occupied subcarriers
/// i (k_i = k0 + i) and Taylor terms q (c_{q,j} = a_j f_{D,j}^q / q!), in f64: eight consecutive
/// subcarriers in SIMD lanes, each path's phasors for them advanced by e^{−j2π 8Δ_j/N} per
/// block. A copy for AVX-512 and one for AVX2+FMA are chosen at run time.
pub(crate) fn path_sums(
    paths: &[&Path],
    terms: usize,
    k0: f64,
    n: usize,
    nsc: usize,
) -> Vec<Complex64> {
    let np = paths.len();
    let mut ph_re = vec![[0.0; LANES]; np];
    let mut ph_im = vec![[0.0; LANES]; np];
    let mut st = vec![Complex64::new(0.0, 0.0); np];
    let mut co = vec![Complex64::new(0.0, 0.0); np * terms];
    for (j, p) in paths.iter().enumerate() {
        let step = Complex64::from_polar(1.0, -std::f64::consts::TAU * p.delay_samples / n as f64);
        let mut e = Complex64::from_polar(
            1.0,
            -std::f64::consts::TAU * ((k0 * p.delay_samples / n as f64).fract()),
        );
        for l in 0..LANES {
            ph_re[j][l] = e.re;
            ph_im[j][l] = e.im;
            e *= step;
        }
        st[j] = Complex64::from_polar(
            1.0,
            -std::f64::consts::TAU * ((LANES as f64 * p.delay_samples / n as f64).fract()),
        );
        let mut c = p.amp;
        for q in 0..terms {
            co[j * terms + q] = c;
            c *= p.doppler_hz / (q + 1) as f64;
        }
    }
    let mut acc = vec![Complex64::new(0.0, 0.0); nsc * terms];
    let mut k = SumKernel {
        ph_re: &mut ph_re,
        ph_im: &mut ph_im,
        st: &st,
        co: &co,
        terms,
        nsc,
        acc: &mut acc,
    };
    #[cfg(target_arch = "x86_64")]
    {
        if crate::kernels::avx512() {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            unsafe { super::avx512::path_sums(&mut k) };
            return acc;
        }
        if crate::kernels::avx2_fma() {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            unsafe { path_sums_avx2(&mut k) };
            return acc;
        }
    }
    path_sums_kernel(&mut k);
    acc
}

/// Buffers of [`path_sums_kernel`].
pub(super) struct SumKernel<'a> {
    /// Per path: phasors of the current block's eight subcarriers.
    pub(super) ph_re: &'a mut [[f64; LANES]],
    pub(super) ph_im: &'a mut [[f64; LANES]],
    /// Per path: advance by eight subcarriers.
    pub(super) st: &'a [Complex64],
    /// Per path and term: coefficient c_{q,j} (path-major).
    pub(super) co: &'a [Complex64],
    pub(super) terms: usize,
    pub(super) nsc: usize,
    pub(super) acc: &'a mut [Complex64],
}

#[inline(always)]
pub(super) fn path_sums_kernel(k: &mut SumKernel<'_>) {
    const MAX_TERMS: usize = 16;
    let terms = k.terms.min(MAX_TERMS);
    for i0 in (0..k.nsc).step_by(LANES) {
        let mut sr = [[0.0f64; LANES]; MAX_TERMS];
        let mut si = [[0.0f64; LANES]; MAX_TERMS];
        for (((pr, pi), st), co) in k
            .ph_re
            .iter_mut()
            .zip(k.ph_im.iter_mut())
            .zip(k.st)
            .zip(k.co.chunks_exact(k.terms))
        {
            for (q, c) in co.iter().enumerate().take(terms) {
                for l in 0..LANES {
                    sr[q][l] += c.re * pr[l] - c.im * pi[l];
                    si[q][l] += c.re * pi[l] + c.im * pr[l];
                }
            }
            for l in 0..LANES {
                let r = pr[l] * st.re - pi[l] * st.im;
                pi[l] = pr[l] * st.im + pi[l] * st.re;
                pr[l] = r;
            }
        }
        let len = LANES.min(k.nsc - i0);
        for q in 0..terms {
            for l in 0..len {
                k.acc[q * k.nsc + i0 + l] = Complex64::new(sr[q][l], si[q][l]);
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) fn path_sums_avx2(k: &mut SumKernel<'_>) {
    path_sums_kernel(k)
}
