//! The file-level steps behind the CLI: `simulate` (plan directory + scene → raw IQ, truth),
//! `process` (recording → images, detections, metrics) and `closed_loop` (mission → plan →
//! simulate → process → report). Every step streams one aperture at a time, so memory stays
//! bounded by one aperture's IQ (~33 MB for 10 s at the defaults) whatever the mission length.

use std::path::{Path, PathBuf};

use rustfft::num_complex::Complex32;
use serde::{Deserialize, Serialize};

use crate::config::SceneFile;
use crate::error::{RadarError, Result};
use crate::io::{
    csv_f64, read_csv, write_csv, write_image_svg, write_json, write_png_db, ImageFrame, NpyReader,
    NpyType, NpyWriter, IMAGE_RANGE_DB,
};
use crate::limits::{IqBudget, IqLimits};
use crate::pipeline::{Processor, RadarSetup};
use crate::scene::SceneObject;
use crate::synth::Components;
use crate::tally::{self, ApertureTally};
use crate::track::{Aperture, PlannedTrack, PulseMeta};
use crate::waveform::Numerology;

/// Format tag of a recording directory.
pub const FORMAT: &str = "cellsar-radar-sim/1";

/// Frame layout, as written into `meta.json`.
pub const FRAME_LAYOUT: &str = "iq/aperture_NNN.npy: pulses × samples complex64 (<c8), row-major, \
little-endian (re, im); samples = symbols_per_pulse × fft_size, symbol-major; each symbol is the \
CP-free FFT window of the UAV receiver, synced to the direct path (pulses.csv: window_delay_samples)";

/// Per-aperture facts known to the simulator (truth side).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ApertureTruth {
    /// The aperture.
    pub aperture: Aperture,
    /// Landmark antenna gain relative to the peak at the middle pulse, dB.
    pub landmark_gain_db: Option<f64>,
    /// Direct-path power over the summed echo power at the middle pulse, dB.
    pub direct_to_echo_db: f64,
    /// Direct-path power over the noise power per sample, dB.
    pub direct_to_noise_db: f64,
}

/// `meta.json` of a recording.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RecordingMeta {
    /// [`FORMAT`].
    pub format: String,
    /// [`FRAME_LAYOUT`].
    pub frame_layout: String,
    /// Mission name.
    pub mission: String,
    /// Mission parameters.
    pub params: planner::Params,
    /// The scene file used.
    pub scene: SceneFile,
    /// The numerology.
    pub numerology: Numerology,
    /// Noise variance per complex sample, W.
    pub noise_power_w: f64,
    /// Complex samples per pulse.
    pub samples_per_pulse: usize,
    /// Apertures with their truth-side facts.
    pub apertures: Vec<ApertureTruth>,
    /// Warnings (e.g. a landmark outside the beam).
    pub warnings: Vec<String>,
}

/// Progress callback: (done, total).
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64);

fn mkdir(p: &Path) -> Result<()> {
    std::fs::create_dir_all(p).map_err(|e| RadarError::io(p, e))
}

fn iq_path(dir: &Path, ap: usize) -> PathBuf {
    dir.join("iq").join(format!("aperture_{ap:03}.npy"))
}

/// Frames of `run::simulate` hold at most this many bytes of IQ (and 100 pulses).
pub const SIMULATE_FRAME_BYTES: usize = 64 << 20;

/// Simulates the recording of `mission` flown along `traj` over the scene into `out`, refusing
/// a run above the default [`IqLimits`] (see [`simulate_limited`]).
pub fn simulate(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    scene: &SceneFile,
    out: &Path,
    progress: Progress<'_>,
) -> Result<RecordingMeta> {
    simulate_limited(mission, traj, scene, out, &IqLimits::default(), progress)
}

