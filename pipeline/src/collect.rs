//! What the launcher collects from the processor (detections, images, metrics), de-duplicated
//! by mission and aperture, and the output files it writes from them: the same files, with
//! the same numbers, as `cellsar-radar-sim closed-loop`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::protocol::{ApertureDetections, ApertureImage, MissionMetrics};
use crate::report::image_svg::write_aperture_view;
use anyhow::{Context, Result};
use bridge::MissionId;
use radar_sim::io::{write_json, write_png_db, ImageFrame, NpyType, NpyWriter, IMAGE_RANGE_DB};
use radar_sim::run::{DetectionRow, Metrics};

/// Results of one mission as they arrive.
#[derive(Debug)]
pub struct Collector {
    /// Mission id.
    pub mission_id: MissionId,
    /// Apertures in the mission.
    pub apertures: usize,
    out: PathBuf,
    detections: BTreeMap<u32, ApertureDetections>,
    images: BTreeMap<u32, ()>,
    metrics: Option<Metrics>,
    /// Metrics received before every aperture's detections, held until they can be checked
    /// against them (at most [`MAX_HELD_METRICS`], the oldest let go).
    held_metrics: Vec<Metrics>,
    /// Messages received again (at-least-once delivery), dropped.
    pub duplicates: u64,
    /// Messages of other missions or apertures out of range, ignored.
    pub foreign: u64,
    /// Messages of this mission that contradict themselves (an image whose pixels are not
    /// `nx × ny`, a marker outside it, detections of another aperture), logged and skipped.
    pub malformed: u64,
}

/// Most metrics held before every aperture's detections are in.
pub const MAX_HELD_METRICS: usize = 8;

/// Malformed messages logged as warnings before the log turns quiet about them (the rest are
/// counted and logged at debug level).
const LOUD_MALFORMED: u64 = 10;

/// Largest image accepted, pixels (`nx × ny`): 16 Mi, the largest that fits in a message of
/// `bridge::envelope::MAX_BODY_BYTES` (64 MiB of f32).
pub const MAX_IMAGE_PIXELS: usize = 16 << 20;

/// Why detections of a mission of `apertures` apertures contradict themselves (`None`:
/// consistent): another aperture count than the mission's, a detection of another aperture
/// than the message's, a position that is not finite or an SNR that is not a number.
pub fn detections_problem(d: &ApertureDetections, apertures: usize) -> Option<String> {
    if d.apertures as usize != apertures {
        return Some(format!(
            "{} apertures claimed for a mission of {apertures}",
            d.apertures
        ));
    }
    if let Some(x) = d
        .detections
        .iter()
        .find(|x| x.aperture != d.aperture as usize)
    {
        return Some(format!(
            "a detection of aperture {} in the message of aperture {}",
            x.aperture, d.aperture
        ));
    }
    d.detections
        .iter()
        .find(|x| !(x.x_m.is_finite() && x.y_m.is_finite()) || x.snr_db.is_nan())
        .map(|x| {
            format!(
                "a detection at ({}, {}) m with SNR {} dB",
                x.x_m, x.y_m, x.snr_db
            )
        })
}

/// Why `metrics` of a mission of `apertures` apertures disagree with its `detections` (one
/// message per aperture, all in): a summary per aperture is expected, each with the landmark,
/// its verdict and the numbers of detections and false alarms of that aperture's message.
pub fn metrics_problem(
    metrics: &Metrics,
    detections: &BTreeMap<u32, ApertureDetections>,
    apertures: usize,
) -> Option<String> {
    if metrics.apertures.len() != apertures {
        return Some(format!(
            "{} aperture summaries for a mission of {apertures}",
            metrics.apertures.len()
        ));
    }
    for a in &metrics.apertures {
        let Some(d) = u32::try_from(a.aperture)
            .ok()
            .and_then(|k| detections.get(&k))
        else {
            return Some(format!("a summary of aperture {} out of range", a.aperture));
        };
        let agree = a.landmark == d.landmark
            && a.landmark_detected == d.landmark_detected
            && a.detections == d.detections.len()
            && a.false_alarms == d.false_alarms;
        if !agree {
            return Some(format!(
                "aperture {}: landmark {:?} detected {:?}, {} detections, {} false alarms, \
                 where its detections say landmark {:?} detected {:?}, {}, {}",
                a.aperture,
                a.landmark,
                a.landmark_detected,
                a.detections,
                a.false_alarms,
                d.landmark,
                d.landmark_detected,
                d.detections.len(),
                d.false_alarms
            ));
        }
    }
    None
}

