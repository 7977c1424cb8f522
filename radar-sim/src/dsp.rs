//! Small exact DSP kernels shared by synthesis, cancellation and compression: sums of a
//! spectrum against complex exponentials at many lags, in f64 with eight lanes per SIMD
//! register (phasor recurrences, starts from exact twiddles).

use rustfft::num_complex::Complex64;

/// Lanes of the kernels (f64: one AVX-512 register, two AVX2 registers).
pub(crate) const LANES: usize = 8;

/// `e^{+j2π r/N}` for r = 0..N.
pub(crate) fn twiddles(n: usize) -> Vec<Complex64> {
    (0..n)
        .map(|r| Complex64::from_polar(1.0, std::f64::consts::TAU * r as f64 / n as f64))
        .collect()
}

/// `Σ_i x_i e^{j2π (k0 + i) s / N}` for each integer lag s in `lags` (`tw` = [`twiddles`] of
/// N), eight lags at a time in SIMD lanes.
#[cfg(test)]
pub(crate) fn int_lag_sums(
    x: &[Complex64],
    k0: i64,
    lags: &[i64],
    tw: &[Complex64],
) -> Vec<Complex64> {
    let n = tw.len() as i64;
    let mut out = Vec::with_capacity(lags.len());
    for chunk in lags.chunks(LANES) {
        let mut ph_re = [0.0; LANES];
        let mut ph_im = [0.0; LANES];
        let mut st_re = [1.0; LANES];
        let mut st_im = [0.0; LANES];
        for (l, &s) in chunk.iter().enumerate() {
            let p = tw[(k0 * s).rem_euclid(n) as usize];
            let st = tw[s.rem_euclid(n) as usize];
            (ph_re[l], ph_im[l], st_re[l], st_im[l]) = (p.re, p.im, st.re, st.im);
        }
        let (sr, si) = lane_sums(x, ph_re, ph_im, st_re, st_im);
        for l in 0..chunk.len() {
            out.push(Complex64::new(sr[l], si[l]));
        }
    }
    out
}