/// Simulates the recording of `mission` flown along `traj` over the scene into `out`. Before
/// anything is synthesised or written, the run's IQ and the memory of its largest aperture are
/// checked against `limits` ([`crate::limits::IqBudget`]).
pub fn simulate_limited(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    scene: &SceneFile,
    out: &Path,
    limits: &IqLimits,
    progress: Progress<'_>,
) -> Result<RecordingMeta> {
    let setup = RadarSetup::new(mission.params(), scene)?;
    let aps = setup.apertures(mission)?;
    IqBudget::new(&setup, &aps).check(&setup, limits)?;
    let objects = setup.objects(mission)?;
    let track = PlannedTrack::new(traj.clone(), mission.params().altitude_m);
    let synth = setup.synthesizer(objects.clone())?;
    mkdir(&out.join("iq"))?;
    let spp = synth.samples_per_pulse();
    let sample_bytes = crate::limits::IQ_SAMPLE_BYTES as usize;
    let frame_pulses = (SIMULATE_FRAME_BYTES / (spp * sample_bytes).max(1)).clamp(1, 100);
    let total: u64 = aps.iter().map(|a| a.pulses() as u64).sum();
    let mut done = 0u64;
    let mut pulse_rows = Vec::new();
    let mut truths = Vec::new();
    let mut warnings = Vec::new();
    for ap in &aps {
        let pulses = setup.pulses(&track, ap);
        let mid = &pulses[pulses.len() / 2];
        let landmark_gain_db = ap.landmark.map(|_| {
            let g = setup.antenna.gain_towards(
                mid.pos_m,
                mid.heading,
                [ap.centre_m[0], ap.centre_m[1], 0.0],
            );
            10.0 * (g / setup.antenna.peak_gain).log10()
        });
        if let Some(g) = landmark_gain_db {
            if g < -10.0 {
                warnings.push(format!(
                    "aperture {} (t = {:.1}..{:.1} s): landmark {:?} is {:.1} dB off the beam peak at mid-aperture",
                    ap.index, ap.t_start_s, ap.t_end_s, ap.landmark, g
                ));
            }
        }
        let pd = synth.direct_power_w(mid.pos_m, mid.heading);
        let pe: f64 = objects
            .iter()
            .map(|o| synth.echo_power_w(o, mid.pos_m, mid.heading))
            .sum();
        truths.push(ApertureTruth {
            aperture: ap.clone(),
            landmark_gain_db,
            direct_to_echo_db: 10.0 * (pd / pe.max(1e-300)).log10(),
            direct_to_noise_db: 10.0 * (pd / synth.noise_power_w()).log10(),
        });
        let mut w = NpyWriter::create(&iq_path(out, ap.index), NpyType::C8, &[pulses.len(), spp])?;
        crate::pipeline::synthesize_frames(
            &synth,
            &pulses,
            frame_pulses,
            Components::ALL,
            &mut |ps, iq| {
                w.write_c8(iq)?;
                done += ps.len() as u64;
                progress(done, total);
                Ok(())
            },
        )?;
        w.finish()?;
        for p in &pulses {
            pulse_rows.push(vec![
                p.index.to_string(),
                p.aperture.to_string(),
                p.look.to_string(),
                format!("{:.9}", p.t_s),
                p.symbol.to_string(),
                format!("{:.6}", p.pos_m[0]),
                format!("{:.6}", p.pos_m[1]),
                format!("{:.6}", p.pos_m[2]),
                format!("{:.6}", p.vel_mps[0]),
                format!("{:.6}", p.vel_mps[1]),
                format!("{:.6}", p.vel_mps[2]),
                format!("{:.12}", p.heading[0]),
                format!("{:.12}", p.heading[1]),
                p.window_delay_samples.to_string(),
            ]);
        }
    }
    if !truths.is_empty()
        && truths
            .iter()
            .all(|t| t.landmark_gain_db.is_some_and(|g| g < -10.0))
    {
        return Err(RadarError::Mismatch(format!(
            "no landmark is in the receive beam in any aperture (best {:.1} dB off the peak): the plan does not look at the scene",
            truths.iter().filter_map(|t| t.landmark_gain_db).fold(f64::NEG_INFINITY, f64::max)
        )));
    }
    write_csv(&out.join("pulses.csv"), &PULSE_COLUMNS, &pulse_rows)?;
    write_truth(&out.join("truth.csv"), &objects)?;
    let meta = RecordingMeta {
        format: FORMAT.into(),
        frame_layout: FRAME_LAYOUT.into(),
        mission: mission.name().to_string(),
        params: mission.params().clone(),
        scene: scene.clone(),
        numerology: setup.num.clone(),
        noise_power_w: synth.noise_power_w(),
        samples_per_pulse: spp,
        apertures: truths,
        warnings,
    };
    write_json(&out.join("meta.json"), &meta)?;
    Ok(meta)
}