/// Why `img` contradicts itself (`None`: consistent): a grid that is empty or larger than
/// [`MAX_IMAGE_PIXELS`], a pixel count other than `nx × ny`, a marker outside the grid, a
/// centre or spacing that is not finite (or a spacing not above 0).
pub fn image_problem(img: &ApertureImage) -> Option<String> {
    let (nx, ny) = (img.nx as usize, img.ny as usize);
    let Some(pixels) = nx
        .checked_mul(ny)
        .filter(|p| (1..=MAX_IMAGE_PIXELS).contains(p))
    else {
        return Some(format!(
            "a grid of {nx} × {ny} pixels (1..={MAX_IMAGE_PIXELS} accepted)"
        ));
    };
    if img.multilook.len() != pixels {
        return Some(format!(
            "{} pixels for a grid of {nx} × {ny} = {pixels}",
            img.multilook.len()
        ));
    }
    if let Some((x, y)) = img
        .markers
        .iter()
        .find(|(x, y)| *x as usize >= nx || *y as usize >= ny)
    {
        return Some(format!(
            "a marker at ({x}, {y}) outside the {nx} × {ny} grid"
        ));
    }
    if !(img.centre_m.iter().all(|c| c.is_finite())
        && img.spacing_m.is_finite()
        && img.spacing_m > 0.0)
    {
        return Some(format!(
            "centre {:?} m, spacing {} m (finite, spacing above 0 expected)",
            img.centre_m, img.spacing_m
        ));
    }
    None
}

/// What a message added.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Added {
    /// Something new.
    New,
    /// Already held.
    Duplicate,
    /// Not for this mission.
    Foreign,
    /// Contradicts itself: skipped.
    Malformed,
    /// Held until it can be checked (metrics before every aperture's detections).
    Held,
}

impl Collector {
    /// A collector writing images into `out/images`.
    pub fn new(mission_id: MissionId, apertures: usize, out: &Path) -> Result<Self> {
        let images = out.join("images");
        std::fs::create_dir_all(&images)
            .with_context(|| format!("creating {}", images.display()))?;
        Ok(Collector {
            mission_id,
            apertures,
            out: out.to_path_buf(),
            detections: BTreeMap::new(),
            images: BTreeMap::new(),
            metrics: None,
            held_metrics: Vec::new(),
            duplicates: 0,
            foreign: 0,
            malformed: 0,
        })
    }

    fn check(&mut self, id: MissionId, aperture: Option<u32>) -> Option<Added> {
        if id != self.mission_id || aperture.is_some_and(|a| a as usize >= self.apertures) {
            self.foreign += 1;
            return Some(Added::Foreign);
        }
        None
    }

    /// Adds the detections of one aperture. Detections that contradict themselves
    /// ([`detections_problem`]) are counted, logged and skipped ([`Added::Malformed`]).
    pub fn add_detections(&mut self, d: ApertureDetections) -> Added {
        if let Some(a) = self.check(d.mission_id, Some(d.aperture)) {
            return a;
        }
        if let Some(why) = detections_problem(&d, self.apertures) {
            self.skip_malformed("detections", d.aperture, &why);
            return Added::Malformed;
        }
        if self.detections.contains_key(&d.aperture) {
            self.duplicates += 1;
            return Added::Duplicate;
        }
        self.detections.insert(d.aperture, d);
        self.settle_metrics();
        Added::New
    }

    /// Adds (and writes) the image of one aperture. One that contradicts itself
    /// ([`image_problem`]) is counted, logged and skipped ([`Added::Malformed`]), so that the
    /// aperture's real image still counts; only writing the files can fail.
    pub fn add_image(&mut self, img: &ApertureImage) -> Result<Added> {
        if let Some(a) = self.check(img.mission_id, Some(img.aperture)) {
            return Ok(a);
        }
        if let Some(why) = image_problem(img) {
            self.skip_malformed("image", img.aperture, &why);
            return Ok(Added::Malformed);
        }
        if self.images.contains_key(&img.aperture) {
            self.duplicates += 1;
            return Ok(Added::Duplicate);
        }
        write_image(&self.out.join("images"), img)?;
        self.images.insert(img.aperture, ());
        Ok(Added::New)
    }

    /// Counts and logs a malformed message (`what` of `aperture`), loudly for the first ones.
    fn skip_malformed(&mut self, what: &str, aperture: u32, why: &str) {
        self.malformed += 1;
        if self.malformed <= LOUD_MALFORMED {
            tracing::warn!(aperture, reason = %why, "malformed {what} skipped");
        } else {
            tracing::debug!(aperture, reason = %why, "malformed {what} skipped");
        }
    }

