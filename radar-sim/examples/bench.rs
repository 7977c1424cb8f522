//! Throughput benchmarks of the hot steps, with straightforward NumPy implementations of the
//! same steps on the same inputs and sizes, measured in the same run
//! (`radar-sim/bench/numpy_bench.py`, needs python3 + numpy).
//!
//! Run: `cargo run --release -p radar-sim --example bench [-- --quick] [-- --threads N]`;
//! `--synthesis-only` stops after the echo-synthesis figures (no NumPy).
//!
//! Every figure is the median over repetitions, with its CPU time (all threads: the process
//! CPU-time clock, [`radar_sim::cputime`]) and the load average at the start of the step,
//! because the machine is shared. The NumPy outputs are checked against the Rust outputs
//! (signal-to-error ratio) so that both do the same work.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::time::Instant;

use radar_sim::backproject::{backproject, backproject_reference, ser_db, BpPulse, Grid};
use radar_sim::config::SceneFile;
use radar_sim::cputime::{load_average, process_cpu_s};
use radar_sim::io::{write_json, NpyType, NpyWriter};
use radar_sim::pipeline::{Compressed, Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::synth::{Components, Synthesizer};
use radar_sim::track::{dist3, plan_apertures, plan_pulses, LinearTrack, PulseMeta};
use rustfft::num_complex::{Complex32, Complex64};
use serde_json::json;

/// Median wall and CPU seconds of `reps` runs of `f`, the load average, the last result, and
/// the best (least) wall time.
fn timed<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, f64, String, T, f64) {
    let load = load_average();
    let mut walls = Vec::new();
    let mut cpus = Vec::new();
    let mut out = None;
    for _ in 0..reps.max(1) {
        let c0 = process_cpu_s();
        let t = Instant::now();
        out = Some(f());
        walls.push(t.elapsed().as_secs_f64());
        cpus.push(process_cpu_s() - c0);
    }
    walls.sort_by(f64::total_cmp);
    cpus.sort_by(f64::total_cmp);
    (
        walls[walls.len() / 2],
        cpus[cpus.len() / 2],
        load,
        out.unwrap(),
        walls[0],
    )
}

fn write_c8(path: &Path, shape: &[usize], v: &[Complex32]) {
    let mut w = NpyWriter::create(path, NpyType::C8, shape).unwrap();
    w.write_c8(v).unwrap();
    w.finish().unwrap();
}

fn write_f8(path: &Path, shape: &[usize], v: &[f64]) {
    let mut w = NpyWriter::create(path, NpyType::F8, shape).unwrap();
    w.write_f8(v).unwrap();
    w.finish().unwrap();
}

fn ser_c32(a: &[Complex32], b: &[Complex32]) -> f64 {
    let r: Vec<Complex64> = b
        .iter()
        .map(|z| Complex64::new(z.re as f64, z.im as f64))
        .collect();
    ser_db(a, &r)
}

/// Pulses of one look of a UAV flying `heading_deg` at 20 m/s whose sensing centre passes the
/// origin at the middle of the look.
fn look_pulses(setup: &RadarSetup, heading_deg: f64, looks: usize) -> Vec<PulseMeta> {
    let a = heading_deg.to_radians();
    let h = [a.cos(), a.sin()];
    let off = setup.params.centre_offset_m();
    let mid = [-off * h[1], off * h[0]]; // origin − off · right, right = (h_y, −h_x)
    let t_mid = 0.5 * looks as f64 * setup.look_s;
    let track = LinearTrack {
        start_m: [
            mid[0] - 20.0 * h[0] * t_mid,
            mid[1] - 20.0 * h[1] * t_mid,
            setup.params.altitude_m,
        ],
        velocity_mps: [20.0 * h[0], 20.0 * h[1], 0.0],
    };
    let ap = plan_apertures(
        &[([0.0, 0.0], Some(0), 0.0, looks as f64 * setup.look_s)],
        setup.look_s,
        setup.scene.radar.prf_hz,
    )
    .unwrap()
    .remove(0);
    plan_pulses(
        &track,
        &setup.num,
        setup.bs_m,
        &ap,
        setup.scene.radar.prf_hz,
    )
}

