//! 2-D censored cell-averaging CFAR on an L-look power image, peak detection with non-maximum
//! suppression and sidelobe editing, and the design false-alarm counts on noise.
//!
//! With unit-mean Gamma(L) noise in every pixel and the noise level estimated as the mean of N
//! independent training cells, the false-alarm probability of the threshold α·mean is
//! `P_fa = Σ_{k<L} C(NL+k−1, k) (α/N)^k (1 + α/N)^{−(NL+k)}`; α is solved from it by bisection.
//! Pixels of an oversampled image are correlated, so `N` is the number of training pixels
//! divided by the pixels per resolution cell ([`CfarParams::pixels_per_cell`]).
//!
//! The training cells are censored, not averaged blindly: a pixel above the level that noise
//! exceeds with probability [`CENSOR_PFA`] relative to the image-wide floor is left out, and the
//! mean of the rest is divided by the mean of a censored unit Gamma(L) variable, so that it is
//! unbiased on noise. Strong neighbours' main lobes, ridges and sidelobes thus do not raise the
//! threshold (masking). The image-wide floor is the censored mean's fixed point reached from
//! the receiver's known thermal floor ([`image_floor`]): it follows a floor raised by anything
//! noise-like (the inter-symbol interference of echoes beyond the cyclic prefix) but not the
//! targets' responses, even where they cover most of the image (near-blind geometry). A pixel
//! with fewer than [`MIN_TRAINING_CELLS`] independent training cells is tested against the
//! image-wide floor instead (and counted: [`CfarMap::fallback_pixels`]); no pixel is left
//! untested.

use serde::{Deserialize, Serialize};

use crate::backproject::Grid;

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
/// [`ResponseModel::noise_curvature_per_m2`]).
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
/// iterated from `start` (the known thermal floor; [`ca_cfar`] starts from the median over the
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

/// Relative scale margin of the response model (linearisation over the grid and the
/// aperture): offsets are shrunk by this fraction before the envelope is read.
pub const MODEL_SCALE_MARGIN: f64 = 0.15;

/// Absolute margin of the response model, resolution cells (peak positions on the pixel grid).
pub const MODEL_CELL_MARGIN: f64 = 0.25;

/// Envelope table step and extent, resolution units.
const ENV_STEP: f64 = 1.0 / 32.0;
const ENV_MAX: f64 = 64.0;

/// `max_{|v| ≥ |u|} |ŵ(v)|²` on a grid of [`ENV_STEP`] up to [`ENV_MAX`]: the response itself
/// inside the main lobe, the next sidelobe peak beyond it.
fn envelope_table(w: crate::config::Weighting) -> Vec<f64> {
    let n = (ENV_MAX / ENV_STEP).round() as usize + 1;
    let mut t: Vec<f64> = (0..n)
        .map(|i| w.amplitude_response(i as f64 * ENV_STEP).powi(2))
        .collect();
    for i in (0..n - 1).rev() {
        t[i] = t[i].max(t[i + 1]);
    }
    t
}

fn envelope_at(t: &[f64], u: f64) -> f64 {
    let u = u.abs();
    if !u.is_finite() {
        return 0.0;
    }
    let last = t.len() - 1;
    if u >= ENV_MAX {
        // beyond the table: at most the 1/u² decay of the unweighted response
        return t[last] * (ENV_MAX / u).powi(2);
    }
    t[((u / ENV_STEP) as usize).min(last)]
}

/// The predicted point response of the multilook image, linearised at the image centre: in each
/// look separable in the range coordinate `u_r = (g·Δ) B / c` and the Doppler coordinate
/// `u_a = (∇f_D·Δ) T` (ground offset Δ from the peak, in resolution cells), with the range and
/// azimuth tapers' responses; the multilook response is the mean over the looks.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseModel {
    /// Per look: (range cells per metre of ground offset `g B / c`, Doppler cells per metre
    /// `∇f_D T`), 1/m.
    pub looks: Vec<([f64; 2], [f64; 2])>,
    /// Range (spectral) taper.
    pub range_weighting: crate::config::Weighting,
    /// Azimuth (slow-time) taper.
    pub azimuth_weighting: crate::config::Weighting,
    range_env: Vec<f64>,
    azimuth_env: Vec<f64>,
}

impl ResponseModel {
    /// The model for the looks' (range, Doppler) cells per metre and the two tapers.
    pub fn new(
        looks: Vec<([f64; 2], [f64; 2])>,
        range_weighting: crate::config::Weighting,
        azimuth_weighting: crate::config::Weighting,
    ) -> Self {
        Self {
            looks,
            range_weighting,
            azimuth_weighting,
            range_env: envelope_table(range_weighting),
            azimuth_env: envelope_table(azimuth_weighting),
        }
    }

