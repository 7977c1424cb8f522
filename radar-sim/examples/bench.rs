//! Throughput benchmarks of the hot loops, with a straightforward NumPy implementation of the
//! same steps measured in the same run (`radar-sim/bench/numpy_bench.py`, needs python3 +
//! numpy). Run: `cargo run --release -p radar-sim --example bench [-- --quick]`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Instant;

use radar_sim::backproject::{backproject, backproject_reference, ser_db, BpPulse};
use radar_sim::config::SceneFile;
use radar_sim::io::{write_json, NpyType, NpyWriter};
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::synth::Components;
use radar_sim::track::{plan_apertures, plan_pulses, LinearTrack};
use rustfft::num_complex::Complex64;

/// CPU seconds used by this process so far (user + system, from /proc/self/stat; 0 elsewhere).
fn cpu_s() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|t| {
            let after = t.rsplit_once(')')?.1.split_whitespace().collect::<Vec<_>>();
            let u: f64 = after.get(11)?.parse().ok()?;
            let s: f64 = after.get(12)?.parse().ok()?;
            Some((u + s) / 100.0)
        })
        .unwrap_or(0.0)
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let params = planner::Params::default();
    let scene = SceneFile::default();
    let setup = RadarSetup::new(&params, &scene).unwrap();
    let proc = Processor::new(setup.clone()).unwrap();
    let threads = rayon::current_num_threads();
    println!(
        "threads: {threads}; numerology: N = {}, N_sc = {}, f_s = {:.2} MHz",
        setup.num.fft_size,
        setup.num.subcarriers,
        setup.num.sample_rate_hz() / 1e6
    );

    // --- scene and pulses: UAV flying south at x = 1000 m, landmark at the origin
    let track = LinearTrack {
        start_m: [1000.0, 10.0, 1000.0],
        velocity_mps: [0.0, -20.0, 0.0],
    };
    let looks = if quick { 1 } else { 10 };
    let ap = plan_apertures(&[([0.0, 0.0], Some(0), 0.0, looks as f64)], 1.0, 100.0)
        .unwrap()
        .remove(0);
    let pulses = plan_pulses(&track, &setup.num, setup.bs_m, &ap, 100.0);
    let objects: Vec<SceneObject> = (0..50)
        .map(|i| SceneObject {
            id: i,
            x_m: -60.0 + 2.4 * i as f64,
            y_m: 40.0 * ((i * 7 % 11) as f64 / 11.0 - 0.5),
            rcs_m2: 5.0,
            phase_rad: i as f64,
            landmark: None,
        })
        .collect();
    let synth = setup.synthesizer(objects).unwrap();

    // --- synthesis
    let t = Instant::now();
    let iq = synth.synthesize_frame(&pulses, Components::ALL).unwrap();
    let dt_synth = t.elapsed().as_secs_f64();
    let synth_rate = (pulses.len() * synth.samples_per_pulse()) as f64 / dt_synth;
    println!(
        "synthesis: {} pulses × {} samples, 51 paths: {:.3} s = {:.3e} samples/s",
        pulses.len(),
        synth.samples_per_pulse(),
        dt_synth,
        synth_rate
    );

    // --- cancellation + compression
    let grid = setup.grid(&ap);
    let t = Instant::now();
    let c = proc
        .compress(
            &grid,
            &pulses,
            &iq,
            ap.pulses_per_look,
            Some(ap.centre_m),
            false,
        )
        .unwrap();
    let dt_comp = t.elapsed().as_secs_f64();
    println!("cancellation (ECA-B, 1 pulse/batch, {} taps) + range compression + ×{} profile: {:.3} s = {:.1} µs per pulse (batch)", scene.processing.taps_before + scene.processing.taps_after, scene.processing.upsample, dt_comp, 1e6 * dt_comp / pulses.len() as f64);
    let one: Vec<_> = pulses[..1].to_vec();
    let n = setup.num.fft_size;
    let t = Instant::now();
    let reps = 50;
    for _ in 0..reps {
        let _ = proc
            .compress(
                &grid,
                &one,
                &iq[..n],
                ap.pulses_per_look,
                Some(ap.centre_m),
                false,
            )
            .unwrap();
    }
    let dt_one = t.elapsed().as_secs_f64() / reps as f64;
    println!("  single pulse, single thread: {:.1} µs", 1e6 * dt_one);

    // --- backprojection: all pulses of the aperture onto the 251 × 251 grid
    let geom = setup.geometry();
    let t = Instant::now();
    let c0 = cpu_s();
    let mut img = Vec::new();
    let reps_bp = if quick { 5 } else { 3 };
    for _ in 0..reps_bp {
        img = backproject(&geom, &grid, &c.pulses, &c.profiles, c.m, 32).unwrap();
    }
    let dt_bp = t.elapsed().as_secs_f64() / reps_bp as f64;
    let cpu_bp = (cpu_s() - c0) / reps_bp as f64;
    let bp_rate = (grid.pixels() * c.pulses.len()) as f64 / dt_bp;
    let per_cpu = (grid.pixels() * c.pulses.len()) as f64 / cpu_bp.max(1e-9);
    println!("backprojection: {} px × {} pulses: {:.3} s wall = {:.3e} pixel-pulses/s; {:.3} CPU-s = {:.3e} pixel-pulses per CPU-second ({:.3e}/s on {threads} idle cores)", grid.pixels(), c.pulses.len(), dt_bp, bp_rate, cpu_bp, per_cpu, per_cpu * threads as f64);
    // accuracy: f64 reference at a subset of pixels
    let idx: Vec<usize> = (0..grid.pixels()).step_by(31).collect();
    let pts: Vec<[f64; 2]> = idx
        .iter()
        .map(|&i| [grid.x(i % grid.nx), grid.y(i / grid.nx)])
        .collect();
    let reference = backproject_reference(&geom, &pts, &c.pulses, &c.profiles, c.m).unwrap();
    let sub: Vec<_> = idx.iter().map(|&i| img[i]).collect();
    let ser = ser_db(&sub, &reference);
    println!("  image SER against the f64 reference: {ser:.1} dB");

    // --- NumPy, same inputs
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut w =
        NpyWriter::create(&d.join("profiles.npy"), NpyType::C8, &[c.pulses.len(), c.m]).unwrap();
    w.write_c8(&c.profiles).unwrap();
    w.finish().unwrap();
    let mut w =
        NpyWriter::create(&d.join("pulses.npy"), NpyType::F8, &[c.pulses.len(), 6]).unwrap();
    let flat: Vec<f64> = c
        .pulses
        .iter()
        .flat_map(|p: &BpPulse| {
            [
                p.pos_m[0],
                p.pos_m[1],
                p.pos_m[2],
                p.window_delay_samples as f64,
                p.j0 as f64,
                p.weight as f64,
            ]
        })
        .collect();
    w.write_f8(&flat).unwrap();
    w.finish().unwrap();
    let np_pulses = if quick { 20 } else { 100 };
    write_json(&d.join("bp.json"), &serde_json::json!({
        "nx": grid.nx, "ny": grid.ny, "spacing_m": grid.spacing_m, "centre_m": grid.centre_m,
        "bs_m": geom.bs_m, "fs_hz": geom.fs_hz, "upsample": geom.upsample, "wavelength_m": geom.wavelength_m,
        "numpy_pulses": np_pulses, "subcarriers": setup.num.subcarriers, "fft_size": setup.num.fft_size,
        "paths": 51, "taps": 20, "numpy_synth_pulses": if quick { 10 } else { 50 }, "numpy_cancel_pulses": if quick { 5 } else { 20 },
    })).unwrap();
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/numpy_bench.py");
    let out = std::process::Command::new("python3")
        .arg(&script)
        .arg(d)
        .output();
    match out {
        Ok(o) if o.status.success() => {
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let np_bp = v["bp_pixel_pulses_per_s"].as_f64().unwrap();
            let np_syn = v["synth_samples_per_s"].as_f64().unwrap();
            let np_can = v["cancel_seconds_per_pulse"].as_f64().unwrap();
            // compare images over the pulses NumPy used
            let part = backproject(
                &geom,
                &grid,
                &c.pulses[..np_pulses],
                &c.profiles[..np_pulses * c.m],
                c.m,
                32,
            )
            .unwrap();
            let mut r = radar_sim::io::NpyReader::open(&d.join("numpy_image.npy")).unwrap();
            let npimg: Vec<Complex64> = r
                .read_c8(0, grid.pixels())
                .unwrap()
                .iter()
                .map(|z| Complex64::new(z.re as f64, z.im as f64))
                .collect();
            let ser_np = ser_db(&part, &npimg);
            println!("NumPy {} (same run):", v["numpy"]);
            println!("  backprojection: {:.3e} pixel-pulses/s ({} pulses) -> Rust {:.0}x; Rust vs NumPy image SER {:.1} dB", np_bp, np_pulses, bp_rate / np_bp, ser_np);
            println!(
                "  synthesis: {:.3e} samples/s -> Rust {:.0}x",
                np_syn,
                synth_rate / np_syn
            );
            println!("  cancellation (ECA lstsq, 20 taps): {:.1} µs per pulse -> Rust (cancel + compress + profile) {:.0}x", 1e6 * np_can, np_can / (dt_comp / pulses.len() as f64));
        }
        Ok(o) => println!(
            "NumPy benchmark failed: {}",
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => println!("NumPy benchmark not run (python3: {e})"),
    }
}
