//! `process`: a recording directory → images (NPY, PNG; the caller adds views), `detections.csv/.json` and
//! `metrics.json`, one aperture at a time.

use std::path::Path;

use rustfft::num_complex::Complex32;

use super::recording::{read_pulses, read_truth, write_detections};
use super::{iq_path, mkdir, DetectionRow, ImageViews, Metrics, Progress, RecordingMeta, FORMAT};
use crate::error::{RadarError, Result};
use crate::io::{
    write_json, write_png_db, ImageFrame, NpyReader, NpyType, NpyWriter, IMAGE_RANGE_DB,
};
use crate::limits::{IqBudget, IqLimits};
use crate::pipeline::{ApertureResult, Processor, RadarSetup};
use crate::tally::{self, ApertureTally};
use crate::track::{Aperture, PulseMeta};

/// Processes the recording in `input` into `out`, refusing apertures above the default
/// [`IqLimits`] (see [`process_limited`]).
pub fn process(
    input: &Path,
    out: &Path,
    progress: Progress<'_>,
    views: ImageViews<'_>,
) -> Result<Metrics> {
    process_limited(input, out, &IqLimits::default(), progress, views)
}

/// Reads `meta.json` of the recording in `input` and checks its format tag.
fn read_meta(input: &Path) -> Result<RecordingMeta> {
    let meta_path = input.join("meta.json");
    let text = std::fs::read_to_string(&meta_path).map_err(|e| RadarError::read(&meta_path, e))?;
    let meta: RecordingMeta = serde_json::from_str(&text)
        .map_err(|e| RadarError::format(meta_path.display().to_string(), "JSON", e.to_string()))?;
    if meta.format != FORMAT {
        return Err(RadarError::format(
            meta_path.display().to_string(),
            "format",
            format!("`{}` is not `{FORMAT}`", meta.format),
        ));
    }
    Ok(meta)
}

/// Processes the recording in `input` into `out`. Each aperture is held in memory at once, so
/// before anything is read, the memory of the largest one is checked against
/// `limits.max_aperture_bytes` (the recording's total size does not matter here). `views` is
/// called with each aperture's image after its NPY and PNG are written.
pub fn process_limited(
    input: &Path,
    out: &Path,
    limits: &IqLimits,
    progress: Progress<'_>,
    views: ImageViews<'_>,
) -> Result<Metrics> {
    let meta = read_meta(input)?;
    let setup = RadarSetup::new(&meta.params, &meta.scene)?;
    let aps: Vec<Aperture> = meta.apertures.iter().map(|a| a.aperture.clone()).collect();
    let budget = IqBudget::new(&setup, &aps);
    if budget.samples_per_pulse != meta.samples_per_pulse as u64 {
        return Err(RadarError::format(
            input.join("meta.json").display().to_string(),
            "samples_per_pulse",
            format!(
                "{}, but the scene's radar gives {}",
                meta.samples_per_pulse, budget.samples_per_pulse
            ),
        ));
    }
    budget.check_aperture(limits)?;
    let proc = Processor::new(setup.clone())?;
    let truth_path = input.join("truth.csv");
    let truth = if truth_path.exists() {
        read_truth(&truth_path)?
    } else {
        Vec::new()
    };
    let pulses_all = read_pulses(&input.join("pulses.csv"))?;
    mkdir(&out.join("images"))?;
    let mut tallies = Vec::with_capacity(meta.apertures.len());
    let total = meta.apertures.len() as u64;
    for (k, at) in meta.apertures.iter().enumerate() {
        let ap = &at.aperture;
        let pulses: Vec<PulseMeta> = pulses_all
            .iter()
            .filter(|p| p.aperture == ap.index)
            .copied()
            .collect();
        if pulses.len() != ap.pulses() {
            return Err(RadarError::format(
                input.join("pulses.csv").display().to_string(),
                format!("aperture {}", ap.index),
                format!("{} pulses listed, {} expected", pulses.len(), ap.pulses()),
            ));
        }
        let iq = read_aperture_iq(input, ap.index, pulses.len(), meta.samples_per_pulse)?;
        let r = proc.process_aperture(ap, &pulses, &iq, &truth)?;
        write_images(&out.join("images"), ap.index, &r, views)?;
        tallies.push(ApertureTally::new(ap, &r, meta.noise_power_w));
        progress(k as u64 + 1, total);
    }
    let det_rows: Vec<DetectionRow> = tallies.iter().flat_map(|t| t.rows.clone()).collect();
    write_detections(out, &det_rows)?;
    let (mut metrics, best) = tally::fold(&tallies, meta.noise_power_w);
    // resolution on the strongest landmark: one look, exact evaluation
    let best = best.and_then(|(ai, look)| Some((aps.iter().find(|a| a.index == ai)?, look)));
    if let Some((ap, look)) = best {
        let pulses: Vec<PulseMeta> = pulses_all
            .iter()
            .filter(|p| p.aperture == ap.index && p.look == look)
            .copied()
            .collect();
        let mut rd = NpyReader::open(&iq_path(input, ap.index))?;
        let first = look * ap.pulses_per_look * meta.samples_per_pulse;
        let iq = rd.read_c8(first, pulses.len() * meta.samples_per_pulse)?;
        if let Some((rr, ra)) = tally::measure_look(&proc, ap, &pulses, &iq)? {
            metrics.range_resolution_m = Some(rr);
            metrics.azimuth_resolution_m = Some(ra);
            metrics.resolution_from = Some((ap.index, look));
        }
    }
    write_json(&out.join("metrics.json"), &metrics)?;
    Ok(metrics)
}