    /// Upper envelope of the normalised multilook power response at ground offset `d_m` from
    /// the peak: the mean over the looks of the product of the range and azimuth responses'
    /// envelopes, each read at the offset shrunk by [`MODEL_SCALE_MARGIN`] and
    /// [`MODEL_CELL_MARGIN`] (1 at 0).
    pub fn envelope(&self, d_m: [f64; 2]) -> f64 {
        if self.looks.is_empty() {
            return 0.0;
        }
        let shrink = |u: f64| (u.abs() * (1.0 - MODEL_SCALE_MARGIN) - MODEL_CELL_MARGIN).max(0.0);
        self.looks
            .iter()
            .map(|(r, a)| {
                let ur = r[0] * d_m[0] + r[1] * d_m[1];
                let ua = a[0] * d_m[0] + a[1] * d_m[1];
                envelope_at(&self.range_env, shrink(ur))
                    * envelope_at(&self.azimuth_env, shrink(ua))
            })
            .sum::<f64>()
            / self.looks.len() as f64
    }

    /// `√det Λ` of the image noise's component Gaussian fields, 1/m² (mean over the looks):
    /// Λ = 4π² (μ_r a_r a_rᵀ + μ_a a_a a_aᵀ), a the cells per metre, μ the tapers' squared
    /// second moments ([`crate::config::Weighting::spectral_second_moment`]).
    pub fn noise_curvature_per_m2(&self) -> f64 {
        if self.looks.is_empty() {
            return 0.0;
        }
        let cross = self
            .looks
            .iter()
            .map(|(a, b)| (a[0] * b[1] - a[1] * b[0]).abs())
            .sum::<f64>()
            / self.looks.len() as f64;
        4.0 * std::f64::consts::PI.powi(2)
            * (self.range_weighting.spectral_second_moment()
                * self.azimuth_weighting.spectral_second_moment())
            .sqrt()
            * cross
    }
}

/// CFAR settings in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CfarParams {
    /// Design false-alarm probability per pixel.
    pub pfa: f64,
    /// Guard half-width along x (columns), pixels.
    pub guard_x_px: usize,
    /// Guard half-width along y (rows), pixels.
    pub guard_y_px: usize,
    /// Training band width, pixels.
    pub train_px: usize,
    /// Looks averaged in the image.
    pub looks: usize,
    /// Pixels per coherence area ∫∫|ρ|² dA of the image (≥ 1): the training mean of N pixels
    /// has the variance of N / this independent cells.
    pub pixels_per_cell: f64,
    /// The image's thermal noise floor if known (1 for the processor's images, normalised to
    /// the per-look noise variance): the image-wide floor estimate ([`image_floor`]) starts
    /// from it; without it, from the median.
    pub known_floor: Option<f64>,
}

/// Output of the CFAR: the exceedance mask and the noise estimates.
#[derive(Debug, Clone, PartialEq)]
pub struct CfarMap {
    /// Per pixel: image ≥ α · noise.
    pub hits: Vec<bool>,
    /// Per pixel: the noise estimate it was tested against (censored training mean, or the
    /// image-wide one for a fallback pixel).
    pub noise: Vec<f32>,
    /// Pixels with fewer than [`MIN_TRAINING_CELLS`] independent training cells, tested
    /// against the image-wide censored mean.
    pub fallback_pixels: usize,
    /// Image-wide noise floor ([`image_floor`]): sets the censoring level, and the noise of the
    /// fallback pixels.
    pub floor: f64,
    /// Median over the pixels of the independent training cells their threshold used.
    pub median_cells: f64,
}

/// Summed-area table of `v` (ny × nx) with a zero first row and column.
fn sat_of(v: &[f64], nx: usize, ny: usize) -> Vec<f64> {
    let w = nx + 1;
    let mut sat = vec![0f64; (ny + 1) * w];
    for y in 0..ny {
        let mut row = 0.0;
        for x in 0..nx {
            row += v[y * nx + x];
            sat[(y + 1) * w + x + 1] = sat[y * w + x + 1] + row;
        }
    }
    sat
}

/// Sum of a SAT over the inclusive box clipped to the image.
fn box_sum(sat: &[f64], nx: usize, ny: usize, x0: i64, y0: i64, x1: i64, y1: i64) -> f64 {
    let w = nx + 1;
    let x0 = x0.max(0) as usize;
    let y0 = y0.max(0) as usize;
    let x1 = x1.min(nx as i64 - 1);
    let y1 = y1.min(ny as i64 - 1);
    if x1 < x0 as i64 || y1 < y0 as i64 {
        return 0.0;
    }
    let (x1, y1) = (x1 as usize, y1 as usize);
    sat[(y1 + 1) * w + x1 + 1] - sat[y0 * w + x1 + 1] - sat[(y1 + 1) * w + x0] + sat[y0 * w + x0]
}

