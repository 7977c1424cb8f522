//! The censored cell-averaging CFAR itself ([`ca_cfar`]): training-cell sums over summed-area
//! tables, censoring against the image-wide floor, thresholds per pixel.

use serde::{Deserialize, Serialize};

use super::stats::{ca_alpha, censored_mean, image_floor, unit_gamma_isf};
use super::{CENSOR_PFA, MIN_TRAINING_CELLS};

/// A known thermal floor this many times below the image-wide floor marks a clutter background
/// (10 dB): [`ca_cfar`] then censors against the local level and tests the pixels without enough
/// training cells beyond their guard against a local mean without guard instead of the
/// image-wide one.
pub const CLUTTER_FLOOR_RATIO: f64 = 10.0;

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
    /// Per pixel: the threshold α · noise it was tested against.
    pub threshold: Vec<f32>,
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
    let looks = p.looks.max(1);
    let ppc = p.pixels_per_cell.max(1.0);
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
    let global = Global {
        mean: global,
        alpha: alpha_global,
        cells: n_global,
    };
    // a background far above the thermal floor is clutter (or interference), whose level
    // varies across the image: censor against the local level (the uncensored local mean,
    // then the censored one) and give the pixels without enough training cells beyond their
    // guard a local mean without guard
    let clutter = matches!(p.known_floor, Some(f) if f > 0.0 && floor > CLUTTER_FLOOR_RATIO * f);
    let pass = if clutter {
        // the local level: first uncensored, then twice censored against the previous pass
        let finite: Vec<f64> = vals
            .iter()
            .map(|v| if v.is_finite() { 1.0 } else { 0.0 })
            .collect();
        let mut pass = train_and_test(&vals, &finite, nx, ny, p, 1.0, global, true);
        for _ in 0..2 {
            let keep: Vec<f64> = vals
                .iter()
                .zip(&pass.noise)
                .map(|(v, m)| {
                    if v.is_finite() && *v < c * f64::from(*m).max(f64::MIN_POSITIVE) {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect();
            pass = train_and_test(&vals, &keep, nx, ny, p, tau, global, true);
        }
        pass
    } else {
        train_and_test(&vals, &keep, nx, ny, p, tau, global, false)
    };
    let Pass {
        hits,
        noise,
        threshold,
        mut cells,
        fallback,
    } = pass;
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
        threshold,
        fallback_pixels: fallback,
        floor,
        median_cells,
    }
}

/// The image-wide estimate: the censored mean, its α and its independent cells.
#[derive(Debug, Clone, Copy)]
struct Global {
    mean: f64,
    alpha: f64,
    cells: f64,
}

/// One training-and-test pass of [`ca_cfar`].
struct Pass {
    hits: Vec<bool>,
    noise: Vec<f32>,
    threshold: Vec<f32>,
    cells: Vec<f64>,
    fallback: usize,
}

/// The CA threshold of every pixel from the training pixels `keep` marks (1) of `vals`: the
/// mean of the kept pixels in the band around its guard box over `tau`; with fewer than
/// [`MIN_TRAINING_CELLS`] there, `global`, or with `box_fallback` the mean of the kept pixels of
/// the box of about 4 × [`MIN_TRAINING_CELLS`] coherence areas around it (no guard) where that
/// has enough.
#[allow(clippy::too_many_arguments)]
fn train_and_test(
    vals: &[f64],
    keep: &[f64],
    nx: usize,
    ny: usize,
    p: &CfarParams,
    tau: f64,
    global: Global,
    box_fallback: bool,
) -> Pass {
    let npx = nx * ny;
    let looks = p.looks.max(1);
    let ppc = p.pixels_per_cell.max(1.0);
    let (gx, gy) = (p.guard_x_px as i64, p.guard_y_px as i64);
    let t = p.train_px as i64;
    let kept: Vec<f64> = vals.iter().zip(keep).map(|(v, k)| v * k).collect();
    let sv = sat_of(&kept, nx, ny);
    let sk = sat_of(keep, nx, ny);
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
    // the fallback box: about 4 × MIN_TRAINING_CELLS coherence areas around the pixel
    let local = box_fallback
        .then(|| ((4.0 * MIN_TRAINING_CELLS * ppc).sqrt() / 2.0).ceil() as i64)
        .filter(|h| *h > 0);
    let mut hits = vec![false; npx];
    let mut noise = vec![0f32; npx];
    let mut threshold = vec![0f32; npx];
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
            } else if let Some((m, n_box)) = local.filter(|_| box_fallback).and_then(|h| {
                let (lx0, lx1) = shift(x, h, nx as i64);
                let (ly0, ly1) = shift(y, h, ny as i64);
                let nb = box_sum(&sk, nx, ny, lx0, ly0, lx1, ly1).round().max(0.0) as usize;
                let sb = box_sum(&sv, nx, ny, lx0, ly0, lx1, ly1);
                (nb as f64 / ppc >= MIN_TRAINING_CELLS).then(|| (sb.max(0.0) / nb as f64 / tau, nb))
            }) {
                let a = *alpha_cache
                    .entry(n_box)
                    .or_insert_with(|| ca_alpha(p.pfa, n_box as f64 / ppc, looks));
                (m, a * m, n_box as f64 / ppc)
            } else {
                fallback += 1;
                (global.mean, global.alpha * global.mean, global.cells)
            };
            noise[i] = m as f32;
            threshold[i] = thr as f32;
            hits[i] = vals[i].is_finite() && vals[i] >= thr;
            cells.push(cells_used);
        }
    }
    Pass {
        hits,
        noise,
        threshold,
        cells,
        fallback,
    }
}