/// Writes what NumPy needs to synthesise `pulses` like `synth` does.
fn write_synth_inputs(
    dir: &Path,
    tag: &str,
    setup: &RadarSetup,
    synth: &Synthesizer,
    pulses: &[PulseMeta],
) {
    let num = &setup.num;
    let meta: Vec<f64> = pulses
        .iter()
        .flat_map(|p| {
            [
                p.pos_m[0],
                p.pos_m[1],
                p.pos_m[2],
                p.heading[0],
                p.heading[1],
                p.window_delay_samples as f64,
                p.symbol as f64,
            ]
        })
        .collect();
    write_f8(
        &dir.join(format!("{tag}_pulses.npy")),
        &[pulses.len(), 7],
        &meta,
    );
    // data of symbols m − 2 .. m + 1 of each pulse (split paths reach the neighbours)
    let mut data = Vec::new();
    for p in pulses {
        for s in -2i64..=1 {
            let m = p.symbol as i64 + s;
            if m >= 0 {
                data.extend(num.symbol_data(m as u64));
            } else {
                data.extend(vec![Complex32::new(0.0, 0.0); num.subcarriers]);
            }
        }
    }
    write_c8(
        &dir.join(format!("{tag}_data.npy")),
        &[pulses.len(), 4, num.subcarriers],
        &data,
    );
    let objs: Vec<f64> = synth
        .objects()
        .iter()
        .flat_map(|o| [o.x_m, o.y_m, o.rcs_m2, o.phase_rad])
        .collect();
    write_f8(
        &dir.join(format!("{tag}_objects.npy")),
        &[synth.objects().len(), 4],
        &objs,
    );
}

/// What every step shares: the radar, the processor, the scene's objects, the repetitions,
/// the directory of NumPy's inputs and the figures so far.
struct Bench {
    setup: RadarSetup,
    proc: Processor,
    synth: Synthesizer,
    /// Pulses per look.
    npl: usize,
    reps: usize,
    quick: bool,
    dir: tempfile::TempDir,
    results: serde_json::Map<String, serde_json::Value>,
}

/// Prints the machine and the numerology.
fn print_header(setup: &RadarSetup, reps: usize) {
    let num = &setup.num;
    let threads = rayon::current_num_threads();
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_default();
    println!(
        "machine: {cpu}, {} CPUs; rayon threads: {threads}; load average at start: {}",
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(0),
        load_average()
    );
    println!(
        "numerology: N = {}, N_sc = {}, f_s = {:.2} MHz, N_cp = {} ({:.0} m); {} repetitions, medians",
        num.fft_size,
        num.subcarriers,
        num.sample_rate_hz() / 1e6,
        num.cp_samples,
        num.cp_range_m(),
        reps
    );
}