/// Runs the censored CA-CFAR on a power image (ny × nx, row-major).
///
/// The image-wide floor is [`image_floor`]; training pixels at or above [`CENSOR_PFA`]'s level
/// times that floor are censored, and each pixel's noise estimate is the mean of its remaining
/// training pixels (the band around its guard box, shifted inside the image at the edges) over
/// [`censored_mean`]. α is solved for the remaining pixels' number of independent cells; a
/// pixel with fewer than [`MIN_TRAINING_CELLS`] uses the image-wide floor, with α for the
/// image's kept pixels.
pub fn ca_cfar(img: &[f32], nx: usize, ny: usize, p: &CfarParams) -> CfarMap {
    let npx = nx * ny;
    let looks = p.looks.max(1);
    let ppc = p.pixels_per_cell.max(1.0);
    let (gx, gy) = (p.guard_x_px as i64, p.guard_y_px as i64);
    let t = p.train_px as i64;
    let vals: Vec<f64> = img.iter().map(|v| *v as f64).collect();
    let from_median = || {
        let mut finite: Vec<f64> = vals.iter().copied().filter(|v| v.is_finite()).collect();
        if finite.is_empty() {
            0.0
        } else {
            let k = finite.len() / 2;
            let (_, m, _) = finite.select_nth_unstable_by(k, f64::total_cmp);
            *m / unit_gamma_isf(looks, 0.5)
        }
    };
    let (floor, n_kept) = match p.known_floor {
        Some(f) if f.is_finite() && f > 0.0 => match image_floor(img, looks, f) {
            // nothing below the censoring level of the known floor: a floor far above it
            (_, 0) => image_floor(img, looks, from_median()),
            found => found,
        },
        _ => image_floor(img, looks, from_median()),
    };
    let c = unit_gamma_isf(looks, CENSOR_PFA);
    let (level, tau) = if floor > 0.0 && n_kept > 0 {
        (c * floor, censored_mean(looks, c))
    } else {
        (f64::INFINITY, 1.0)
    };
    let keep: Vec<f64> = vals
        .iter()
        .map(|v| {
            if v.is_finite() && *v < level {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    let kept: Vec<f64> = vals.iter().zip(&keep).map(|(v, k)| v * k).collect();
    let n_all: f64 = keep.iter().sum();
    let global = if n_all > 0.0 {
        kept.iter().sum::<f64>() / n_all / tau
    } else {
        floor.max(f64::MIN_POSITIVE)
    };
    let n_global = (n_all / ppc).max(1.0);
    let alpha_global = ca_alpha(p.pfa, n_global, looks);
    let sv = sat_of(&kept, nx, ny);
    let sk = sat_of(&keep, nx, ny);
    let mut alpha_cache: std::collections::HashMap<usize, f64> = std::collections::HashMap::new();
    // the training box is shifted inside the image at the edges (same size where possible)
    let shift = |c: i64, h: i64, n: i64| -> (i64, i64) {
        let (mut a, mut b) = (c - h, c + h);
        if a < 0 {
            b += -a;
            a = 0;
        }
        if b > n - 1 {
            a -= b - (n - 1);
            b = n - 1;
        }
        (a.max(0), b)
    };
    let mut hits = vec![false; npx];
    let mut noise = vec![0f32; npx];
    let mut cells = Vec::with_capacity(npx);
    let mut fallback = 0usize;
    for y in 0..ny as i64 {
        for x in 0..nx as i64 {
            let (ox0, ox1) = shift(x, gx + t, nx as i64);
            let (oy0, oy1) = shift(y, gy + t, ny as i64);
            let so = box_sum(&sv, nx, ny, ox0, oy0, ox1, oy1);
            let sg = box_sum(&sv, nx, ny, x - gx, y - gy, x + gx, y + gy);
            let no = box_sum(&sk, nx, ny, ox0, oy0, ox1, oy1);
            let ng = box_sum(&sk, nx, ny, x - gx, y - gy, x + gx, y + gy);
            let n = (no - ng).round().max(0.0) as usize;
            let i = y as usize * nx + x as usize;
            let n_eff = n as f64 / ppc;
            let (m, thr, cells_used) = if n_eff >= MIN_TRAINING_CELLS {
                let m = (so - sg).max(0.0) / n as f64 / tau;
                let a = *alpha_cache
                    .entry(n)
                    .or_insert_with(|| ca_alpha(p.pfa, n_eff, looks));
                (m, a * m, n_eff)
            } else {
                fallback += 1;
                (global, alpha_global * global, n_global)
            };
            noise[i] = m as f32;
            hits[i] = vals[i].is_finite() && vals[i] >= thr;
            cells.push(cells_used);
        }
    }
    let median_cells = if cells.is_empty() {
        0.0
    } else {
        let k = cells.len() / 2;
        let (_, m, _) = cells.select_nth_unstable_by(k, f64::total_cmp);
        *m
    };
    CfarMap {
        hits,
        noise,
        fallback_pixels: fallback,
        floor,
        median_cells,
    }
}

/// One detection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Aperture index.
    pub aperture: usize,
    /// Ground x, m.
    pub x_m: f64,
    /// Ground y, m.
    pub y_m: f64,
    /// Peak image value over the local noise estimate, dB.
    pub snr_db: f64,
    /// Pixels in the cluster.
    pub pixels: usize,
}

/// 8-connected components of the `hits` of an `nx × ny` image: per pixel its component's index
/// (`usize::MAX` for no hit), and each component's size.
pub fn components(hits: &[bool], nx: usize, ny: usize) -> (Vec<usize>, Vec<usize>) {
    let mut label = vec![usize::MAX; nx * ny];
    let mut sizes: Vec<usize> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..(nx * ny).min(hits.len()) {
        if !hits[start] || label[start] != usize::MAX {
            continue;
        }
        let id = sizes.len();
        label[start] = id;
        stack.push(start);
        let mut size = 0usize;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx < 0 || yy < 0 || xx >= nx as i64 || yy >= ny as i64 {
                        continue;
                    }
                    let j = yy as usize * nx + xx as usize;
                    if hits[j] && label[j] == usize::MAX {
                        label[j] = id;
                        stack.push(j);
                    }
                }
            }
        }
        sizes.push(size);
    }
    (label, sizes)
}