/// The IQ of aperture `index` (`pulses × samples_per_pulse`), its shape checked.
fn read_aperture_iq(
    input: &Path,
    index: usize,
    pulses: usize,
    samples_per_pulse: usize,
) -> Result<Vec<Complex32>> {
    let path = iq_path(input, index);
    let mut rd = NpyReader::open(&path)?;
    if rd.shape != [pulses, samples_per_pulse] {
        return Err(RadarError::format(
            path.display().to_string(),
            "shape",
            format!("{:?}, expected [{pulses}, {samples_per_pulse}]", rd.shape),
        ));
    }
    rd.read_c8(0, pulses * samples_per_pulse)
}

/// Writes aperture `index`'s images into `dir`: the multilook power (NPY, PNG with the
/// detections marked) and, when kept, each look's complex image (NPY); then hands the power
/// image to `views`.
fn write_images(dir: &Path, index: usize, r: &ApertureResult, views: ImageViews<'_>) -> Result<()> {
    let mut w = NpyWriter::create(
        &dir.join(format!("aperture_{index:03}.npy")),
        NpyType::F4,
        &[r.grid.ny, r.grid.nx],
    )?;
    w.write_f4(&r.multilook)?;
    w.finish()?;
    for (l, img) in r.looks.iter().enumerate() {
        let mut w = NpyWriter::create(
            &dir.join(format!("aperture_{index:03}_look_{l:02}.npy")),
            NpyType::C8,
            &[r.grid.ny, r.grid.nx],
        )?;
        w.write_c8(img)?;
        w.finish()?;
    }
    let markers = tally::detection_pixels(r);
    let png_name = format!("aperture_{index:03}.png");
    write_png_db(
        &dir.join(&png_name),
        &r.multilook,
        r.grid.nx,
        r.grid.ny,
        IMAGE_RANGE_DB,
        &markers,
    )?;
    let frame = ImageFrame {
        aperture: index,
        centre_m: r.grid.centre_m,
        spacing_m: r.grid.spacing_m,
        nx: r.grid.nx,
        ny: r.grid.ny,
    };
    views(dir, &frame, &r.multilook)
}