const PULSE_COLUMNS: [&str; 14] = [
    "index",
    "aperture",
    "look",
    "t_s",
    "symbol",
    "x_m",
    "y_m",
    "z_m",
    "vx_mps",
    "vy_mps",
    "vz_mps",
    "heading_x",
    "heading_y",
    "window_delay_samples",
];

fn write_truth(path: &Path, objects: &[SceneObject]) -> Result<()> {
    let rows: Vec<Vec<String>> = objects
        .iter()
        .map(|o| {
            vec![
                o.id.to_string(),
                format!("{:.6}", o.x_m),
                format!("{:.6}", o.y_m),
                format!("{:.6e}", o.rcs_m2),
                format!("{:.9}", o.phase_rad),
                o.landmark.map(|l| l.to_string()).unwrap_or_default(),
            ]
        })
        .collect();
    write_csv(
        path,
        &["id", "x_m", "y_m", "rcs_m2", "phase_rad", "landmark"],
        &rows,
    )
}

/// Reads `truth.csv` (columns id,x_m,y_m,rcs_m2; phase_rad and landmark optional).
pub fn read_truth(path: &Path) -> Result<Vec<SceneObject>> {
    let (h, rows) = read_csv(path)?;
    rows.iter()
        .enumerate()
        .map(|(i, r)| {
            let line = i + 2;
            let phase = if h.iter().any(|c| c == "phase_rad") {
                csv_f64(path, &h, r, line, "phase_rad")?
            } else {
                0.0
            };
            let landmark = h
                .iter()
                .position(|c| c == "landmark")
                .and_then(|k| r.get(k))
                .and_then(|s| s.parse::<usize>().ok());
            Ok(SceneObject {
                id: csv_f64(path, &h, r, line, "id")? as usize,
                x_m: csv_f64(path, &h, r, line, "x_m")?,
                y_m: csv_f64(path, &h, r, line, "y_m")?,
                rcs_m2: csv_f64(path, &h, r, line, "rcs_m2")?,
                phase_rad: phase,
                landmark,
            })
        })
        .collect()
}

/// Reads `pulses.csv`.
pub fn read_pulses(path: &Path) -> Result<Vec<PulseMeta>> {
    let (h, rows) = read_csv(path)?;
    rows.iter()
        .enumerate()
        .map(|(i, r)| {
            let l = i + 2;
            let f = |c: &str| csv_f64(path, &h, r, l, c);
            Ok(PulseMeta {
                index: f("index")? as usize,
                aperture: f("aperture")? as usize,
                look: f("look")? as usize,
                t_s: f("t_s")?,
                symbol: f("symbol")? as u64,
                pos_m: [f("x_m")?, f("y_m")?, f("z_m")?],
                vel_mps: [f("vx_mps")?, f("vy_mps")?, f("vz_mps")?],
                heading: [f("heading_x")?, f("heading_y")?],
                window_delay_samples: f("window_delay_samples")? as i64,
            })
        })
        .collect()
}

