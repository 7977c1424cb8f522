//! Tests of [`super`].

use super::*;
use crate::backproject::Grid;
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
            threshold: vec![threshold as f32; m * m],
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
                let a =
                    Weighting::Hann.amplitude_response(ur) * Weighting::Hann.amplitude_response(ua);
                img[y * nx + x] += (peak * a * a) as f32;
            }
        }
    };
    put(&mut img, [0.0, 0.0], 1e5);
    put(&mut img, [25.0, -3.0], 1e2);
    let map = ca_cfar(&img, nx, ny, &params(1e-6, 8, 16, looks));
    let plain = cluster(&img, &map, &grid, 10.0, 0, None);
    let edited = cluster(&img, &map, &grid, 10.0, 0, Some(&model));
    let at = |d: &[Detection], x: f64, y: f64| d.iter().any(|p| (p.x_m - x).hypot(p.y_m - y) < 2.0);
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
        let p = (Weighting::Hann.amplitude_response(ur) * Weighting::Hann.amplitude_response(ua))
            .powi(2);
        assert!(model.envelope(d) >= p * (1.0 - 1e-9), "{d:?}");
    }
}

/// Clutter 15–25 dB above the known thermal floor with a 10 dB level ramp across the image,
/// and a guard so wide (big resolution cells) that no pixel has enough training cells beyond
/// it: the pixels' thresholds follow the local clutter level (censoring against it, a local
/// mean without guard), so the exceedance rate stays near its design, where the image-wide
/// level of a background taken for noise puts the bright side far above it.
#[test]
fn thresholds_follow_a_clutter_ramp() {
    let (nx, ny, looks, pfa) = (240usize, 240usize, 4usize, 1e-3);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let g = Gamma::new(looks as f64, 1.0 / looks as f64).unwrap();
    let img: Vec<f32> = (0..nx * ny)
        .map(|i| {
            let level = 30.0 * 10f64.powf(1.0 * (i % nx) as f64 / (nx - 1) as f64);
            (level * g.sample(&mut rng)) as f32
        })
        .collect();
    // the guard covers the image: every pixel lacks training cells beyond it
    let mut p = params(pfa, nx, 3, looks);
    p.pixels_per_cell = 100.0;
    let map = ca_cfar(&img, nx, ny, &p);
    let hits = map.hits.iter().filter(|h| **h).count() as f64;
    let want = pfa * (nx * ny) as f64;
    assert!(map.floor > CLUTTER_FLOOR_RATIO, "floor {}", map.floor);
    assert_eq!(map.fallback_pixels, 0, "no pixel uses the image-wide level");
    // the image-wide level of a noise background: the bright side exceeds it
    p.known_floor = None;
    let noise_like = ca_cfar(&img, nx, ny, &p);
    let noise_hits = noise_like.hits.iter().filter(|h| **h).count() as f64;
    println!("clutter ramp: {hits} exceedances (design {want:.1}); as noise: {noise_hits}");
    assert!(hits <= 2.0 * want && hits >= want / 4.0, "{hits} vs {want}");
    assert!(
        noise_hits > 20.0 * want,
        "{noise_hits}: the test does not discriminate"
    );
}