/// The scene: 50 objects around the origin (the default mission's first landmark) + it.
fn bench_objects() -> Vec<SceneObject> {
    (0..51)
        .map(|i| SceneObject {
            id: i,
            x_m: if i == 0 { 0.0 } else { -60.0 + 2.4 * i as f64 },
            y_m: if i == 0 {
                0.0
            } else {
                40.0 * ((i * 7 % 11) as f64 / 11.0 - 0.5)
            },
            rcs_m2: 5.0,
            phase_rad: i as f64,
            landmark: None,
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let threads = args
        .iter()
        .position(|a| a == "--threads")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .unwrap();
    let reps = if quick { 3 } else { 7 };
    let params = planner::Params::default();
    let scene = SceneFile::default();
    let setup = RadarSetup::new(&params, &scene).unwrap();
    print_header(&setup, reps);
    let mut b = Bench {
        proc: Processor::new(setup.clone()).unwrap(),
        synth: setup.synthesizer(bench_objects()).unwrap(),
        npl: (setup.look_s * scene.radar.prf_hz).round() as usize,
        setup,
        reps,
        quick,
        dir: tempfile::tempdir().unwrap(),
        results: serde_json::Map::new(),
    };
    let synth_cases = bench_synthesis(&mut b);
    if args.iter().any(|a| a == "--synthesis-only") {
        println!("load average at the end: {}", load_average());
        return;
    }
    // cancellation, range compression and backprojection on the in-CP look
    let (_, pulses, iq) = &synth_cases[0];
    let ap = plan_apertures(&[([0.0, 0.0], Some(0), 0.0, b.setup.look_s)], 1.0, 100.0)
        .unwrap()
        .remove(0);
    let grid = b.setup.grid(&ap);
    let comp = bench_compress(&mut b, &grid, pulses, iq);
    let img = bench_backprojection(&mut b, &grid, iq, &comp);
    write_numpy_config(&b, &grid, &comp);
    if let Some(v) = run_numpy(b.dir.path()) {
        compare_with_numpy(&b, &v, &grid, &img);
    }
    println!("load average at the end: {}", load_average());
}

/// Echo synthesis on an in-CP geometry (UAV west of the landmark heading north, as on the
/// default mission) and on one whose echoes lie beyond the CP (UAV east, heading south):
/// (tag, pulses, IQ) of each.
fn bench_synthesis(b: &mut Bench) -> Vec<(&'static str, Vec<PulseMeta>, Vec<Complex32>)> {
    let (setup, synth, reps, d) = (&b.setup, &b.synth, b.reps, b.dir.path());
    let num = &setup.num;
    let mut synth_cases = Vec::new();
    for (tag, heading) in [("incp", 90.0), ("split", 270.0)] {
        let pulses = look_pulses(setup, heading, 1);
        let mid = &pulses[pulses.len() / 2];
        let excess: Vec<f64> = synth
            .objects()
            .iter()
            .map(|o| {
                let q = [o.x_m, o.y_m, 0.0];
                dist3(setup.bs_m, q) + dist3(q, mid.pos_m) - dist3(setup.bs_m, mid.pos_m)
            })
            .collect();
        let beyond = excess.iter().filter(|e| **e > num.cp_range_m()).count();
        let (w, c, load, iq, best) = timed(reps, || {
            synth.synthesize_frame(&pulses, Components::ALL).unwrap()
        });
        let samples = (pulses.len() * synth.samples_per_pulse()) as f64;
        println!(
            "synthesis [{tag}]: {} pulses × {} samples, {} paths ({} beyond the CP): {:.4} s wall = {:.3e} samples/s; {:.4} CPU-s = {:.3e} samples per CPU-second (load {load})",
            pulses.len(),
            synth.samples_per_pulse(),
            synth.objects().len() + 1,
            beyond,
            w,
            samples / w,
            c,
            samples / c
        );
        write_synth_inputs(d, tag, setup, synth, &pulses);
        let clean = synth
            .synthesize_frame(
                &pulses,
                Components {
                    noise: false,
                    ..Components::ALL
                },
            )
            .unwrap();
        write_c8(
            &d.join(format!("{tag}_clean.npy")),
            &[pulses.len(), synth.samples_per_pulse()],
            &clean,
        );
        b.results.insert(
            format!("synth_{tag}"),
            json!({"wall_s": w, "cpu_s": c, "best_s": best, "samples": samples, "load": load, "beyond_cp": beyond}),
        );
        synth_cases.push((tag, pulses, iq));
    }

    synth_cases
}

/// Cancellation + range compression (ECA-B, 1 pulse per batch) of one look.
fn bench_compress(
    b: &mut Bench,
    grid: &Grid,
    pulses: &[PulseMeta],
    iq: &[Complex32],
) -> Compressed {
    let (setup, proc, reps, npl, d) = (&b.setup, &b.proc, b.reps, b.npl, b.dir.path());
    let (num, scene) = (&setup.num, &setup.scene);
    let (w, c, load, comp, best) = timed(reps, || {
        proc.compress(grid, pulses, iq, npl, Some([0.0, 0.0]), false)
            .unwrap()
    });
    println!(
        "cancellation (ECA-B, {} taps, 1 pulse per batch) + reciprocal filter + ×{} profile window: {:.4} s wall = {:.1} µs per pulse; {:.1} CPU-µs per pulse (load {load})",
        scene.processing.taps_before + scene.processing.taps_after,
        scene.processing.upsample,
        w,
        1e6 * w / pulses.len() as f64,
        1e6 * c / pulses.len() as f64
    );
    b.results.insert(
        "compress".into(),
        json!({"wall_s": w, "cpu_s": c, "best_s": best, "pulses": pulses.len(), "load": load}),
    );
    write_c8(&d.join("cancel_iq.npy"), &[pulses.len(), num.fft_size], iq);
    let jm: Vec<f64> = comp.pulses.iter().map(|p| p.j0 as f64).collect();
    write_f8(&d.join("cancel_j0.npy"), &[pulses.len()], &jm);
    // per pulse: the direct path's delay (metric) and the test target's (landmark) delay
    let geom0 = setup.geometry();
    let delays: Vec<f64> = pulses
        .iter()
        .flat_map(|p| {
            [
                dist3(p.pos_m, setup.bs_m) * num.sample_rate_hz() / radar_sim::waveform::C_MPS
                    - p.window_delay_samples as f64,
                geom0.delay_samples([0.0, 0.0], p.pos_m, p.window_delay_samples),
            ]
        })
        .collect();
    write_f8(&d.join("cancel_delays.npy"), &[pulses.len(), 2], &delays);
    b.results.insert(
        "compress_metrics".into(),
        json!({
            "input_power": comp.cancel.input_power, "output_power": comp.cancel.output_power,
            "dp_mf_before": comp.cancel.dp_mf_before, "dp_mf_after": comp.cancel.dp_mf_after,
            "target_loss_db": comp.cancel.target_loss_db(),
        }),
    );
    write_c8(
        &d.join("cancel_profiles.npy"),
        &[pulses.len(), comp.m],
        &comp.profiles,
    );

    comp
}

/// Backprojection of the look's profiles onto the 251 × 251 grid (and of 10 looks' worth);
/// returns the one-look image.
fn bench_backprojection(
    b: &mut Bench,
    grid: &Grid,
    iq: &[Complex32],
    comp: &Compressed,
) -> Vec<Complex32> {
    let (setup, proc, reps, npl, quick, d) =
        (&b.setup, &b.proc, b.reps, b.npl, b.quick, b.dir.path());
    let geom = setup.geometry();
    let bp_sets: Vec<(usize, usize)> = if quick {
        vec![(npl, reps)]
    } else {
        vec![(npl, reps), (10 * npl, 3)]
    };
    let ten = look_pulses(setup, 90.0, 10);
    let comp10 = if quick {
        None
    } else {
        // profiles of 10 looks: the same IQ repeated is enough for timing
        let iq10: Vec<Complex32> = (0..10).flat_map(|_| iq.iter().copied()).collect();
        Some(
            proc.compress(grid, &ten, &iq10, npl, Some([0.0, 0.0]), false)
                .unwrap(),
        )
    };
    let mut img = Vec::new();
    for (np, r) in bp_sets {
        let cc = if np == npl {
            comp
        } else {
            comp10.as_ref().unwrap()
        };
        let (w, c, load, im, best) = timed(r, || {
            backproject(&geom, grid, &cc.pulses, &cc.profiles, cc.m, 32).unwrap()
        });
        let work = (grid.pixels() * cc.pulses.len()) as f64;
        println!(
            "backprojection: {} px × {} pulses: {:.4} s wall = {:.3e} pixel-pulses/s; {:.4} CPU-s = {:.3e} per CPU-second (load {load})",
            grid.pixels(),
            cc.pulses.len(),
            w,
            work / w,
            c,
            work / c
        );
        b.results.insert(
            format!("bp_{np}"),
            json!({"wall_s": w, "cpu_s": c, "best_s": best, "work": work, "load": load}),
        );
        if np == npl {
            img = im;
        }
    }
    let idx: Vec<usize> = (0..grid.pixels()).step_by(13).collect();
    let pts: Vec<[f64; 2]> = idx
        .iter()
        .map(|&i| [grid.x(i % grid.nx), grid.y(i / grid.nx)])
        .collect();
    let reference =
        backproject_reference(&geom, &pts, &comp.pulses, &comp.profiles, comp.m).unwrap();
    let sub: Vec<_> = idx.iter().map(|&i| img[i]).collect();
    let ser = ser_db(&sub, &reference);
    println!("  image SER against the f64 reference: {ser:.1} dB");
    b.results.insert("bp_ser_db".into(), json!(ser));
    write_c8(
        &d.join("bp_profiles.npy"),
        &[comp.pulses.len(), comp.m],
        &comp.profiles,
    );
    let flat: Vec<f64> = comp
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
    write_f8(&d.join("bp_pulses.npy"), &[comp.pulses.len(), 6], &flat);

    img
}

/// Writes what NumPy needs besides the arrays: sizes, geometry, link budget, antenna.
fn write_numpy_config(b: &Bench, grid: &Grid, comp: &Compressed) {
    let (setup, d) = (&b.setup, b.dir.path());
    let (num, scene, geom) = (&setup.num, &setup.scene, setup.geometry());
    let reps = b.reps;
    let ant = &setup.antenna;
    let radar = &scene.radar;
    write_json(
        &d.join("config.json"),
        &json!({
            "reps": reps,
            "nx": grid.nx, "ny": grid.ny, "spacing_m": grid.spacing_m, "centre_m": grid.centre_m,
            "bs_m": geom.bs_m, "fs_hz": geom.fs_hz, "upsample": geom.upsample,
            "wavelength_m": geom.wavelength_m,
            "fft_size": num.fft_size, "cp_samples": num.cp_samples, "subcarriers": num.subcarriers,
            "eirp_w": radar.tx_power_w * 10f64.powf((radar.tx_gain_dbi - radar.system_loss_db) / 10.0),
            "noise_w": b.synth.noise_power_w(),
            "antenna": {"length_m": ant.length_m, "height_m": ant.height_m, "look_rad": ant.look_rad,
                        "peak_gain": ant.peak_gain, "floor": ant.floor, "back": ant.back},
            "taps_before": scene.processing.taps_before, "taps_after": scene.processing.taps_after,
            "profile_m": comp.m,
        }),
    )
    .unwrap();
}

/// Runs `bench/numpy_bench.py` on the inputs in `d`; its figures, or None (said why).
fn run_numpy(d: &Path) -> Option<serde_json::Value> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/numpy_bench.py");
    let out = std::process::Command::new("python3")
        .arg(&script)
        .arg(d)
        .output();
    match out {
        Ok(o) if o.status.success() => Some(serde_json::from_slice(&o.stdout).unwrap()),
        Ok(o) => {
            println!(
                "NumPy benchmark failed: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            None
        }
        Err(e) => {
            println!("NumPy benchmark not run (python3: {e})");
            None
        }
    }
}

/// Prints NumPy's figures against Rust's: the ratios and the agreement of the outputs.
fn compare_with_numpy(b: &Bench, v: &serde_json::Value, grid: &Grid, img: &[Complex32]) {
    let (results, reps, npl, d) = (&b.results, b.reps, b.npl, b.dir.path());
    let geom = b.setup.geometry();
    println!("NumPy {} (same run, same inputs and sizes):", v["numpy"]);
    let f = |k: &str, f: &str| v[k][f].as_f64().unwrap_or(f64::NAN);
    let r = |k: &str, f: &str| results[k][f].as_f64().unwrap_or(f64::NAN);
    for tag in ["incp", "split"] {
        let key = format!("synth_{tag}");
        let np_rate = f(&key, "samples") / f(&key, "wall_s");
        let rs_rate = r(&key, "samples") / r(&key, "wall_s");
        println!(
            "  synthesis [{tag}]: {:.3e} samples/s (median {:.3} s, load {}); Rust {:.1}x wall ({:.1}x best of {reps}), {:.1}x per CPU-second; NumPy vs Rust output (no noise) SER {:.1} dB",
            np_rate,
            f(&key, "wall_s"),
            v[&key]["load"],
            rs_rate / np_rate,
            f(&key, "best_s") / r(&key, "best_s"),
            (r(&key, "samples") / r(&key, "cpu_s")) / (f(&key, "samples") / f(&key, "cpu_s")),
            f(&key, "ser_db")
        );
    }
    let np_per = f("compress", "wall_s") / f("compress", "pulses");
    let rs_per = r("compress", "wall_s") / r("compress", "pulses");
    let rel = |k: &str| {
        let a = v["compress"]["metrics"][k].as_f64().unwrap_or(f64::NAN);
        let b = results["compress_metrics"][k].as_f64().unwrap_or(f64::NAN);
        (a / b - 1.0).abs()
    };
    println!(
        "  cancellation metrics, NumPy vs Rust (relative difference): input power {:.1e}, output power {:.1e}, direct path before {:.1e}; target loss {:.4} vs {:.4} dB",
        rel("input_power"),
        rel("output_power"),
        rel("dp_mf_before"),
        v["compress"]["metrics"]["target_loss_db"].as_f64().unwrap_or(f64::NAN),
        results["compress_metrics"]["target_loss_db"].as_f64().unwrap_or(f64::NAN)
    );
    println!(
        "  cancellation (ECA by lstsq, with its metrics) + reciprocal filter + ×{} profile: {:.1} µs per pulse (load {}); Rust {:.1}x wall ({:.1}x best of {reps}), {:.1}x per CPU-second; NumPy vs Rust profiles SER {:.1} dB",
        geom.upsample,
        1e6 * np_per,
        v["compress"]["load"],
        np_per / rs_per,
        f("compress", "best_s") / r("compress", "best_s"),
        (f("compress", "cpu_s") / f("compress", "pulses"))
            / (r("compress", "cpu_s") / r("compress", "pulses")),
        f("compress", "ser_db")
    );
    let np_bp = f("bp", "work") / f("bp", "wall_s");
    let key = format!("bp_{npl}");
    println!(
        "  backprojection: {:.3e} pixel-pulses/s ({} pulses, load {}); Rust {:.1}x wall ({:.1}x best of {reps}), {:.1}x per CPU-second; NumPy vs Rust image SER {:.1} dB",
        np_bp,
        npl,
        v["bp"]["load"],
        (r(&key, "work") / r(&key, "wall_s")) / np_bp,
        f("bp", "best_s") / r(&key, "best_s"),
        (r(&key, "work") / r(&key, "cpu_s")) / (f("bp", "work") / f("bp", "cpu_s")),
        {
            let mut rd = radar_sim::io::NpyReader::open(&d.join("numpy_image.npy")).unwrap();
            let npimg = rd.read_c8(0, grid.pixels()).unwrap();
            ser_c32(img, &npimg)
        }
    );
}