/// A measured resolution with its predictions (for `metrics.json`). Every pair uses one
/// definition: the `*_m` widths without `cell` are −3 dB widths of the image's response (the
/// cell times the weighting's main-lobe factor), the `*_cell_m` ones the unweighted cells
/// c/(B|g|), 1/(T|∇f_D|) and the paper's δ (the planner's definition).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MeasuredResolution {
    /// Measured −3 dB width, m.
    pub measured_m: f64,
    /// −3 dB main-lobe factor of the weighting along this axis (0.886 none, 1.44 Hann).
    pub mainlobe_factor: f64,
    /// General prediction of the −3 dB width: the general cell × `mainlobe_factor`, m.
    pub predicted_general_m: f64,
    /// The paper's δ × `mainlobe_factor`: the −3 dB width its cell implies, m.
    pub paper_mainlobe_m: f64,
    /// The general cell (no factor), m.
    pub general_cell_m: f64,
    /// The paper's δ (no factor), m.
    pub paper_cell_m: f64,
}

/// Per-aperture summary in `metrics.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ApertureSummary {
    /// Aperture index.
    pub aperture: usize,
    /// Landmark index.
    pub landmark: Option<usize>,
    /// Landmark detected (matched within the gate); None when no truth object is the
    /// landmark (not scored).
    pub landmark_detected: Option<bool>,
    /// Expected per-look SNR of the landmark, dB.
    pub landmark_snr_db: Option<f64>,
    /// Detections.
    pub detections: usize,
    /// Unmatched detections.
    pub false_alarms: usize,
    /// Expected false-alarm detections on noise by design (see [`Metrics::design_false_alarms`]).
    pub design_false_alarms: f64,
    /// CFAR exceedance pixels among the clear pixels (see [`Metrics::false_alarm_pixels`]).
    pub false_alarm_pixels: usize,
    /// Clear pixels (noise only by the truth's predicted responses).
    pub clear_pixels: usize,
    /// Pixels tested against the image-wide noise estimate (too few training cells).
    pub cfar_fallback_pixels: usize,
    /// The image's noise floor as the CFAR estimated it, dB over thermal noise.
    pub image_floor_db: f64,
    /// The floor predicted from the truth (thermal noise + the inter-symbol interference of
    /// echoes beyond the cyclic prefix), dB over thermal noise.
    pub predicted_image_floor_db: f64,
    /// Canceller: direct-path suppression, dB ([`crate::cancel::CancelStats::dp_suppression_db`]);
    /// None without a direct path in the scene.
    pub dp_suppression_db: Option<f64>,
    /// Canceller: residual over the predicted echo + noise floor, dB (0 = no direct path left).
    pub residual_over_floor_db: f64,
    /// Canceller: residual over thermal noise (echoes included), dB.
    pub residual_to_noise_db: f64,
    /// Worst width of the unweighted resolution cell (1/B, 1/T: the planner's definition) at
    /// the landmark (SPEC §4 item 12), m.
    pub worst_width_m: f64,
    /// The same with the weightings' main-lobe factors: the worst −3 dB width of the image's
    /// response there, m.
    pub worst_width_mainlobe_m: f64,
}