/// [`int_lag_sums`] of `V` spectra at once (shared phasors): `out[v][l]` =
/// `Σ_i xs[v]_i e^{j2π (k0 + i) lags[l] / N}`.
pub(crate) fn int_lag_sums_many<const V: usize>(
    xs: [&[Complex64]; V],
    k0: i64,
    lags: &[i64],
    tw: &[Complex64],
) -> [Vec<Complex64>; V] {
    #[inline(always)]
    fn kernel<const V: usize>(
        xs: [&[Complex64]; V],
        mut pr: [f64; LANES],
        mut pi: [f64; LANES],
        st_re: [f64; LANES],
        st_im: [f64; LANES],
    ) -> [[f64; 2 * LANES]; V] {
        let mut acc = [[0.0; 2 * LANES]; V];
        let len = xs.iter().map(|x| x.len()).min().unwrap_or(0); // equal lengths (callers)
        for i in 0..len {
            for (v, x) in xs.iter().enumerate() {
                let z = x[i];
                for l in 0..LANES {
                    acc[v][l] += z.re * pr[l] - z.im * pi[l];
                    acc[v][LANES + l] += z.re * pi[l] + z.im * pr[l];
                }
            }
            for l in 0..LANES {
                let r = pr[l] * st_re[l] - pi[l] * st_im[l];
                pi[l] = pr[l] * st_im[l] + pi[l] * st_re[l];
                pr[l] = r;
            }
        }
        acc
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn k512<const V: usize>(
        xs: [&[Complex64]; V],
        a: [f64; LANES],
        b: [f64; LANES],
        c: [f64; LANES],
        d: [f64; LANES],
    ) -> [[f64; 2 * LANES]; V] {
        kernel(xs, a, b, c, d)
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn k256<const V: usize>(
        xs: [&[Complex64]; V],
        a: [f64; LANES],
        b: [f64; LANES],
        c: [f64; LANES],
        d: [f64; LANES],
    ) -> [[f64; 2 * LANES]; V] {
        kernel(xs, a, b, c, d)
    }
    let n = tw.len() as i64;
    let mut out: [Vec<Complex64>; V] = std::array::from_fn(|_| Vec::with_capacity(lags.len()));
    for chunk in lags.chunks(LANES) {
        let mut ph_re = [0.0; LANES];
        let mut ph_im = [0.0; LANES];
        let mut st_re = [1.0; LANES];
        let mut st_im = [0.0; LANES];
        for (l, &s) in chunk.iter().enumerate() {
            let p = tw[(k0 * s).rem_euclid(n) as usize];
            let st = tw[s.rem_euclid(n) as usize];
            (ph_re[l], ph_im[l], st_re[l], st_im[l]) = (p.re, p.im, st.re, st.im);
        }
        let acc = 'run: {
            #[cfg(target_arch = "x86_64")]
            {
                if crate::kernels::avx512() {
                    // SAFETY: the CPU supports AVX-512F (checked just above).
                    break 'run unsafe { k512(xs, ph_re, ph_im, st_re, st_im) };
                }
                if crate::kernels::avx2_fma() {
                    // SAFETY: the CPU supports AVX2 and FMA (checked just above).
                    break 'run unsafe { k256(xs, ph_re, ph_im, st_re, st_im) };
                }
            }
            kernel(xs, ph_re, ph_im, st_re, st_im)
        };
        for (o, a) in out.iter_mut().zip(&acc) {
            for l in 0..chunk.len() {
                o.push(Complex64::new(a[l], a[LANES + l]));
            }
        }
    }
    out
}

/// `Σ_i x_i e^{j2π (k0 + i) d / N}` for one real lag d, eight consecutive i in SIMD lanes.
pub(crate) fn ramp_sum(x: &[Complex64], k0: f64, n: usize, d: f64) -> Complex64 {
    let n = n as f64;
    let step = Complex64::from_polar(1.0, std::f64::consts::TAU * d / n);
    let mut ph = Complex64::from_polar(1.0, std::f64::consts::TAU * (k0 * d / n).rem_euclid(1.0));
    let mut pr = [0.0; LANES];
    let mut pi = [0.0; LANES];
    for l in 0..LANES {
        (pr[l], pi[l]) = (ph.re, ph.im);
        ph *= step;
    }
    let s8 = Complex64::from_polar(
        1.0,
        std::f64::consts::TAU * (LANES as f64 * d / n).rem_euclid(1.0),
    );
    let mut sr = [0.0; LANES];
    let mut si = [0.0; LANES];
    let mut chunks = x.chunks_exact(LANES);
    for c in &mut chunks {
        for l in 0..LANES {
            sr[l] += c[l].re * pr[l] - c[l].im * pi[l];
            si[l] += c[l].re * pi[l] + c[l].im * pr[l];
            let r = pr[l] * s8.re - pi[l] * s8.im;
            pi[l] = pr[l] * s8.im + pi[l] * s8.re;
            pr[l] = r;
        }
    }
    for (l, c) in chunks.remainder().iter().enumerate() {
        sr[l] += c.re * pr[l] - c.im * pi[l];
        si[l] += c.re * pi[l] + c.im * pr[l];
    }
    Complex64::new(sr.iter().sum(), si.iter().sum())
}

/// `out[i] = e^{−j2π (k0 + i) d / N}` for i = 0..out.len(), from blocks of exact twiddles
/// (one complex product per value, no long recurrence).
pub(crate) fn phase_ramp(d: f64, k0: f64, n: usize, out: &mut [Complex64]) {
    const B: usize = 64;
    let cis = |x: f64| Complex64::from_polar(1.0, -std::f64::consts::TAU * (x - x.floor()));
    let inner: Vec<Complex64> = (0..B).map(|r| cis(r as f64 * d / n as f64)).collect();
    for (b, chunk) in out.chunks_mut(B).enumerate() {
        let outer = cis((k0 + (b * B) as f64) * d / n as f64);
        for (o, w) in chunk.iter_mut().zip(&inner) {
            *o = outer * w;
        }
    }
}

/// `Σ_i z_i e^{j2π (k0 + i) k / N}` for each k in `ks`, eight k at a time in SIMD lanes.
pub(crate) fn direct_sums(
    z: &[Complex64],
    k0: i64,
    n: usize,
    ks: std::ops::Range<usize>,
) -> Vec<Complex64> {
    let ks: Vec<usize> = ks.collect();
    let mut out = Vec::with_capacity(ks.len());
    for chunk in ks.chunks(LANES) {
        let mut ph_re = [0.0; LANES];
        let mut ph_im = [0.0; LANES];
        let mut st_re = [1.0; LANES];
        let mut st_im = [0.0; LANES];
        for (l, &k) in chunk.iter().enumerate() {
            let r0 = (k0 * k as i64).rem_euclid(n as i64) as f64 / n as f64;
            let p = Complex64::from_polar(1.0, std::f64::consts::TAU * r0);
            let s = Complex64::from_polar(1.0, std::f64::consts::TAU * k as f64 / n as f64);
            (ph_re[l], ph_im[l], st_re[l], st_im[l]) = (p.re, p.im, s.re, s.im);
        }
        let (sr, si) = lane_sums(z, ph_re, ph_im, st_re, st_im);
        for l in 0..chunk.len() {
            out.push(Complex64::new(sr[l], si[l]));
        }
    }
    out
}

/// Σ_i z_i ph_l step_l^i for eight lanes l (dispatches to an AVX-512 or AVX2 copy).
pub(crate) fn lane_sums(
    z: &[Complex64],
    ph_re: [f64; LANES],
    ph_im: [f64; LANES],
    st_re: [f64; LANES],
    st_im: [f64; LANES],
) -> ([f64; LANES], [f64; LANES]) {
    #[inline(always)]
    fn kernel(
        z: &[Complex64],
        ph_re: [f64; LANES],
        ph_im: [f64; LANES],
        st_re: [f64; LANES],
        st_im: [f64; LANES],
    ) -> ([f64; LANES], [f64; LANES]) {
        // two interleaved chains (even and odd i, advanced by step²): twice the independent
        // work per iteration for the out-of-order core
        let mut qr = ph_re;
        let mut qi = ph_im;
        for l in 0..LANES {
            qr[l] = ph_re[l] * st_re[l] - ph_im[l] * st_im[l];
            qi[l] = ph_re[l] * st_im[l] + ph_im[l] * st_re[l];
        }
        let mut s2r = [0.0; LANES];
        let mut s2i = [0.0; LANES];
        for l in 0..LANES {
            s2r[l] = st_re[l] * st_re[l] - st_im[l] * st_im[l];
            s2i[l] = 2.0 * st_re[l] * st_im[l];
        }
        let (mut pr, mut pi) = (ph_re, ph_im);
        let mut sr = [0.0; LANES];
        let mut si = [0.0; LANES];
        let mut tr = [0.0; LANES];
        let mut ti = [0.0; LANES];
        let mut pairs = z.chunks_exact(2);
        for zz in &mut pairs {
            let (a, b) = (zz[0], zz[1]);
            for l in 0..LANES {
                sr[l] += a.re * pr[l] - a.im * pi[l];
                si[l] += a.re * pi[l] + a.im * pr[l];
                tr[l] += b.re * qr[l] - b.im * qi[l];
                ti[l] += b.re * qi[l] + b.im * qr[l];
                let r = pr[l] * s2r[l] - pi[l] * s2i[l];
                pi[l] = pr[l] * s2i[l] + pi[l] * s2r[l];
                pr[l] = r;
                let r = qr[l] * s2r[l] - qi[l] * s2i[l];
                qi[l] = qr[l] * s2i[l] + qi[l] * s2r[l];
                qr[l] = r;
            }
        }
        if let [a] = pairs.remainder() {
            for l in 0..LANES {
                sr[l] += a.re * pr[l] - a.im * pi[l];
                si[l] += a.re * pi[l] + a.im * pr[l];
            }
        }
        for l in 0..LANES {
            sr[l] += tr[l];
            si[l] += ti[l];
        }
        (sr, si)
    }
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f")]
        fn k512(
            z: &[Complex64],
            a: [f64; LANES],
            b: [f64; LANES],
            c: [f64; LANES],
            d: [f64; LANES],
        ) -> ([f64; LANES], [f64; LANES]) {
            kernel(z, a, b, c, d)
        }
        #[target_feature(enable = "avx2,fma")]
        fn k256(
            z: &[Complex64],
            a: [f64; LANES],
            b: [f64; LANES],
            c: [f64; LANES],
            d: [f64; LANES],
        ) -> ([f64; LANES], [f64; LANES]) {
            kernel(z, a, b, c, d)
        }
        if crate::kernels::avx512() {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { k512(z, ph_re, ph_im, st_re, st_im) };
        }
        if crate::kernels::avx2_fma() {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            return unsafe { k256(z, ph_re, ph_im, st_re, st_im) };
        }
    }
    kernel(z, ph_re, ph_im, st_re, st_im)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(x: &[Complex64], k0: f64, n: usize, s: f64) -> Complex64 {
        x.iter()
            .enumerate()
            .map(|(i, v)| {
                v * Complex64::from_polar(
                    1.0,
                    std::f64::consts::TAU * (k0 + i as f64) * s / n as f64,
                )
            })
            .sum()
    }

    #[test]
    fn lag_sums_match_brute_force() {
        let n = 256;
        let x: Vec<Complex64> = (0..203)
            .map(|i| Complex64::new((0.37 * i as f64).sin(), (0.11 * i as f64).cos()))
            .collect();
        let tw = twiddles(n);
        let lags: Vec<i64> = (-13..11).chain([200, -1000]).collect();
        let got = int_lag_sums(&x, -101, &lags, &tw);
        for (s, g) in lags.iter().zip(&got) {
            let w = brute(&x, -101.0, n, *s as f64);
            assert!(
                (g - w).norm() < 1e-10 * (1.0 + w.norm()),
                "lag {s}: {g} vs {w}"
            );
        }
        let y: Vec<Complex64> = x.iter().map(|v| v * Complex64::new(0.3, -1.1)).collect();
        let z: Vec<Complex64> = x.iter().rev().copied().collect();
        let three = int_lag_sums_many([&x, &y, &z], -101, &lags, &tw);
        for (v, xv) in [&x, &y, &z].iter().enumerate() {
            for (s, g) in lags.iter().zip(&three[v]) {
                let w = brute(xv, -101.0, n, *s as f64);
                assert!(
                    (g - w).norm() < 1e-10 * (1.0 + w.norm()),
                    "x{v} lag {s}: {g} vs {w}"
                );
            }
        }
        for d in [0.0, 3.25, -7.7, 1234.5] {
            let w = brute(&x, -101.0, n, d);
            let g = ramp_sum(&x, -101.0, n, d);
            assert!(
                (g - w).norm() < 1e-10 * (1.0 + w.norm()),
                "delay {d}: {g} vs {w}"
            );
        }
        let mut r = vec![Complex64::new(0.0, 0.0); 203];
        phase_ramp(3.7, -101.0, n, &mut r);
        for (i, v) in r.iter().enumerate() {
            let w = Complex64::from_polar(
                1.0,
                -std::f64::consts::TAU * (i as f64 - 101.0) * 3.7 / n as f64,
            );
            assert!((v - w).norm() < 1e-12);
        }
    }
}
