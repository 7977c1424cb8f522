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
    let (mut lo, mut hi) = (1e-6, 1e6);
    for _ in 0..200 {
        let mid = (lo * hi as f64).sqrt();
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
    /// Guard half-width, pixels.
    pub guard_px: usize,
    /// Training band width, pixels.
    pub train_px: usize,
    /// Looks averaged in the image.
    pub looks: usize,
    /// Pixels per independent resolution cell (≥ 1).
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

/// Runs CA-CFAR on a power image (ny × nx, row-major).
pub fn ca_cfar(img: &[f32], nx: usize, ny: usize, p: &CfarParams) -> CfarMap {
    // summed-area table
    let w = nx + 1;
    let mut sat = vec![0f64; (ny + 1) * w];
    for y in 0..ny {
        let mut row = 0.0;
        for x in 0..nx {
            row += img[y * nx + x] as f64;
            sat[(y + 1) * w + x + 1] = sat[y * w + x + 1] + row;
        }
    }
    let rect = |x0: i64, y0: i64, x1: i64, y1: i64| -> (f64, usize) {
        // inclusive bounds clipped to the image
        let x0 = x0.max(0) as usize;
        let y0 = y0.max(0) as usize;
        let x1 = (x1.min(nx as i64 - 1)) as usize;
        let y1 = (y1.min(ny as i64 - 1)) as usize;
        if x1 < x0 || y1 < y0 {
            return (0.0, 0);
        }
        let s = sat[(y1 + 1) * w + x1 + 1] - sat[y0 * w + x1 + 1] - sat[(y1 + 1) * w + x0]
            + sat[y0 * w + x0];
        (s, (x1 - x0 + 1) * (y1 - y0 + 1))
    };
    let g = p.guard_px as i64;
    let o = (p.guard_px + p.train_px) as i64;
    let mut hits = vec![false; nx * ny];
    let mut noise = vec![0f32; nx * ny];
    let mut alpha_cache: std::collections::HashMap<usize, f64> = std::collections::HashMap::new();
    for y in 0..ny as i64 {
        for x in 0..nx as i64 {
            let (so, no) = rect(x - o, y - o, x + o, y + o);
            let (sg, ng) = rect(x - g, y - g, x + g, y + g);
            let n = no - ng;
            if n == 0 {
                continue;
            }
            let mean = (so - sg) / n as f64;
            let alpha = *alpha_cache.entry(n).or_insert_with(|| {
                let n_eff = (n as f64 / p.pixels_per_cell.max(1.0)).max(8.0);
                ca_alpha(p.pfa, n_eff, p.looks)
            });
            let i = (y as usize) * nx + x as usize;
            noise[i] = mean as f32;
            hits[i] = img[i] as f64 >= alpha * mean;
        }
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

/// Groups exceedances into 8-connected components, merges components whose peaks lie within
/// `merge_radius_m`, and returns one detection per cluster at its (sub-pixel) peak.
pub fn cluster(
    img: &[f32],
    map: &CfarMap,
    grid: &Grid,
    merge_radius_m: f64,
    aperture: usize,
) -> Vec<Detection> {
    let (nx, ny) = (grid.nx, grid.ny);
    let mut label = vec![usize::MAX; nx * ny];
    let mut comps: Vec<(usize, usize)> = Vec::new(); // (peak pixel, size)
    let mut stack = Vec::new();
    for start in 0..nx * ny {
        if !map.hits[start] || label[start] != usize::MAX {
            continue;
        }
        let id = comps.len();
        label[start] = id;
        stack.push(start);
        let (mut peak, mut size) = (start, 0usize);
        while let Some(i) = stack.pop() {
            size += 1;
            if img[i] > img[peak] {
                peak = i;
            }
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
        comps.push((peak, size));
    }
    // merge: strongest first, absorb weaker peaks within the radius
    let mut order: Vec<usize> = (0..comps.len()).collect();
    order.sort_by(|a, b| img[comps[*b].0].total_cmp(&img[comps[*a].0]));
    let mut taken = vec![false; comps.len()];
    let pos = |i: usize| [grid.x(i % nx), grid.y(i / nx)];
    let mut out = Vec::new();
    for (oi, &c) in order.iter().enumerate() {
        if taken[c] {
            continue;
        }
        taken[c] = true;
        let (peak, mut size) = comps[c];
        let pp = pos(peak);
        for &d in &order[oi + 1..] {
            if !taken[d] {
                let q = pos(comps[d].0);
                if (q[0] - pp[0]).hypot(q[1] - pp[1]) <= merge_radius_m {
                    taken[d] = true;
                    size += comps[d].1;
                }
            }
        }
        // sub-pixel refinement: parabola through the peak and its neighbours in x and y
        let (x, y) = (peak % nx, peak / nx);
        let refine = |a: f32, b: f32, c: f32| -> f64 {
            let (a, b, c) = (a as f64, b as f64, c as f64);
            let den = a - 2.0 * b + c;
            if den < 0.0 {
                (0.5 * (a - c) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        };
        let fx = if x > 0 && x + 1 < nx {
            refine(img[peak - 1], img[peak], img[peak + 1])
        } else {
            0.0
        };
        let fy = if y > 0 && y + 1 < ny {
            refine(img[peak - nx], img[peak], img[peak + nx])
        } else {
            0.0
        };
        let noise = map.noise[peak].max(f32::MIN_POSITIVE) as f64;
        out.push(Detection {
            aperture,
            x_m: pp[0] + fx * grid.spacing_m,
            y_m: pp[1] + fy * grid.spacing_m,
            snr_db: 10.0 * (img[peak] as f64 / noise).log10(),
            pixels: size,
        });
    }
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
            let p = CfarParams { pfa: 1e-3, guard_px: 2, train_px: 6, looks, pixels_per_cell: 1.0 };
            let map = ca_cfar(&img, nx, ny, &p);
            let hits = map.hits.iter().filter(|h| **h).count() as f64;
            let want = 1e-3 * (nx * ny) as f64;
            assert!(hits > want / 2.0 && hits < want * 2.0, "L={looks}: {hits} vs {want}");
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
        let p = CfarParams { pfa: 1e-3, guard_px: 2, train_px: 3, looks: 1, pixels_per_cell: 1.0 };
        let map = ca_cfar(&img, nx, ny, &p);
        let d = cluster(&img, &map, &grid, 2.0, 0);
        assert_eq!(d.len(), 1);
        assert!((d[0].x_m - (grid.x(7) + 0.0555)).abs() < 0.01, "{}", d[0].x_m);
        assert!((d[0].y_m - grid.y(5)).abs() < 1e-9);
    }
}