/// `metrics.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Metrics {
    /// Detection probability over object-aperture pairs with expected SNR ≥ 13 dB: an object
    /// counts once per aperture whose image holds it.
    pub pd: f64,
    /// Object-aperture pairs with expected SNR ≥ 13 dB.
    pub strong_objects: usize,
    /// Detection probability over all object-aperture pairs in the images.
    pub pd_all: f64,
    /// Distinct objects with expected SNR ≥ 13 dB in at least one image.
    pub strong_distinct_objects: usize,
    /// Fraction of those detected in at least one image in which they are strong.
    pub pd_distinct: f64,
    /// Unmatched detections.
    pub false_alarms: usize,
    /// Expected unmatched detections on noise by design: the Euler-characteristic density of
    /// the multilook noise at the CFAR's threshold times the image area outside the truth
    /// objects' gates ([`crate::cfar::expected_peaks_per_m2`]).
    pub design_false_alarms: f64,
    /// CFAR exceedance pixels among the clear pixels: outside every truth object's gate, where
    /// the objects' predicted responses (sidelobes included) stay 10 dB below the thermal noise
    /// ([`crate::pipeline::CLEAR_SIGNAL`]).
    pub false_alarm_pixels: usize,
    /// Expected exceedance pixels there on noise: P_fa × the clear pixels.
    pub design_false_alarm_pixels: f64,
    /// Pixels tested against the image-wide noise estimate (too few training cells of their
    /// own); no pixel is left untested.
    pub cfar_fallback_pixels: usize,
    /// Pixels tested by the CFAR (every pixel of every image).
    pub cfar_pixels: usize,
    /// Mean position error of matched detections, m.
    pub mean_position_error_m: f64,
    /// Canceller: direct-path suppression, dB: the direct path's power before cancellation over
    /// the power the projection leaves of it (its measured copy through the same projection,
    /// [`crate::cancel::CancelStats::dp_suppression_db`]). None without a direct path.
    pub dp_suppression_db: Option<f64>,
    /// The direct path's power before cancellation over the predicted echo + noise floor, dB.
    /// None without a direct path.
    pub dp_over_floor_db: Option<f64>,
    /// Canceller: residual power after cancellation over the predicted echo + noise floor (the
    /// truth objects' link budget plus the thermal noise the projection keeps), dB: 0 when
    /// nothing of the direct path is left above the floor.
    pub residual_over_floor_db: f64,
    /// Canceller: mean power reduction P_in/P_out, dB (the echoes' share of the input bounds it).
    pub cancellation_db: f64,
    /// Canceller: mean residual over thermal noise, dB (echoes included).
    pub residual_to_noise_db: f64,
    /// Canceller: power loss of a target at the landmark delay, dB.
    pub target_loss_db: f64,
    /// Measured range resolution (along g) of the strongest landmark.
    pub range_resolution_m: Option<MeasuredResolution>,
    /// Measured azimuth resolution (along the Doppler gradient).
    pub azimuth_resolution_m: Option<MeasuredResolution>,
    /// Aperture and look of the resolution measurement.
    pub resolution_from: Option<(usize, usize)>,
    /// Per aperture.
    pub apertures: Vec<ApertureSummary>,
}

impl Metrics {
    /// One line on detection: Pd over object-aperture pairs and distinct objects, false alarms
    /// against their design counts, position error.
    pub fn detection_summary(&self) -> String {
        format!(
            "Pd {:.3} over {} object-aperture pairs ≥ 13 dB (per distinct object: {:.3} of {}), {} false alarms (expected from noise: {:.3}), mean error {:.2} m; CFAR: {} of {} pixels tested against the image-wide noise floor",
            self.pd,
            self.strong_objects,
            self.pd_distinct,
            self.strong_distinct_objects,
            self.false_alarms,
            self.design_false_alarms,
            self.mean_position_error_m,
            self.cfar_fallback_pixels,
            self.cfar_pixels
        )
    }

    /// One line on the canceller.
    pub fn canceller_summary(&self) -> String {
        let rest = format!(
            "residual {:+.2} dB over the predicted echo+noise floor ({:.2} dB over thermal noise), target loss {:.4} dB",
            self.residual_over_floor_db, self.residual_to_noise_db, self.target_loss_db
        );
        match (self.dp_suppression_db, self.dp_over_floor_db) {
            (Some(s), Some(f)) => format!(
                "direct-path suppression {s:.1} dB (the path was {f:.1} dB above the echo+noise floor), {rest}"
            ),
            _ => format!("no direct path in the scene; {rest}"),
        }
    }

