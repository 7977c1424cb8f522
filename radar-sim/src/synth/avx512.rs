//! AVX-512 copy of the path-sum kernel (eight f64 subcarriers per register).

use std::arch::x86_64::*;

use super::path_sums::{SumKernel, LANES};

/// [`super::path_sums::path_sums_kernel`] with explicit AVX-512F intrinsics: per block of eight
/// subcarriers, two interleaved accumulator pairs per term (short dependency chains), each
/// path's phasors loaded, used and advanced in registers.
///
/// # Safety
/// The CPU must support AVX-512F.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn path_sums(k: &mut SumKernel<'_>) {
    const MAX_TERMS: usize = 16;
    let terms = k.terms.min(MAX_TERMS);
    let np = k.ph_re.len();
    let zero = _mm512_setzero_pd();
    let mut tr = [0.0f64; LANES];
    let mut ti = [0.0f64; LANES];
    if terms == 1 {
        // SAFETY: forwarded from the caller.
        unsafe { path_sums_one(k) };
        return;
    }
    for i0 in (0..k.nsc).step_by(LANES) {
        // accumulators: [term][pair] (two pairs: even and odd paths)
        let mut ar = [[zero; 2]; MAX_TERMS];
        let mut ai = [[zero; 2]; MAX_TERMS];
        for j in 0..np {
            let h = j & 1;
            // SAFETY: ph_re[j], ph_im[j] are [f64; LANES] = 8 f64 = one register each.
            let (pr, pi) = unsafe {
                (
                    _mm512_loadu_pd(k.ph_re[j].as_ptr()),
                    _mm512_loadu_pd(k.ph_im[j].as_ptr()),
                )
            };
            for q in 0..terms {
                let c = k.co[j * k.terms + q];
                let (cr, ci) = (_mm512_set1_pd(c.re), _mm512_set1_pd(c.im));
                ar[q][h] = _mm512_fnmadd_pd(ci, pi, _mm512_fmadd_pd(cr, pr, ar[q][h]));
                ai[q][h] = _mm512_fmadd_pd(ci, pr, _mm512_fmadd_pd(cr, pi, ai[q][h]));
            }
            let (sr, si) = (_mm512_set1_pd(k.st[j].re), _mm512_set1_pd(k.st[j].im));
            let nr = _mm512_fmsub_pd(pr, sr, _mm512_mul_pd(pi, si));
            let ni = _mm512_fmadd_pd(pr, si, _mm512_mul_pd(pi, sr));
            // SAFETY: as for the loads.
            unsafe {
                _mm512_storeu_pd(k.ph_re[j].as_mut_ptr(), nr);
                _mm512_storeu_pd(k.ph_im[j].as_mut_ptr(), ni);
            }
        }
        let len = LANES.min(k.nsc - i0);
        for q in 0..terms {
            // SAFETY: tr, ti hold LANES = 8 f64.
            unsafe {
                _mm512_storeu_pd(tr.as_mut_ptr(), _mm512_add_pd(ar[q][0], ar[q][1]));
                _mm512_storeu_pd(ti.as_mut_ptr(), _mm512_add_pd(ai[q][0], ai[q][1]));
            }
            for l in 0..len {
                k.acc[q * k.nsc + i0 + l] = rustfft::num_complex::Complex64::new(tr[l], ti[l]);
            }
        }
    }
}

/// The single-term case (stop-and-hop) with all accumulators in registers: four chains, one
/// per path modulo 4.
///
/// # Safety
/// The CPU must support AVX-512F; `k.terms == 1`.
#[target_feature(enable = "avx512f")]
unsafe fn path_sums_one(k: &mut SumKernel<'_>) {
    let np = k.ph_re.len();
    let zero = _mm512_setzero_pd();
    let mut tr = [0.0f64; LANES];
    let mut ti = [0.0f64; LANES];
    for i0 in (0..k.nsc).step_by(LANES) {
        let mut ar = [zero; 4];
        let mut ai = [zero; 4];
        for j in 0..np {
            let h = j & 3;
            // SAFETY: ph_re[j], ph_im[j] are [f64; LANES] = 8 f64 = one register each.
            let (pr, pi) = unsafe {
                (
                    _mm512_loadu_pd(k.ph_re[j].as_ptr()),
                    _mm512_loadu_pd(k.ph_im[j].as_ptr()),
                )
            };
            let c = k.co[j];
            let (cr, ci) = (_mm512_set1_pd(c.re), _mm512_set1_pd(c.im));
            ar[h] = _mm512_fnmadd_pd(ci, pi, _mm512_fmadd_pd(cr, pr, ar[h]));
            ai[h] = _mm512_fmadd_pd(ci, pr, _mm512_fmadd_pd(cr, pi, ai[h]));
            let (sr, si) = (_mm512_set1_pd(k.st[j].re), _mm512_set1_pd(k.st[j].im));
            let nr = _mm512_fmsub_pd(pr, sr, _mm512_mul_pd(pi, si));
            let ni = _mm512_fmadd_pd(pr, si, _mm512_mul_pd(pi, sr));
            // SAFETY: as for the loads.
            unsafe {
                _mm512_storeu_pd(k.ph_re[j].as_mut_ptr(), nr);
                _mm512_storeu_pd(k.ph_im[j].as_mut_ptr(), ni);
            }
        }
        let sr = _mm512_add_pd(_mm512_add_pd(ar[0], ar[1]), _mm512_add_pd(ar[2], ar[3]));
        let si = _mm512_add_pd(_mm512_add_pd(ai[0], ai[1]), _mm512_add_pd(ai[2], ai[3]));
        // SAFETY: tr, ti hold LANES = 8 f64.
        unsafe {
            _mm512_storeu_pd(tr.as_mut_ptr(), sr);
            _mm512_storeu_pd(ti.as_mut_ptr(), si);
        }
        for l in 0..LANES.min(k.nsc - i0) {
            k.acc[i0 + l] = rustfft::num_complex::Complex64::new(tr[l], ti[l]);
        }
    }
}
