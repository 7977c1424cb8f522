//! Tests of [`super`].

use super::kernel::sincos_2pi;
use super::*;
use rand::{Rng, SeedableRng};

#[test]
fn sincos_accuracy() {
    for k in 0..=1000 {
        let f = -0.5 + k as f32 / 1000.0;
        let (s, c) = sincos_2pi(f);
        let a = std::f64::consts::TAU * f as f64;
        assert!((s as f64 - a.sin()).abs() < 3e-7, "{f}");
        assert!((c as f64 - a.cos()).abs() < 3e-7, "{f}");
    }
}

#[test]
fn delay_bounds_contain_every_pixel() {
    let geom = BpGeometry {
        bs_m: [1000.0, -1000.0, 50.0],
        fs_hz: 245.76e6,
        upsample: 8,
        wavelength_m: 0.1,
    };
    let grid = Grid::square([0.0, 0.0], 60.0, 1.5);
    for uav in [
        [-1000.0, 0.0, 1000.0],
        [0.0, 1000.0, 1000.0],
        [30.0, -40.0, 1000.0],
    ] {
        let (lo, hi) = geom.delay_bounds(&grid, uav, 100);
        for iy in 0..grid.ny {
            for ix in 0..grid.nx {
                let d = geom.delay_samples([grid.x(ix), grid.y(iy)], uav, 100);
                assert!(d >= lo - 1e-9 && d <= hi + 1e-9);
            }
        }
    }
}

fn setup(
    grid: &Grid,
    npulses: usize,
    seed: u64,
) -> (BpGeometry, Vec<BpPulse>, Vec<Complex32>, usize) {
    let geom = BpGeometry {
        bs_m: [1000.0, -1000.0, 50.0],
        fs_hz: 245.76e6,
        upsample: 8,
        wavelength_m: 0.1,
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let raw: Vec<([f64; 3], i64)> = (0..npulses)
        .map(|n| {
            let pos = [
                grid.centre_m[0] - 1000.0 + rng.gen_range(-1.0..1.0),
                grid.centre_m[1] - 10.0 + 0.2 * n as f64,
                1000.0,
            ];
            let d = (dist3(pos, geom.bs_m) * geom.fs_hz / C_MPS).floor() as i64;
            (pos, d)
        })
        .collect();
    let (j0s, m) = profile_windows(&geom, grid, &raw);
    let pulses: Vec<BpPulse> = raw
        .iter()
        .zip(&j0s)
        .enumerate()
        .map(|(n, (&(pos, d), &j0))| BpPulse {
            pos_m: pos,
            window_delay_samples: d,
            j0,
            weight: 0.5 + (n % 3) as f32 * 0.25,
        })
        .collect();
    // smooth random profiles (band-limited like real ones): sum of a few complex tones
    let profiles: Vec<Complex32> = (0..pulses.len() * m)
        .map(|k| {
            let j = (k % m) as f32;
            let ph = 0.05 * j + 0.3 * (k / m) as f32;
            Complex32::new((ph).cos() + 0.5 * (0.11 * j).sin(), (ph).sin())
        })
        .collect();
    (geom, pulses, profiles, m)
}

fn all_points(grid: &Grid) -> Vec<[f64; 2]> {
    (0..grid.ny)
        .flat_map(|iy| (0..grid.nx).map(move |ix| (ix, iy)))
        .map(|(ix, iy)| [grid.x(ix), grid.y(iy)])
        .collect()
}

/// Random profiles, realistic geometry: both f32 tiled kernels match the f64 reference,
/// on grids whose sizes are not multiples of the tile (edge tiles, padded columns).
#[test]
fn image_ser_against_f64_reference() {
    let grids = [
        Grid::square([0.0, 0.0], 20.0, 0.4),
        Grid {
            centre_m: [300.0, 120.0],
            spacing_m: 0.7,
            nx: 37,
            ny: 5,
        },
        Grid {
            centre_m: [-50.0, 20.0],
            spacing_m: 0.25,
            nx: 3,
            ny: 70,
        },
    ];
    for (gi, grid) in grids.iter().enumerate() {
        let (geom, pulses, profiles, m) = setup(grid, 40, 3 + gi as u64);
        let reference =
            backproject_reference(&geom, &all_points(grid), &pulses, &profiles, m).unwrap();
        for kernel in [Kernel::Auto, Kernel::Portable] {
            for tile in [32, 7] {
                let opts = BpOptions {
                    tile,
                    pulse_block: 16,
                    kernel,
                };
                let img = backproject_with(&geom, grid, &pulses, &profiles, m, &opts).unwrap();
                assert_eq!(img.len(), grid.pixels());
                let ser = ser_db(&img, &reference);
                assert!(
                    ser >= 60.0,
                    "grid {gi} {kernel:?} tile {tile}: SER {ser} dB"
                );
            }
        }
    }
}

/// A point response: a profile that is one sinc-like bump puts the image peak at the pixel
/// whose bistatic delay matches, with the summed weights as its magnitude.
#[test]
fn matched_pixel_collects_every_pulse() {
    let grid = Grid::square([0.0, 0.0], 6.0, 0.5);
    let (geom, pulses, _, m) = setup(&grid, 20, 9);
    let target = [grid.x(5), grid.y(17)];
    let u = geom.upsample as f64;
    let mut profiles = vec![Complex32::new(0.0, 0.0); pulses.len() * m];
    for (n, p) in pulses.iter().enumerate() {
        let r = geom.bistatic_range_m(target, p.pos_m);
        let x = (r * geom.fs_hz / C_MPS - p.window_delay_samples as f64) * u - p.j0 as f64;
        // a smooth bump centred on x, carrier phase removed so that the pixel sums in phase
        let cyc = r / geom.wavelength_m;
        let ph = Complex32::from_polar(1.0, -(std::f64::consts::TAU * (cyc - cyc.floor())) as f32);
        for k in 0..m {
            let t = (k as f64 - x) / (2.0 * u);
            profiles[n * m + k] = ph * (-(t * t)).exp() as f32;
        }
    }
    for kernel in [Kernel::Auto, Kernel::Portable] {
        let opts = BpOptions {
            kernel,
            ..BpOptions::default()
        };
        let img = backproject_with(&geom, &grid, &pulses, &profiles, m, &opts).unwrap();
        let (best, v) = img
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
            .unwrap();
        assert_eq!(best, 17 * grid.nx + 5, "{kernel:?}");
        let wsum: f32 = pulses.iter().map(|p| p.weight).sum();
        assert!(
            (v.norm() / wsum - 1.0).abs() < 0.01,
            "{kernel:?}: {} vs {wsum}",
            v.norm()
        );
    }
}

#[test]
fn bad_inputs_are_named() {
    let grid = Grid::square([0.0, 0.0], 2.0, 0.5);
    let (geom, mut pulses, profiles, m) = setup(&grid, 4, 1);
    let e = backproject(&geom, &grid, &pulses, &profiles[1..], m, 32).unwrap_err();
    assert!(e.to_string().contains("profiles"), "{e}");
    pulses[2].pos_m[1] = f64::NAN;
    let e = backproject(&geom, &grid, &pulses, &profiles, m, 32).unwrap_err();
    assert!(e.to_string().contains("pulse 2"), "{e}");
    let e = backproject(&geom, &grid, &pulses[..1], &profiles[..1], 1, 32).unwrap_err();
    assert!(e.to_string().contains("profile length"), "{e}");
}