    /// One line on the measured resolution, if measured: −3 dB widths against the general
    /// prediction and the paper's δ, both × the main-lobe factor, then the cells.
    pub fn resolution_summary(&self) -> Option<String> {
        let (r, a) = (
            self.range_resolution_m.as_ref()?,
            self.azimuth_resolution_m.as_ref()?,
        );
        Some(format!(
            "resolution (−3 dB, main-lobe factors {:.3}/{:.3}): range {:.3} m (general {:.3}, paper {:.3}), azimuth {:.3} m (general {:.3}, paper {:.3}); cells without the factor: range general {:.3}, paper {:.3}; azimuth general {:.3}, paper {:.3}",
            r.mainlobe_factor,
            a.mainlobe_factor,
            r.measured_m,
            r.predicted_general_m,
            r.paper_mainlobe_m,
            a.measured_m,
            a.predicted_general_m,
            a.paper_mainlobe_m,
            r.general_cell_m,
            r.paper_cell_m,
            a.general_cell_m,
            a.paper_cell_m
        ))
    }
}

/// One row of `detections.csv`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DetectionRow {
    /// Aperture.
    pub aperture: usize,
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// SNR over the local noise, dB.
    pub snr_db: f64,
    /// Pixels.
    pub pixels: usize,
    /// Matched truth id.
    pub truth_id: Option<usize>,
    /// Distance to the matched truth, m.
    pub error_m: Option<f64>,
}

/// Processes the recording in `input` into `out`, refusing apertures above the default
/// [`IqLimits`] (see [`process_limited`]).
pub fn process(input: &Path, out: &Path, progress: Progress<'_>) -> Result<Metrics> {
    process_limited(input, out, &IqLimits::default(), progress)
}