/// Turns exceedances into detections. Every exceeding pixel that is a local maximum of the
/// image (above its 8 neighbours) is a peak; peaks are taken strongest first, and a peak is
/// suppressed when
/// - a stronger peak already taken lies within `merge_radius_m` (Euclidean; non-maximum
///   suppression between peaks, not pixels, so that a distinct peak next to a strong
///   neighbour's flank is kept), or
/// - with a `model` of the point response, it is no higher than [`SIDELOBE_MARGIN`] times the
///   response that the stronger peaks taken can put there (the coherent sum of their
///   amplitudes times the response's envelope, [`ResponseModel::envelope`]) plus the local
///   noise: a sidelobe of a stronger return, not an object (sidelobe editing).
///
/// Each peak kept is one detection at its sub-pixel position; `pixels` is the size of its
/// 8-connected exceedance region. A peak on the image border is no detection (the response
/// still rises towards the outside, so it belongs to an object beyond the grid, imaged in its
/// own aperture), but it suppresses as any other.
pub fn cluster(
    img: &[f32],
    map: &CfarMap,
    grid: &Grid,
    merge_radius_m: f64,
    aperture: usize,
    model: Option<&ResponseModel>,
) -> Vec<Detection> {
    let (nx, ny) = (grid.nx, grid.ny);
    let (label, sizes) = components(&map.hits, nx, ny);
    // peaks: exceeding local maxima (equal values: the lower index is the maximum)
    let mut peaks: Vec<usize> = (0..nx * ny)
        .filter(|&i| {
            if !map.hits[i] {
                return false;
            }
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            let v = img[i];
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let (xx, yy) = (x + dx, y + dy);
                    if (dx == 0 && dy == 0)
                        || xx < 0
                        || yy < 0
                        || xx >= nx as i64
                        || yy >= ny as i64
                    {
                        continue;
                    }
                    let j = yy as usize * nx + xx as usize;
                    if img[j] > v || (img[j] == v && j < i) {
                        return false;
                    }
                }
            }
            true
        })
        .collect();
    peaks.sort_by(|a, b| img[*b].total_cmp(&img[*a]).then(a.cmp(b)));
    let r = merge_radius_m.max(grid.spacing_m);
    let mut taken: Vec<([f64; 2], f64)> = Vec::new();
    let mut out = Vec::new();
    for i in peaks {
        let (xu, yu) = (i % nx, i / nx);
        let pos = [grid.x(xu), grid.y(yu)];
        let v = img[i] as f64;
        let near = taken
            .iter()
            .any(|(q, _)| (q[0] - pos[0]).hypot(q[1] - pos[1]) <= r);
        if near {
            continue;
        }
        if let Some(m) = model {
            let amp: f64 = taken
                .iter()
                .map(|(q, qv)| (qv * m.envelope([pos[0] - q[0], pos[1] - q[1]])).sqrt())
                .sum();
            if v <= SIDELOBE_MARGIN * (amp * amp + map.noise[i].max(0.0) as f64) {
                continue;
            }
        }
        taken.push((pos, v));
        if xu == 0 || yu == 0 || xu + 1 == nx || yu + 1 == ny {
            continue;
        }
        let refine = |a: f32, b: f32, c: f32| -> f64 {
            let (a, b, c) = (a as f64, b as f64, c as f64);
            let den = a - 2.0 * b + c;
            if den < 0.0 {
                (0.5 * (a - c) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        };
        let fx = refine(img[i - 1], img[i], img[i + 1]);
        let fy = refine(img[i - nx], img[i], img[i + nx]);
        let noise = map.noise[i].max(f32::MIN_POSITIVE) as f64;
        out.push(Detection {
            aperture,
            x_m: pos[0] + fx * grid.spacing_m,
            y_m: pos[1] + fy * grid.spacing_m,
            snr_db: 10.0 * (v / noise).log10(),
            pixels: sizes[label[i]],
        });
    }
    out.sort_by(|a, b| b.snr_db.total_cmp(&a.snr_db));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Gamma};

    #[test]
    fn pfa_formula_limits() {
        // L = 1: (1 + α/N)^−N
        let a = ca_alpha(1e-4, 50.0, 1);
        assert!(((1.0 + a / 50.0).powf(-50.0) / 1e-4 - 1.0).abs() < 1e-6);
        // large N, L = 1 → exp(−α)
        let a = ca_alpha(1e-6, 1e6, 1);
        assert!((a - 13.8155).abs() < 1e-2, "{a}");
        // more looks → lower threshold relative to the mean
        assert!(ca_alpha(1e-6, 200.0, 10) < ca_alpha(1e-6, 200.0, 1));
    }

    /// On white Gamma(L) noise the exceedance rate matches the design within 2x.
    #[test]
    fn false_alarm_rate_on_white_noise() {
        let (nx, ny) = (300usize, 300usize);
        for looks in [1usize, 4] {
            let g = Gamma::new(looks as f64, 1.0 / looks as f64).unwrap();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11 + looks as u64);
            let img: Vec<f32> = (0..nx * ny).map(|_| g.sample(&mut rng) as f32).collect();
            let p = CfarParams {
                pfa: 1e-3,
                guard_x_px: 2,
                guard_y_px: 2,
                train_px: 6,
                looks,
                pixels_per_cell: 1.0,
                known_floor: None,
            };
            let map = ca_cfar(&img, nx, ny, &p);
            let hits = map.hits.iter().filter(|h| **h).count() as f64;
            let want = 1e-3 * (nx * ny) as f64;
            assert!(
                hits > want / 2.0 && hits < want * 2.0,
                "L={looks}: {hits} vs {want}"
            );
        }
    }

    #[test]
    fn cluster_finds_peak() {
        let grid = Grid::square([0.0, 0.0], 10.0, 1.0);
        let (nx, ny) = (grid.nx, grid.ny);
        let mut img = vec![1f32; nx * ny];
        let c = 5 * nx + 7;
        img[c] = 100.0;
        img[c + 1] = 60.0;
        img[c - 1] = 50.0;
        let p = CfarParams {
            pfa: 1e-3,
            guard_x_px: 2,
            guard_y_px: 2,
            train_px: 3,
            looks: 1,
            pixels_per_cell: 1.0,
            known_floor: None,
        };
        let map = ca_cfar(&img, nx, ny, &p);
        let d = cluster(&img, &map, &grid, 2.0, 0, None);
        assert_eq!(d.len(), 1);
        assert!(
            (d[0].x_m - (grid.x(7) + 0.0555)).abs() < 0.01,
            "{}",
            d[0].x_m
        );
        assert!((d[0].y_m - grid.y(5)).abs() < 1e-9);
    }

    #[test]
    fn border_maxima_are_not_detections() {
        let grid = Grid::square([0.0, 0.0], 10.0, 1.0);
        let (nx, ny) = (grid.nx, grid.ny);
        // a response rising towards the left border (an object beyond the grid) and one
        // interior peak
        let mut img: Vec<f32> = (0..nx * ny)
            .map(|i| 1.0 + 400.0 * (-3.0 * (i % nx) as f32).exp())
            .collect();
        img[14 * nx + 15] = 300.0;
        let p = CfarParams {
            pfa: 1e-3,
            guard_x_px: 1,
            guard_y_px: 1,
            train_px: 3,
            looks: 1,
            pixels_per_cell: 1.0,
            known_floor: None,
        };
        let map = ca_cfar(&img, nx, ny, &p);
        assert!(
            (0..ny).any(|y| map.hits[y * nx]),
            "the border exceeds the threshold"
        );
        let d = cluster(&img, &map, &grid, 2.0, 0, None);
        assert_eq!(d.len(), 1, "{d:?}");
        assert!((d[0].x_m - grid.x(15)).abs() < 0.5 && (d[0].y_m - grid.y(14)).abs() < 0.5);
    }

    fn noise(nx: usize, ny: usize, looks: usize, floor: f64, seed: u64) -> Vec<f32> {
        let g = Gamma::new(looks as f64, floor / looks as f64).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..nx * ny).map(|_| g.sample(&mut rng) as f32).collect()
    }

    fn params(pfa: f64, guard: usize, train: usize, looks: usize) -> CfarParams {
        CfarParams {
            pfa,
            guard_x_px: guard,
            guard_y_px: guard,
            train_px: train,
            looks,
            pixels_per_cell: 1.0,
            known_floor: Some(1.0),
        }
    }

    /// Averaging the exceedance probability over the CA estimate's Gamma distribution gives
    /// back the closed-form CA P_fa: the averaging behind the design false-alarm count is right.
    #[test]
    fn averaging_over_the_estimate_reproduces_the_ca_pfa() {
        for looks in [1usize, 4, 10] {
            for n in [8.0, 30.0, 300.0, 1e5] {
                for pfa in [1e-2, 1e-4, 1e-6] {
                    let got = averaged_pfa(pfa, n, looks);
                    assert!(
                        (got / pfa - 1.0).abs() < 1e-3,
                        "L {looks} n {n} P_fa {pfa}: {got}"
                    );
                }
            }
        }
        // the censored mean of unit Gamma(L) noise
        for looks in [1usize, 10] {
            let c = unit_gamma_isf(looks, CENSOR_PFA);
            assert!((unit_gamma_sf(looks, c) / CENSOR_PFA - 1.0).abs() < 1e-9);
            let tau = censored_mean(looks, c);
            // E[X] = P(X < c) τ + P(X ≥ c) E[X | X ≥ c] = 1 with E[X | X ≥ c] > c
            assert!(tau < 1.0 && (1.0 - tau) * (1.0 - CENSOR_PFA) < CENSOR_PFA * (c + 1.0));
        }
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
    }

    /// The Euler-characteristic count of noise peaks above a fixed threshold, checked on
    /// simulated χ²_2L fields: 2L independent Gaussian fields with a Gaussian correlation of
    /// known curvature (periodic, so no borders), peaks counted as `cluster` counts them.
    #[test]
    fn euler_characteristic_count_matches_simulated_chi2_fields() {
        let (n, looks, sigma_px) = (255usize, 4usize, 2.5f64);
        // kernel k(x) ∝ e^{−x²/(2σ²)}, Σk² = 1 per axis: field correlation e^{−Δ²/(4σ²)},
        // whose curvature −ρ''(0) = 1/(2σ²) per axis: √det Λ = 1/(2σ²) per px²
        let half = (4.0 * sigma_px).ceil() as i64;
        let mut k: Vec<f64> = (-half..=half)
            .map(|x| (-(x as f64).powi(2) / (2.0 * sigma_px * sigma_px)).exp())
            .collect();
        let norm = k.iter().map(|v| v * v).sum::<f64>().sqrt();
        k.iter_mut().for_each(|v| *v /= norm);
        let curvature = 1.0 / (2.0 * sigma_px * sigma_px);
        let pfa = 1e-3;
        let threshold = unit_gamma_isf(looks, pfa);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let normal = rand_distr::StandardNormal;
        let (mut peaks, mut expected) = (0usize, 0.0);
        for _ in 0..6 {
            let mut img = vec![0f64; n * n];
            for _ in 0..2 * looks {
                let w: Vec<f64> = (0..n * n).map(|_| normal.sample(&mut rng)).collect();
                let conv = |src: &[f64], along_x: bool| -> Vec<f64> {
                    let mut out = vec![0f64; n * n];
                    for y in 0..n {
                        for x in 0..n {
                            let mut s = 0.0;
                            for (j, kv) in k.iter().enumerate() {
                                let o = j as i64 - half;
                                let (xx, yy) = if along_x {
                                    ((x as i64 + o).rem_euclid(n as i64) as usize, y)
                                } else {
                                    (x, (y as i64 + o).rem_euclid(n as i64) as usize)
                                };
                                s += kv * src[yy * n + xx];
                            }
                            out[y * n + x] = s;
                        }
                    }
                    out
                };
                let u = conv(&conv(&w, true), false);
                for (o, v) in img.iter_mut().zip(&u) {
                    *o += v * v / (2.0 * looks as f64);
                }
            }
            // a periodic field: count peaks one period in from a padded copy's border
            let m = n + 2;
            let padded: Vec<f32> = (0..m * m)
                .map(|i| {
                    let (x, y) = ((i % m + n - 1) % n, (i / m + n - 1) % n);
                    img[y * n + x] as f32
                })
                .collect();
            let pgrid = Grid::square([0.0, 0.0], (m as f64 - 1.0) / 2.0, 1.0);
            let map = CfarMap {
                hits: padded.iter().map(|v| *v as f64 >= threshold).collect(),
                noise: vec![1.0; m * m],
                fallback_pixels: 0,
                floor: 1.0,
                median_cells: 1e9,
            };
            peaks += cluster(&padded, &map, &pgrid, 0.5, 0, None).len();
            expected += (n * n) as f64 * expected_peaks_per_m2(pfa, 1e9, looks, curvature);
        }
        println!("peaks {peaks}, Euler characteristic {expected:.1}");
        assert!(expected > 40.0, "{expected}");
        assert!(
            (peaks as f64 - expected).abs() < 0.15 * expected + 3.0 * expected.sqrt(),
            "{peaks} peaks vs {expected:.1}"
        );
    }

    /// A long strong ridge next to a weak target lies in the target's training band: the
    /// censored mean ignores it (detected), the plain mean of the same cells would be raised by
    /// it tenfold (masked). On the noise around, the rate stays at the design.
    #[test]
    fn censoring_keeps_strong_ridges_out_of_the_training_cells() {
        let (nx, ny, looks) = (200usize, 200usize, 4usize);
        let mut img = noise(nx, ny, looks, 1.0, 3);
        for y in 0..ny {
            for x in 100..103 {
                img[y * nx + x] += 1e4;
            }
        }
        let target = 50 * nx + 110;
        img[target] = 30.0;
        let p = params(1e-3, 3, 16, looks);
        let map = ca_cfar(&img, nx, ny, &p);
        assert!(map.hits[target], "the weak target is masked");
        assert!((map.floor - 1.0).abs() < 0.05, "floor {}", map.floor);
        assert!(
            (map.noise[target] as f64 - 1.0).abs() < 0.2,
            "{}",
            map.noise[target]
        );
        // the plain training mean around the target (its band reaches the ridge)
        let (mut s, mut n) = (0.0, 0usize);
        for y in 50 - 19..=50 + 19 {
            for x in 110 - 19..=110 + 19 {
                if (y as i64 - 50).abs() > 3 || (x as i64 - 110).abs() > 3 {
                    s += img[y * nx + x] as f64;
                    n += 1;
                }
            }
        }
        assert!(s / n as f64 > 10.0, "plain mean {}", s / n as f64);
        // noise away from the ridge and the target
        let (mut hits, mut cells) = (0usize, 0usize);
        for y in 0..ny {
            for x in 0..60 {
                cells += 1;
                hits += map.hits[y * nx + x] as usize;
            }
        }
        let want = 1e-3 * cells as f64;
        assert!((hits as f64) < 3.0 * want + 5.0, "{hits} vs {want}");
    }

    /// A guard wider than the image leaves no training cells: every pixel is tested against
    /// the image-wide floor, and counted; a target is still detected, noise stays at the design.
    #[test]
    fn too_few_training_cells_fall_back_to_the_image_floor_and_are_counted() {
        let (nx, ny, looks) = (101usize, 101usize, 4usize);
        let mut img = noise(nx, ny, looks, 1.0, 4);
        img[50 * nx + 50] = 40.0;
        let map = ca_cfar(&img, nx, ny, &params(1e-3, 200, 16, looks));
        assert_eq!(map.fallback_pixels, nx * ny);
        assert!(map.hits[50 * nx + 50]);
        let hits = map.hits.iter().filter(|h| **h).count();
        assert!((2..40).contains(&hits), "{hits}");
        // a usual guard: no fallback
        let map = ca_cfar(&img, nx, ny, &params(1e-3, 3, 16, looks));
        assert_eq!(map.fallback_pixels, 0);
    }

    /// The image-wide floor: the censored mean's fixed point from the thermal floor follows a
    /// raised floor (2.5×, and 10⁴× from the median when nothing lies below the known floor's
    /// censoring level), and ignores targets' responses covering most of the image.
    #[test]
    fn the_image_floor_follows_the_noise_not_the_targets() {
        let (nx, ny, looks) = (200usize, 200usize, 10usize);
        let img = noise(nx, ny, looks, 2.5, 6);
        let (f, _) = image_floor(&img, looks, 1.0);
        assert!((f / 2.5 - 1.0).abs() < 0.02, "{f}");
        // a floor far above the known one (nothing below its censoring level): from the median
        let img: Vec<f32> = img.iter().map(|v| v * 4e3).collect();
        let map = ca_cfar(&img, nx, ny, &params(1e-3, 3, 16, looks));
        assert!((map.floor / 1e4 - 1.0).abs() < 0.02, "{}", map.floor);
        let hits = map.hits.iter().filter(|h| **h).count() as f64;
        assert!(hits < 3.0 * 1e-3 * (nx * ny) as f64, "{hits}");
        // ridges 1e2..1e5 over 80 % of the image
        let mut img = noise(nx, ny, looks, 1.0, 7);
        for (i, v) in img.iter_mut().enumerate() {
            let x = i % nx;
            if x % 10 < 8 {
                *v += 10f32.powf(2.0 + 3.0 * ((x as f32) * 0.37).sin().abs());
            }
        }
        let (f, kept) = image_floor(&img, looks, 1.0);
        assert!((f - 1.0).abs() < 0.03, "{f}");
        assert!(kept > nx * ny / 6, "{kept}");
        let median = {
            let mut v: Vec<f32> = img.clone();
            v.sort_by(f32::total_cmp);
            v[v.len() / 2]
        };
        assert!(median > 50.0, "the median would be {median}");
    }

    /// Non-maximum suppression between peaks: a distinct peak 12 m from a much stronger one,
    /// whose flank within ±10 m of it is higher than the peak itself, is kept (the old box
    /// suppression dropped it); a ripple on the strong peak's flank within 10 m is not.
    #[test]
    fn a_distinct_peak_beside_a_stronger_flank_is_kept() {
        let grid = Grid::square([0.0, 0.0], 30.0, 0.4);
        let (nx, ny) = (grid.nx, grid.ny);
        let mut img = noise(nx, ny, 4, 1.0, 8);
        let (ax, ay) = (75usize, 75usize);
        let bump = |img: &mut Vec<f32>, cx: f64, cy: f64, amp: f64, s: f64| {
            for y in 0..ny {
                for x in 0..nx {
                    let r2 = (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2);
                    img[y * nx + x] += (amp * (-r2 / (2.0 * s * s)).exp()) as f32;
                }
            }
        };
        // strong broad peak (σ = 4 m) and a weaker narrow one 12 m (30 px) along x
        bump(&mut img, ax as f64, ay as f64, 1e5, 10.0);
        bump(&mut img, ax as f64 + 30.0, ay as f64, 3e3, 1.5);
        // a ripple on the flank 5 m (12 px) from the strong peak along y
        bump(&mut img, ax as f64, ay as f64 + 12.0, 2e3, 1.5);
        let b = ay * nx + ax + 30;
        // the old suppression: some pixel within ±10 m (25 px) of B is higher than B
        let r = 25i64;
        let higher_in_box = (-r..=r).any(|dy| {
            (-r..=r).any(|dx| {
                let (x, y) = ((ax + 30) as i64 + dx, ay as i64 + dy);
                img[y as usize * nx + x as usize] > img[b]
            })
        });
        assert!(higher_in_box);
        let map = ca_cfar(&img, nx, ny, &params(1e-4, 3, 16, 4));
        let d = cluster(&img, &map, &grid, 10.0, 0, None);
        let near = |x: f64, y: f64| d.iter().any(|p| (p.x_m - x).hypot(p.y_m - y) < 1.0);
        assert!(near(grid.x(ax), grid.y(ay)), "{d:?}");
        assert!(
            near(grid.x(ax + 30), grid.y(ay)),
            "the distinct peak was suppressed: {d:?}"
        );
        assert_eq!(d.len(), 2, "{d:?}");
    }

    /// Sidelobe editing: a 50 dB point response with Hann sidelobes (azimuth cell 8 m: the
    /// first sidelobes 19 m away, 18 dB above the noise) gives sidelobe detections without the
    /// response model and none with it, while a 20 dB object in the range direction, 25 m away,
    /// is detected either way.
    #[test]
    fn sidelobes_of_a_strong_return_are_not_detections() {
        use crate::config::Weighting;
        let grid = Grid::square([0.0, 0.0], 50.0, 0.4);
        let (nx, ny) = (grid.nx, grid.ny);
        let looks = 10;
        let mut img = noise(nx, ny, looks, 1.0, 9);
        let (ar, aa) = ([1.0 / 1.2, 0.0], [0.1, 1.0 / 8.0]);
        let model = ResponseModel::new(vec![(ar, aa)], Weighting::Hann, Weighting::Hann);
        let put = |img: &mut Vec<f32>, c: [f64; 2], peak: f64| {
            for y in 0..ny {
                for x in 0..nx {
                    let d = [grid.x(x) - c[0], grid.y(y) - c[1]];
                    let ur = ar[0] * d[0] + ar[1] * d[1];
                    let ua = aa[0] * d[0] + aa[1] * d[1];
                    let a = Weighting::Hann.amplitude_response(ur)
                        * Weighting::Hann.amplitude_response(ua);
                    img[y * nx + x] += (peak * a * a) as f32;
                }
            }
        };
        put(&mut img, [0.0, 0.0], 1e5);
        put(&mut img, [25.0, -3.0], 1e2);
        let map = ca_cfar(&img, nx, ny, &params(1e-6, 8, 16, looks));
        let plain = cluster(&img, &map, &grid, 10.0, 0, None);
        let edited = cluster(&img, &map, &grid, 10.0, 0, Some(&model));
        let at =
            |d: &[Detection], x: f64, y: f64| d.iter().any(|p| (p.x_m - x).hypot(p.y_m - y) < 2.0);
        for d in [&plain, &edited] {
            assert!(at(d, 0.0, 0.0) && at(d, 25.0, -3.0), "{d:?}");
        }
        assert!(plain.len() > 2, "no sidelobe detections to edit: {plain:?}");
        assert_eq!(edited.len(), 2, "{edited:?}");
        // the envelope bounds the response and is 1 at the peak
        assert!((model.envelope([0.0, 0.0]) - 1.0).abs() < 1e-12);
        for k in 0..400 {
            let d = [0.37 * k as f64 - 70.0, 0.11 * k as f64 - 20.0];
            let ur = ar[0] * d[0] + ar[1] * d[1];
            let ua = aa[0] * d[0] + aa[1] * d[1];
            let p = (Weighting::Hann.amplitude_response(ur)
                * Weighting::Hann.amplitude_response(ua))
            .powi(2);
            assert!(model.envelope(d) >= p * (1.0 - 1e-9), "{d:?}");
        }
    }
}
