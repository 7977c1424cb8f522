//! Backprojection kernel timing on synthetic band-limited profiles (no synthesis, no NumPy):
//! wall-clock and CPU-time throughput of each kernel, median over repetitions, with the image
//! SER against the f64 reference.
//! Run: `cargo run --release -p radar-sim --example bp_kernel [-- PULSES REPS THREADS]`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Instant;

use radar_sim::backproject::{
    backproject_reference, backproject_with, profile_windows, ser_db, BpGeometry, BpOptions,
    BpPulse, Grid, Kernel,
};
use radar_sim::cputime::{load_average, process_cpu_s};
use rustfft::num_complex::Complex32;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let npulses: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(400);
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(7);
    let threads: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| run(npulses, reps));
}

fn run(npulses: usize, reps: usize) {
    let geom = BpGeometry {
        bs_m: [1000.0, -1000.0, 50.0],
        fs_hz: 245.76e6,
        upsample: 8,
        wavelength_m: 0.1,
    };
    let grid = Grid::square([0.0, 0.0], 50.0, 0.4);
    // UAV flying north at x = −1000 m, 20 m/s, 100 Hz
    let raw: Vec<([f64; 3], i64)> = (0..npulses)
        .map(|n| {
            let pos = [-1000.0, -0.1 * npulses as f64 + 0.2 * n as f64, 1000.0];
            let d = (radar_sim::track::dist3(pos, geom.bs_m) * geom.fs_hz
                / radar_sim::waveform::C_MPS)
                .floor() as i64;
            (pos, d)
        })
        .collect();
    let (j0s, m) = profile_windows(&geom, &grid, &raw);
    let pulses: Vec<BpPulse> = raw
        .iter()
        .zip(&j0s)
        .map(|(&(pos, d), &j0)| BpPulse {
            pos_m: pos,
            window_delay_samples: d,
            j0,
            weight: 1.0,
        })
        .collect();
    let profiles: Vec<Complex32> = (0..pulses.len() * m)
        .map(|k| {
            let j = (k % m) as f32;
            let ph = 0.05 * j + 0.3 * (k / m) as f32;
            Complex32::new(ph.cos() + 0.5 * (0.11 * j).sin(), ph.sin())
        })
        .collect();
    let work = (grid.pixels() * pulses.len()) as f64;
    println!(
        "grid {} × {} px, {} pulses, profile {} samples, {} threads, load average {}",
        grid.nx,
        grid.ny,
        pulses.len(),
        m,
        rayon::current_num_threads(),
        load_average()
    );
    let idx: Vec<usize> = (0..grid.pixels()).step_by(17).collect();
    let pts: Vec<[f64; 2]> = idx
        .iter()
        .map(|&i| [grid.x(i % grid.nx), grid.y(i / grid.nx)])
        .collect();
    let reference = backproject_reference(&geom, &pts, &pulses, &profiles, m).unwrap();
    for kernel in [Kernel::Auto, Kernel::Portable] {
        let opts = BpOptions {
            kernel,
            ..BpOptions::default()
        };
        let mut walls = Vec::new();
        let mut cpus = Vec::new();
        let mut img = Vec::new();
        for _ in 0..reps {
            let c0 = process_cpu_s();
            let t = Instant::now();
            img = backproject_with(&geom, &grid, &pulses, &profiles, m, &opts).unwrap();
            walls.push(t.elapsed().as_secs_f64());
            cpus.push(process_cpu_s() - c0);
        }
        walls.sort_by(f64::total_cmp);
        cpus.sort_by(f64::total_cmp);
        let (w, c) = (walls[reps / 2], cpus[reps / 2]);
        let best = walls[0];
        let sub: Vec<Complex32> = idx.iter().map(|&i| img[i]).collect();
        println!(
            "{kernel:?}: median {:.4} s wall = {:.3e} pixel-pulses/s (best {:.3e}); {:.4} CPU-s = {:.3e} per CPU-second; SER {:.1} dB",
            w,
            work / w,
            work / best,
            c,
            work / c,
            ser_db(&sub, &reference)
        );
    }
}