/// Processes the recording in `input` into `out`. Each aperture is held in memory at once, so
/// before anything is read, the memory of the largest one is checked against
/// `limits.max_aperture_bytes` (the recording's total size does not matter here).
pub fn process_limited(
    input: &Path,
    out: &Path,
    limits: &IqLimits,
    progress: Progress<'_>,
) -> Result<Metrics> {
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
    let setup = RadarSetup::new(&meta.params, &meta.scene)?;
    let aps: Vec<Aperture> = meta.apertures.iter().map(|a| a.aperture.clone()).collect();
    let budget = IqBudget::new(&setup, &aps);
    if budget.samples_per_pulse != meta.samples_per_pulse as u64 {
        return Err(RadarError::format(
            meta_path.display().to_string(),
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
        let mut rd = NpyReader::open(&iq_path(input, ap.index))?;
        if rd.shape != [pulses.len(), meta.samples_per_pulse] {
            return Err(RadarError::format(
                iq_path(input, ap.index).display().to_string(),
                "shape",
                format!(
                    "{:?}, expected [{}, {}]",
                    rd.shape,
                    pulses.len(),
                    meta.samples_per_pulse
                ),
            ));
        }
        let iq: Vec<Complex32> = rd.read_c8(0, pulses.len() * meta.samples_per_pulse)?;
        let r = proc.process_aperture(ap, &pulses, &iq, &truth)?;
        // images
        let mut w = NpyWriter::create(
            &out.join("images")
                .join(format!("aperture_{:03}.npy", ap.index)),
            NpyType::F4,
            &[r.grid.ny, r.grid.nx],
        )?;
        w.write_f4(&r.multilook)?;
        w.finish()?;
        for (l, img) in r.looks.iter().enumerate() {
            let mut w = NpyWriter::create(
                &out.join("images")
                    .join(format!("aperture_{:03}_look_{l:02}.npy", ap.index)),
                NpyType::C8,
                &[r.grid.ny, r.grid.nx],
            )?;
            w.write_c8(img)?;
            w.finish()?;
        }
        let markers = tally::detection_pixels(&r);
        let png_name = format!("aperture_{:03}.png", ap.index);
        write_png_db(
            &out.join("images").join(&png_name),
            &r.multilook,
            r.grid.nx,
            r.grid.ny,
            IMAGE_RANGE_DB,
            &markers,
        )?;
        write_image_svg(
            &out.join("images")
                .join(format!("aperture_{:03}.svg", ap.index)),
            &png_name,
            &ImageFrame {
                aperture: ap.index,
                centre_m: r.grid.centre_m,
                spacing_m: r.grid.spacing_m,
                nx: r.grid.nx,
                ny: r.grid.ny,
            },
            &r.multilook,
            IMAGE_RANGE_DB,
        )?;
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

/// Writes `detections.csv` and `detections.json` into `out`.
pub fn write_detections(out: &Path, rows: &[DetectionRow]) -> Result<()> {
    let csv: Vec<Vec<String>> = rows
        .iter()
        .map(|d| {
            vec![
                d.aperture.to_string(),
                format!("{:.3}", d.x_m),
                format!("{:.3}", d.y_m),
                format!("{:.2}", d.snr_db),
                d.pixels.to_string(),
                d.truth_id.map(|v| v.to_string()).unwrap_or_default(),
                d.error_m.map(|v| format!("{v:.3}")).unwrap_or_default(),
            ]
        })
        .collect();
    write_csv(
        &out.join("detections.csv"),
        &[
            "aperture", "x_m", "y_m", "snr_db", "pixels", "truth_id", "error_m",
        ],
        &csv,
    )?;
    write_json(&out.join("detections.json"), &rows)
}

/// Closed-loop report row: one aperture.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopRow {
    /// Aperture.
    pub aperture: usize,
    /// Landmark.
    pub landmark: Option<usize>,
    /// Fraction of the window's slots in which the plan keeps the landmark in view.
    pub in_view_fraction: f64,
    /// Landmark detected; None when no truth object is the landmark (a scene without
    /// landmark objects): not scored.
    pub detected: Option<bool>,
    /// Expected per-look SNR, dB.
    pub snr_db: Option<f64>,
}

/// A landmark counts as in view of its aperture when the plan keeps it in view in at least this
/// fraction of its window's slots; such a landmark must be detected.
pub const IN_VIEW_MIN_FRACTION: f64 = 0.5;

impl LoopRow {
    /// The landmark was in view (≥ [`IN_VIEW_MIN_FRACTION`] of its window), scored, and not
    /// detected.
    pub fn missed_in_view(&self) -> bool {
        self.in_view_fraction >= IN_VIEW_MIN_FRACTION && self.detected == Some(false)
    }

    /// `true`, `false`, or `-` when not scored.
    pub fn detected_label(&self) -> &'static str {
        match self.detected {
            Some(true) => "true",
            Some(false) => "false",
            None => "-",
        }
    }
}

/// The closed-loop report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopReport {
    /// Mission name.
    pub mission: String,
    /// Plan energy on the exact geometry, J.
    pub energy_j: f64,
    /// Per aperture.
    pub rows: Vec<LoopRow>,
    /// Every scored landmark in view (≥ [`IN_VIEW_MIN_FRACTION`] of its window) was
    /// detected (true when none was scored).
    pub all_in_view_detected: bool,
    /// Landmark windows scored (the landmark is a truth object of its image).
    pub landmarks_scored: usize,
    /// Processing metrics.
    pub metrics: Metrics,
}

/// In-view fraction per landmark window from the plan's exact evaluation.
pub fn in_view_fractions(mission: &planner::Mission, eval: &planner::Evaluation) -> Vec<f64> {
    let n = mission.schedule().landmarks.len();
    let mut count = vec![0usize; n];
    let mut inv = vec![0usize; n];
    for (s, lm) in eval.slots.iter().zip(&mission.schedule().slot_landmark) {
        if let Some(l) = lm {
            count[*l] += 1;
            if s.in_view {
                inv[*l] += 1;
            }
        }
    }
    count
        .iter()
        .zip(&inv)
        .map(|(c, i)| if *c > 0 { *i as f64 / *c as f64 } else { 0.0 })
        .collect()
}

/// Builds the loop report from a processed run.
pub fn loop_report(
    mission: &planner::Mission,
    eval: &planner::Evaluation,
    metrics: Metrics,
) -> LoopReport {
    let frac = in_view_fractions(mission, eval);
    let rows: Vec<LoopRow> = metrics
        .apertures
        .iter()
        .map(|a| LoopRow {
            aperture: a.aperture,
            landmark: a.landmark,
            in_view_fraction: a.landmark.and_then(|l| frac.get(l).copied()).unwrap_or(0.0),
            detected: a.landmark_detected,
            snr_db: a.landmark_snr_db,
        })
        .collect();
    LoopReport {
        mission: mission.name().to_string(),
        energy_j: eval.energy_j,
        all_in_view_detected: !rows.iter().any(LoopRow::missed_in_view),
        landmarks_scored: rows.iter().filter(|r| r.detected.is_some()).count(),
        rows,
        metrics,
    }
}

/// Cuts `mission` to the windows that end within `horizon_s` and sets the horizon.
///
/// `horizon_s` must be a finite number > 0 that holds at least one whole landmark window
/// (a [`RadarError::Config`] naming `horizon_s` otherwise).
pub fn shorten(mission: &planner::Mission, horizon_s: f64) -> Result<planner::Mission> {
    if !(horizon_s.is_finite() && horizon_s > 0.0) {
        return Err(RadarError::config(
            "horizon_s",
            format!("{horizon_s}: must be a finite number > 0"),
        ));
    }
    let mut file = mission.to_file_struct();
    let keep: Vec<planner::LandmarkWindow> = mission
        .schedule()
        .landmarks
        .iter()
        .filter(|w| w.to_s <= horizon_s + 1e-9)
        .copied()
        .collect();
    if keep.is_empty() {
        return Err(RadarError::config(
            "horizon_s",
            format!("{horizon_s} s holds no whole landmark window"),
        ));
    }
    file.landmarks = planner::LandmarksSpec {
        points: Some(keep),
        ..Default::default()
    };
    file.params.horizon_s = Some(horizon_s);
    planner::Mission::from_file_struct(&file)
        .map_err(|e| RadarError::config("mission", e.to_string()))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::{shorten, LoopRow, IN_VIEW_MIN_FRACTION};

    #[test]
    fn shorten_keeps_whole_windows_and_names_a_bad_horizon() {
        let m = planner::Mission::preset(planner::Preset::Default, 30.0).unwrap();
        let short = shorten(&m, 25.0).unwrap();
        assert_eq!(short.schedule().landmarks.len(), 2);
        assert_eq!(short.params().horizon_s, 25.0);
        for bad in [f64::NAN, f64::INFINITY, -10.0, 0.0, 5.0] {
            let e = shorten(&m, bad).unwrap_err();
            assert!(e.is_bad_input(), "{bad}: {e:?}");
            assert!(e.to_string().contains("horizon_s"), "{bad}: {e}");
        }
        let e = shorten(&m, f64::NAN).unwrap_err().to_string();
        assert!(e.contains("finite"), "{e}");
    }

    fn row(in_view_fraction: f64, detected: Option<bool>) -> LoopRow {
        LoopRow {
            aperture: 0,
            landmark: Some(0),
            in_view_fraction,
            detected,
            snr_db: None,
        }
    }

    #[test]
    fn a_miss_counts_only_when_the_plan_keeps_the_landmark_in_view() {
        assert!(row(1.0, Some(false)).missed_in_view());
        assert!(row(IN_VIEW_MIN_FRACTION, Some(false)).missed_in_view());
        assert!(!row(IN_VIEW_MIN_FRACTION - 0.01, Some(false)).missed_in_view());
        assert!(!row(1.0, Some(true)).missed_in_view());
        assert!(!row(0.0, Some(true)).missed_in_view());
    }

    /// A landmark that is no truth object (`include_landmarks = false`) is not scored: in
    /// view, it is no miss.
    #[test]
    fn a_landmark_without_a_truth_object_is_not_scored() {
        let r = row(1.0, None);
        assert!(!r.missed_in_view());
        assert_eq!(r.detected_label(), "-");
    }
}
