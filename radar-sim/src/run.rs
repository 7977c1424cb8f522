//! The file-level steps behind the CLI: `simulate` (plan directory + scene → raw IQ, truth),
//! `process` (recording → images, detections, metrics) and `closed_loop` (mission → plan →
//! simulate → process → report); [`landmark_snrs`] gives the closed loop's expected landmark
//! SNRs of a plan without synthesising it. Every step streams one aperture at a time, so memory
//! stays bounded by one aperture's IQ (~33 MB for 10 s at the defaults) whatever the mission
//! length.
//!
//! Modules: [`simulate`](simulate_limited) writes a recording, [`process`](process_limited)
//! reads one; the recording's CSV tables (`pulses.csv`, `truth.csv`, `detections.csv`) are
//! read and written in `recording`; `metrics.json` is [`Metrics`]; the closed loop's report is
//! [`LoopReport`].

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::config::SceneFile;
use crate::error::{RadarError, Result};
use crate::io::ImageFrame;
use crate::track::Aperture;
use crate::waveform::Numerology;

mod closed_loop;
mod metrics;
mod process;
mod recording;
mod simulate;
mod snr;

pub use closed_loop::{
    in_view_fractions, loop_report, shorten, LoopReport, LoopRow, IN_VIEW_MIN_FRACTION,
};
pub use metrics::{ApertureSummary, DetectionRow, MeasuredResolution, Metrics};
pub use process::{process, process_limited};
pub use recording::{
    object_as_recorded, pulse_as_recorded, read_pulses, read_truth, write_detections,
};
pub use simulate::{
    planned_track, simulate, simulate_limited, simulate_profile_limited, SIMULATE_FRAME_BYTES,
};
pub use snr::{landmark_snrs, LandmarkSnr, SnrSummary};

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

/// What the caller adds to each aperture's images once their NPY and PNG are written: called
/// with the images directory, where the image lies and its multilook power (the apps layer
/// writes the annotated SVG view there; [`no_image_views`] adds nothing).
pub type ImageViews<'a> = &'a mut dyn FnMut(&Path, &ImageFrame, &[f32]) -> Result<()>;

/// An [`ImageViews`] that adds nothing.
pub fn no_image_views(_dir: &Path, _frame: &ImageFrame, _power: &[f32]) -> Result<()> {
    Ok(())
}

fn mkdir(p: &Path) -> Result<()> {
    std::fs::create_dir_all(p).map_err(|e| RadarError::io(p, e))
}

fn iq_path(dir: &Path, ap: usize) -> PathBuf {
    dir.join("iq").join(format!("aperture_{ap:03}.npy"))
}
