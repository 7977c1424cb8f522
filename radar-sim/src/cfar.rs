//! 2-D cell-averaging CFAR on an L-look power image, clustering of the exceedances, and the
//! detections (peak position with sub-pixel refinement, SNR).
//!
//! With unit-mean Gamma(L) noise in every pixel and the noise level estimated as the mean of N
//! independent training cells, the false-alarm probability of the threshold α·mean is
//! `P_fa = Σ_{k<L} C(NL+k−1, k) (α/N)^k (1 + α/N)^{−(NL+k)}`; α is solved from it by bisection.
//! Pixels of an oversampled image are correlated, so `N` is the number of training pixels
//! divided by the pixels per resolution cell (at least 8).

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
}

/// Output of the CFAR: the exceedance mask and the local noise estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct CfarMap {
    /// Per pixel: image ≥ α · noise.
    pub hits: Vec<bool>,
    /// Per pixel: the training-cell mean.
    pub noise: Vec<f32>,
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

/// Runs CA-CFAR with excision on a power image (ny × nx, row-major).
///
/// Pass 1 finds strong returns with a strict threshold (P_fa = min(design, 1e-5)); the guard
/// box around each is excised from the training cells of pass 2, so that neighbouring targets do
/// not raise each other's thresholds (masking). Pass 2 is the CA-CFAR at the design P_fa over the
/// remaining training cells, α solved for their effective number.
pub fn ca_cfar(img: &[f32], nx: usize, ny: usize, p: &CfarParams) -> CfarMap {
    let (gx, gy) = (p.guard_x_px as i64, p.guard_y_px as i64);
    let t = p.train_px as i64;
    let vals: Vec<f64> = img.iter().map(|v| *v as f64).collect();
    let mut alpha_cache: std::collections::HashMap<(usize, u64), f64> =
        std::collections::HashMap::new();
    let mut alpha_for = |n: usize, pfa: f64| -> f64 {
        *alpha_cache.entry((n, pfa.to_bits())).or_insert_with(|| {
            let n_eff = (n as f64 / p.pixels_per_cell.max(1.0)).max(1.0);
            ca_alpha(pfa, n_eff, p.looks)
        })
    };
    // one CA pass over (values, weights): returns per-pixel mean and training count
    let pass = |v: &[f64], keep: &[f64]| -> (Vec<f64>, Vec<usize>) {
        let weighted: Vec<f64> = v.iter().zip(keep).map(|(a, k)| a * k).collect();
        let sv = sat_of(&weighted, nx, ny);
        let sk = sat_of(keep, nx, ny);
        let mut mean = vec![0f64; nx * ny];
        let mut cnt = vec![0usize; nx * ny];
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
                cnt[i] = n;
                mean[i] = if n > 0 { (so - sg) / n as f64 } else { 0.0 };
            }
        }
        (mean, cnt)
    };
    let ones = vec![1f64; nx * ny];
    let (mean1, cnt1) = pass(&vals, &ones);
    let strict = p.pfa.min(1e-5);
    let strong: Vec<f64> = (0..nx * ny)
        .map(|i| {
            let hit = cnt1[i] > 0 && vals[i] >= alpha_for(cnt1[i], strict) * mean1[i];
            if hit {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    // excise the guard box around every strong return
    let ss = sat_of(&strong, nx, ny);
    let keep: Vec<f64> = (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            if box_sum(&ss, nx, ny, x - gx, y - gy, x + gx, y + gy) > 0.0 {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    let (mean2, cnt2) = pass(&vals, &keep);
    let mut hits = vec![false; nx * ny];
    let mut noise = vec![0f32; nx * ny];
    for i in 0..nx * ny {
        let (m, n) = if cnt2[i] > 0 {
            (mean2[i], cnt2[i])
        } else {
            (mean1[i], cnt1[i])
        };
        if n == 0 {
            continue;
        }
        noise[i] = m as f32;
        hits[i] = vals[i] >= alpha_for(n, p.pfa) * m;
    }
    CfarMap { hits, noise }
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

/// Turns exceedances into detections: every exceeding pixel that is the maximum of the image
/// within ±`merge_radius_m` (a box) is one detection (non-maximum suppression, so that two
/// objects whose exceedance regions touch stay two detections), at its sub-pixel peak;
/// `pixels` is the size of its 8-connected exceedance region. A maximum on the image border is
/// no detection: the response still rises towards the outside, so it belongs to an object
/// beyond the grid (its own image has it), and its position would be clamped to the border.
pub fn cluster(
    img: &[f32],
    map: &CfarMap,
    grid: &Grid,
    merge_radius_m: f64,
    aperture: usize,
) -> Vec<Detection> {
    let (nx, ny) = (grid.nx, grid.ny);
    // connected components (sizes)
    let mut label = vec![usize::MAX; nx * ny];
    let mut sizes: Vec<usize> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..nx * ny {
        if !map.hits[start] || label[start] != usize::MAX {
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
                    if map.hits[j] && label[j] == usize::MAX {
                        label[j] = id;
                        stack.push(j);
                    }
                }
            }
        }
        sizes.push(size);
    }
    let r = ((merge_radius_m / grid.spacing_m).round() as i64).max(1);
    let mut out = Vec::new();
    for i in 0..nx * ny {
        if !map.hits[i] {
            continue;
        }
        let (x, y) = ((i % nx) as i64, (i / nx) as i64);
        let v = img[i];
        let mut is_max = true;
        'outer: for yy in (y - r).max(0)..=(y + r).min(ny as i64 - 1) {
            for xx in (x - r).max(0)..=(x + r).min(nx as i64 - 1) {
                let j = yy as usize * nx + xx as usize;
                // strictly greater elsewhere, or equal at a lower index, suppresses this pixel
                if img[j] > v || (img[j] == v && j < i) {
                    is_max = false;
                    break 'outer;
                }
            }
        }
        if !is_max || x == 0 || y == 0 || x + 1 == nx as i64 || y + 1 == ny as i64 {
            continue;
        }
        let (xu, yu) = (x as usize, y as usize);
        let refine = |a: f32, b: f32, c: f32| -> f64 {
            let (a, b, c) = (a as f64, b as f64, c as f64);
            let den = a - 2.0 * b + c;
            if den < 0.0 {
                (0.5 * (a - c) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        };
        let fx = if xu > 0 && xu + 1 < nx {
            refine(img[i - 1], img[i], img[i + 1])
        } else {
            0.0
        };
        let fy = if yu > 0 && yu + 1 < ny {
            refine(img[i - nx], img[i], img[i + nx])
        } else {
            0.0
        };
        let noise = map.noise[i].max(f32::MIN_POSITIVE) as f64;
        out.push(Detection {
            aperture,
            x_m: grid.x(xu) + fx * grid.spacing_m,
            y_m: grid.y(yu) + fy * grid.spacing_m,
            snr_db: 10.0 * (v as f64 / noise).log10(),
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
        };
        let map = ca_cfar(&img, nx, ny, &p);
        let d = cluster(&img, &map, &grid, 2.0, 0);
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
        };
        let map = ca_cfar(&img, nx, ny, &p);
        assert!(
            (0..ny).any(|y| map.hits[y * nx]),
            "the border exceeds the threshold"
        );
        let d = cluster(&img, &map, &grid, 2.0, 0);
        assert_eq!(d.len(), 1, "{d:?}");
        assert!((d[0].x_m - grid.x(15)).abs() < 0.5 && (d[0].y_m - grid.y(14)).abs() < 0.5);
    }
}
