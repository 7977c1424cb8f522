//! Statistics of Gamma(L) noise behind the CFAR's design: the false-alarm probability of the
//! cell-averaging threshold and its inverse, the censored mean, the expected number of
//! false-alarm peaks, and the image-wide noise floor.

/// ln C(n, k) via lgamma-free summation of logs (n, k small enough).
fn ln_binom(n: f64, k: usize) -> f64 {
    let mut s = 0.0;
    for i in 0..k {
        s += (n - i as f64).ln() - ((i + 1) as f64).ln();
    }
    s
}

/// P_fa of CA-CFAR with `n` independent training cells, `looks` looks, factor `alpha`.
pub fn ca_pfa(alpha: f64, n: f64, looks: usize) -> f64 {
    let l = looks.max(1);
    let x = alpha / n;
    let nl = n * l as f64;
    let mut p = 0.0;
    for k in 0..l {
        p += (ln_binom(nl + k as f64 - 1.0, k) + k as f64 * x.ln() - (nl + k as f64) * x.ln_1p())
            .exp();
    }
    p
}

/// The CA-CFAR factor α for a design `pfa` (bisection on [`ca_pfa`]).
pub fn ca_alpha(pfa: f64, n: f64, looks: usize) -> f64 {
    let (mut lo, mut hi): (f64, f64) = (1e-6, 1e6);
    for _ in 0..200 {
        let mid = (lo * hi).sqrt();
        if ca_pfa(mid, n, looks) > pfa {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo * hi).sqrt()
}

/// Noise exceeds the censoring level of the training cells with this probability per pixel
/// (the level is relative to the image-wide floor).
pub const CENSOR_PFA: f64 = 1e-3;

/// A pixel with fewer independent training cells than this is tested against the image-wide
/// censored mean (α for the image's cells) instead of its own training cells.
pub const MIN_TRAINING_CELLS: f64 = 8.0;

/// Sidelobe editing margin: a peak no higher than this times (the stronger detections'
/// predicted response at it + the local noise) is taken for their response, not an object.
pub const SIDELOBE_MARGIN: f64 = 2.0;

/// `P(X > x)` for X ~ Gamma(`shape`, `rate`) with an integer shape:
/// `e^{−rate·x} Σ_{j<shape} (rate·x)^j / j!` (summed in logs).
pub fn gamma_sf(shape: usize, rate: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let t = rate * x;
    let lt = t.ln();
    let mut ln_fact = 0.0;
    let mut s = 0.0;
    for j in 0..shape.max(1) {
        if j > 0 {
            ln_fact += (j as f64).ln();
        }
        s += (-t + j as f64 * lt - ln_fact).exp();
    }
    s.min(1.0)
}

/// `P(X > x)` for the unit-mean Gamma(L) intensity of L-look noise.
pub fn unit_gamma_sf(looks: usize, x: f64) -> f64 {
    let l = looks.max(1);
    gamma_sf(l, l as f64, x)
}

/// The level that unit-mean L-look noise exceeds with probability `p` (bisection).
pub fn unit_gamma_isf(looks: usize, p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while unit_gamma_sf(looks, hi) > p && hi < 1e6 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if unit_gamma_sf(looks, mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `E[X | X < c]` for unit-mean L-look noise X: `P(Y < c) / P(X < c)` with
/// Y ~ Gamma(L + 1, rate L) (since x f_X(x) is Y's density).
pub fn censored_mean(looks: usize, c: f64) -> f64 {
    let l = looks.max(1);
    let below = 1.0 - unit_gamma_sf(l, c);
    if below <= 0.0 {
        return 1.0;
    }
    (1.0 - gamma_sf(l + 1, l as f64, c)) / below
}

/// ln Γ(x), x > 0 (Lanczos, g = 7, 9 terms; relative error ~1e-15).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// `E[f(m)]` for the CA noise estimate m of `n` independent training cells of unit-mean
/// L-look noise, m ~ Gamma(nL, rate nL) (Simpson's rule over ±12 standard deviations).
fn expect_over_estimate(n: f64, looks: usize, f: impl Fn(f64) -> f64) -> f64 {
    let a = n.max(1e-3) * looks.max(1) as f64;
    let sd = 1.0 / a.sqrt();
    let lo = (1.0 - 12.0 * sd).max(1e-9);
    let hi = 1.0 + 12.0 * sd + 24.0 / a;
    let steps = 4000;
    let h = (hi - lo) / steps as f64;
    let ln_norm = a * a.ln() - ln_gamma(a);
    let mut s = 0.0;
    for i in 0..=steps {
        let m = lo + i as f64 * h;
        let w = if i == 0 || i == steps {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        s += w * (ln_norm + (a - 1.0) * m.ln() - a * m).exp() * f(m);
    }
    s * h / 3.0
}

/// Expected number per m² of noise peaks that the CFAR detects at design `pfa` with `n`
/// independent training cells on `looks`-look noise whose component Gaussian fields have
/// `√det Λ` = `curvature_per_m2` (Λ the covariance of their gradient,
/// [`ResponseModel::noise_curvature_per_m2`](super::ResponseModel::noise_curvature_per_m2)).
///
/// The multilook intensity is `χ²_{2L} / 2L` times the floor, and at high thresholds each
/// excursion above it holds one peak, so the count is the Euler-characteristic density of the
/// χ²_k field (Worsley 1994), k = 2L, `ρ₂(t) = √det Λ · f_k(t) (t − k + 1) / π` (f_k the χ²_k
/// density), at t = 2L α m, averaged over the random CA estimate m. The boundary terms are left
/// out: a peak on the image border is no detection.
pub fn expected_peaks_per_m2(pfa: f64, n: f64, looks: usize, curvature_per_m2: f64) -> f64 {
    let l = looks.max(1);
    let k = 2.0 * l as f64;
    let alpha = ca_alpha(pfa, n.max(1.0), l);
    let ln_norm = -(l as f64) * 2f64.ln() - ln_gamma(l as f64);
    let rho2 = |t: f64| -> f64 {
        if t <= 0.0 {
            return 0.0;
        }
        let f = (ln_norm + (l as f64 - 1.0) * t.ln() - 0.5 * t).exp();
        curvature_per_m2 * f * (t - k + 1.0) / std::f64::consts::PI
    };
    expect_over_estimate(n.max(1.0), l, |m| rho2(k * alpha * m)).max(0.0)
}

/// The same average of the exceedance probability, `E[P(X > α m)]`: equals [`ca_pfa`] (a check
/// of the averaging).
pub fn averaged_pfa(pfa: f64, n: f64, looks: usize) -> f64 {
    let l = looks.max(1);
    let alpha = ca_alpha(pfa, n.max(1.0), l);
    expect_over_estimate(n.max(1.0), l, |m| unit_gamma_sf(l, alpha * m))
}

/// The image-wide noise floor of an L-look power image: the fixed point of the censored mean,
/// `f = mean{x < c f} / censored_mean(L, c)` (c the [`CENSOR_PFA`] level of unit L-look noise),
/// iterated from `start` (the known thermal floor; [`ca_cfar`](super::ca_cfar) starts from the median over the
/// median of unit noise instead when no floor is known or nothing lies below the known one's
/// censoring level). On noise it is an unbiased estimate of the floor; pixels of targets'
/// responses above the censoring level do not enter it. Returns (floor, pixels kept at the
/// fixed point).
pub fn image_floor(img: &[f32], looks: usize, start: f64) -> (f64, usize) {
    let l = looks.max(1);
    let c = unit_gamma_isf(l, CENSOR_PFA);
    let tau = censored_mean(l, c);
    let mut f = start;
    let mut kept = 0usize;
    if !(f.is_finite() && f > 0.0) {
        return (f, 0);
    }
    for _ in 0..200 {
        let level = c * f;
        let (mut s, mut n) = (0.0f64, 0usize);
        for v in img {
            let v = *v as f64;
            if v.is_finite() && v < level {
                s += v;
                n += 1;
            }
        }
        kept = n;
        if n == 0 {
            break;
        }
        let next = s / n as f64 / tau;
        let done = (next - f).abs() <= 1e-6 * f;
        f = next;
        if done {
            break;
        }
    }
    (f, kept)
}
