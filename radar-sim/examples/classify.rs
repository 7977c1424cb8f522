//! Classifies the misses and the false alarms of a processed run (`closed-loop --out DIR`, or
//! a directory with `recording/` and `processed/`), as the physics review's analysis did:
//! - each missed object-aperture pair: the image value at the object, whether the multilook
//!   image has a local maximum within 2 m of it (none: merged with a neighbour's response, a
//!   resolution loss; one: the detector dropped a distinct peak), and the aperture's cell;
//! - each false alarm (unmatched detection): every truth object within 150 m of the aperture
//!   centre is imaged alone (noise-free, no direct path, the run's processing), and the one
//!   whose response is strongest at the false alarm is named, with whether it lies inside the
//!   grid; if no single response comes within 6 dB of the false alarm, every object of the
//!   scene is imaged together (a coherent combination, as in near-blind geometry, where the
//!   responses of objects hundreds of metres away cross the image), else it is noise.
//!
//! `cargo run --release -p radar-sim --example classify -- DIR`

use std::path::Path;

use anyhow::{Context, Result};

use radar_sim::io::NpyReader;
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::run::{read_pulses, read_truth, DetectionRow, Metrics, RecordingMeta};
use radar_sim::synth::Components;

/// Reads and parses a JSON file, naming it in the error.
fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}

/// Whether the image (`ny × nx`) has a local maximum (of its 3 × 3 neighbourhood) within `r`
/// pixels of `(cx, cy)`.
fn has_local_max(img: &[f32], nx: usize, ny: usize, (cx, cy): (i64, i64), r: i64) -> bool {
    let at_px = |x: i64, y: i64| img[y as usize * nx + x as usize];
    ((cy - r).max(1)..=(cy + r).min(ny as i64 - 2)).any(|y| {
        ((cx - r).max(1)..=(cx + r).min(nx as i64 - 2)).any(|x| {
            let v = at_px(x, y);
            (-1..=1).all(|dy| (-1..=1).all(|dx| at_px(x + dx, y + dy) <= v))
        })
    })
}

fn main() -> Result<()> {
    let dir = std::env::args()
        .nth(1)
        .context("usage: classify DIR (a closed-loop output directory)")?;
    let dir = Path::new(&dir);
    let rec = dir.join("recording");
    let out = dir.join("processed");
    let meta: RecordingMeta = read_json(&rec.join("meta.json"))?;
    let metrics: Metrics = read_json(&out.join("metrics.json"))?;
    let dets: Vec<DetectionRow> = read_json(&out.join("detections.json"))?;
    let truth = read_truth(&rec.join("truth.csv"))?;
    let pulses_all = read_pulses(&rec.join("pulses.csv"))?;
    let mut scene = meta.scene.clone();
    scene.radar.thermal_noise = false;
    scene.radar.direct_path = false;
    let setup = RadarSetup::new(&meta.params, &scene)?;
    let proc = Processor::new(setup.clone())?;
    for (k, at) in meta.apertures.iter().enumerate() {
        let ap = &at.aperture;
        let grid = setup.grid(ap);
        let summary = metrics
            .apertures
            .get(k)
            .with_context(|| format!("metrics.json has no aperture {k}"))?;
        let img = NpyReader::open(
            &out.join("images")
                .join(format!("aperture_{:03}.npy", ap.index)),
        )?
        .read_f4(0, grid.pixels())?;
        let half = (grid.nx as f64 - 1.0) / 2.0 * grid.spacing_m - grid.spacing_m;
        let rel = |p: [f64; 2]| [p[0] - ap.centre_m[0], p[1] - ap.centre_m[1]];
        let inside = |p: [f64; 2]| rel(p)[0].abs() <= half && rel(p)[1].abs() <= half;
        let pixel = |p: [f64; 2]| {
            let (x, y) = grid.index_of(p);
            (x.round() as i64, y.round() as i64)
        };
        let at_px = |x: i64, y: i64| img[y as usize * grid.nx + x as usize];
        let cell = format!(
            "cell {:.1} m (−3 dB {:.1} m)",
            summary.worst_width_m, summary.worst_width_mainlobe_m
        );
        // misses
        for o in truth.iter().filter(|o| inside(o.pos_m())) {
            if dets
                .iter()
                .any(|d| d.aperture == ap.index && d.truth_id == Some(o.id))
            {
                continue;
            }
            let (cx, cy) = pixel(o.pos_m());
            let r = (2.0 / grid.spacing_m).round() as i64;
            let local_max = has_local_max(&img, grid.nx, grid.ny, (cx, cy), r);
            let p = rel(o.pos_m());
            println!(
                "aperture {:2} MISS object {} at ({:.1}, {:.1}): {:.1} dB, {}; {cell}",
                ap.index,
                o.id,
                p[0],
                p[1],
                10.0 * (at_px(cx, cy) as f64).log10(),
                if local_max {
                    "a local maximum within 2 m (dropped by the detector)"
                } else {
                    "no local maximum within 2 m (merged)"
                }
            );
        }
        // false alarms
        let fas: Vec<&DetectionRow> = dets
            .iter()
            .filter(|d| d.aperture == ap.index && d.truth_id.is_none())
            .collect();
        if fas.is_empty() {
            continue;
        }
        let pulses: Vec<_> = pulses_all
            .iter()
            .filter(|p| p.aperture == ap.index)
            .copied()
            .collect();
        let near: Vec<_> = truth
            .iter()
            .filter(|o| {
                let p = rel(o.pos_m());
                p[0].hypot(p[1]) < 150.0
            })
            .collect();
        let mut alone = Vec::new();
        for o in &near {
            let iq = setup
                .synthesizer(vec![**o])?
                .synthesize_frame(&pulses, Components::ALL)?;
            alone.push(proc.process_aperture(ap, &pulses, &iq, &[])?.multilook);
        }
        // every object of the scene together, noise-free
        let iq = setup
            .synthesizer(truth.clone())?
            .synthesize_frame(&pulses, Components::ALL)?;
        let together = proc.process_aperture(ap, &pulses, &iq, &[])?.multilook;
        for d in fas {
            let (x, y) = pixel([d.x_m, d.y_m]);
            let i = y as usize * grid.nx + x as usize;
            let best = near
                .iter()
                .zip(&alone)
                .map(|(o, a)| (a[i], o))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            let p = rel([d.x_m, d.y_m]);
            let Some((v, o)) = best else {
                println!(
                    "aperture {:2} FALSE ALARM at ({:.1}, {:.1}), {:.1} dB: no object within 150 m (noise); {cell}",
                    ap.index, p[0], p[1], d.snr_db
                );
                continue;
            };
            let q = rel(o.pos_m());
            let level = 10.0 * (v as f64).log10();
            let all = 10.0 * (together[i] as f64).log10();
            let what = if level > d.snr_db - 6.0 {
                "the response of one object".to_string()
            } else if all > d.snr_db - 6.0 {
                format!(
                    "the objects' responses together ({all:.1} dB noise-free); the strongest alone"
                )
            } else {
                format!("noise (all objects together: {all:.1} dB); the strongest object response")
            };
            println!(
                "aperture {:2} FALSE ALARM at ({:.1}, {:.1}), {:.1} dB: {what} is object {} at ({:.1}, {:.1}) ({}, {:.1} m away), {level:.1} dB there; {cell}",
                ap.index,
                p[0],
                p[1],
                d.snr_db,
                o.id,
                q[0],
                q[1],
                if inside(o.pos_m()) { "inside the grid" } else { "beyond the grid" },
                (q[0] - p[0]).hypot(q[1] - p[1]),
            );
        }
    }
    Ok(())
}