    /// Adds the mission's metrics. They are taken only when they agree with the detections
    /// taken from the processor ([`metrics_problem`]): metrics that arrive before every
    /// aperture's detections are held until then ([`Added::Held`]); metrics that contradict
    /// themselves or the detections are counted, logged and skipped.
    pub fn add_metrics(&mut self, m: MissionMetrics) -> Added {
        if let Some(a) = self.check(m.mission_id, None) {
            return a;
        }
        if self.metrics.is_some() {
            self.duplicates += 1;
            return Added::Duplicate;
        }
        if m.apertures as usize != self.apertures {
            let why = format!(
                "{} apertures for a mission of {}",
                m.apertures, self.apertures
            );
            self.skip_malformed("metrics", 0, &why);
            return Added::Malformed;
        }
        if self.held_metrics.len() >= MAX_HELD_METRICS {
            self.held_metrics.remove(0);
        }
        self.held_metrics.push(m.metrics);
        self.settle_metrics();
        if self.metrics.is_some() {
            Added::New
        } else if self.held_metrics.is_empty() {
            Added::Malformed
        } else {
            Added::Held
        }
    }

    /// Once every aperture's detections are in: takes the first held metrics that agree with
    /// them; the others are skipped as malformed.
    fn settle_metrics(&mut self) {
        if self.metrics.is_some() || self.detections.len() < self.apertures {
            return;
        }
        for m in std::mem::take(&mut self.held_metrics) {
            if self.metrics.is_some() {
                self.duplicates += 1;
                continue;
            }
            match metrics_problem(&m, &self.detections, self.apertures) {
                None => self.metrics = Some(m),
                Some(why) => self.skip_malformed("metrics", 0, &why),
            }
        }
    }

    /// Apertures with both detections and image.
    pub fn done(&self) -> usize {
        self.detections
            .keys()
            .filter(|k| self.images.contains_key(k))
            .count()
    }

    /// Apertures that lack detections or image.
    pub fn missing(&self) -> Vec<u32> {
        (0..self.apertures as u32)
            .filter(|k| !(self.detections.contains_key(k) && self.images.contains_key(k)))
            .collect()
    }

    /// Whether every aperture and the metrics are in.
    pub fn complete(&self) -> bool {
        self.done() == self.apertures && self.metrics.is_some()
    }

    /// Whether the metrics are in.
    pub fn has_metrics(&self) -> bool {
        self.metrics.is_some()
    }

    /// The detections of aperture `k`.
    pub fn detections(&self, k: u32) -> Option<&ApertureDetections> {
        self.detections.get(&k)
    }

    /// The metrics.
    pub fn metrics(&self) -> Option<&Metrics> {
        self.metrics.as_ref()
    }

    /// Every detection row, in aperture order.
    pub fn rows(&self) -> Vec<DetectionRow> {
        self.detections
            .values()
            .flat_map(|d| d.detections.iter().map(DetectionRow::from))
            .collect()
    }

    /// Writes `detections.csv`, `detections.json` and `metrics.json` (formats of
    /// `cellsar-radar-sim process`).
    pub fn write(&self) -> Result<()> {
        let rows = self.rows();
        radar_sim::run::write_detections(&self.out, &rows)?;
        if let Some(m) = &self.metrics {
            write_json(&self.out.join("metrics.json"), m)?;
        }
        Ok(())
    }
}

/// Writes `aperture_NNN.npy` (f32 multilook), `.png` (dB, [`IMAGE_RANGE_DB`] range, detections
/// marked) and `.svg` (the PNG with ground axes and a colour bar).
pub fn write_image(dir: &Path, img: &ApertureImage) -> Result<()> {
    let (nx, ny) = (img.nx as usize, img.ny as usize);
    let stem = format!("aperture_{:03}", img.aperture);
    let mut w = NpyWriter::create(&dir.join(format!("{stem}.npy")), NpyType::F4, &[ny, nx])?;
    w.write_f4(&img.multilook)?;
    w.finish()?;
    let markers: Vec<(usize, usize)> = img
        .markers
        .iter()
        .map(|(x, y)| (*x as usize, *y as usize))
        .collect();
    write_png_db(
        &dir.join(format!("{stem}.png")),
        &img.multilook,
        nx,
        ny,
        IMAGE_RANGE_DB,
        &markers,
    )?;
    let frame = ImageFrame {
        aperture: img.aperture as usize,
        centre_m: img.centre_m,
        spacing_m: img.spacing_m,
        nx,
        ny,
    };
    write_aperture_view(dir, &frame, &img.multilook)?;
    Ok(())
}

#[cfg(test)]
mod tests;
