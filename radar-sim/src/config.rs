//! The scene file (`SCENE.toml`): objects, radar and processing settings, with documented
//! defaults and validation that names the offending field.
//!
//! ```toml
//! [objects]            # homogeneous Poisson objects in a disk (+ the mission's landmarks)
//! count = 40           # or intensity_per_km2 = 50
//! radius_m = 300.0
//! center_m = [200.0, 200.0]   # default: centre of the landmarks' bounding box
//! seed = 1
//! min_separation_m = 20.0     # default: the mission's d_min
//! rcs_m2 = 10.0
//! include_landmarks = true
//!
//! [radar]              # waveform, PRF, link budget, antenna, motion model
//! prf_hz = 100.0
//! subcarrier_spacing_hz = 60e3
//! fft_size = 4096
//! cp_samples = 1024
//!
//! reference = "ideal"  # or "pilots" / "reconstructed" (with [radar.nr])
//!
//! [radar.nr]           # optional: the 5G NR cell that illuminates (numerology, PRBs, TDD,
//! numerology = 2       # reference signals, load, QAM orders, the pulse's slot and symbols)
//! tdd_pattern = "DDDSU"
//!
//! [processing]         # canceller, range filter, backprojection grid, CFAR
//! canceller = "eca-b"
//!
//! [clutter]            # optional: constant-γ ground clutter under the objects (off by default)
//! enabled = true
//! terrain = "farmland"
//! ```

use serde::{Deserialize, Serialize};

use crate::error::{RadarError, Result};

mod clutter;
mod nr;
mod objects;
mod processing;
mod radar;

pub use clutter::{ClutterConfig, Terrain, MAX_SCATTERERS_PER_CELL};
pub use nr::{NrConfig, NR_PREFIX};
pub use objects::ObjectsConfig;
pub use processing::{
    CancellerKind, ProcessingConfig, RangeFilter, Weighting, DEFAULT_GUARD_BAND_M,
    GUARD_BAND_PIXEL_FACTOR,
};
pub use radar::{
    BsAntennaConfig, Modulation, MotionModel, RadarConfig, MAX_BANDWIDTH_HZ,
    MAX_SUBCARRIER_SPACING_HZ, MIN_SUBCARRIER_SPACING_HZ,
};

/// Boltzmann constant, J/K.
pub const BOLTZMANN_J_PER_K: f64 = 1.380_649e-23;

/// Most objects a scene may hold (`objects.count`, or the mean of `objects.intensity_per_km2`
/// over the disk).
pub const MAX_OBJECTS: usize = 1_000_000;

/// Most complex samples in one pulse, `symbols_per_pulse × fft_size` (2^20: 8 MiB of IQ per
/// pulse; the default is 4096).
pub const MAX_SAMPLES_PER_PULSE: usize = 1 << 20;

/// Most samples of an upsampled range profile, `fft_size × upsample` (2^22: 64 MiB per
/// profile buffer; the default is 32768).
pub const MAX_PROFILE_SAMPLES: usize = 1 << 22;

/// Most pixels on a side of the image grid, `2 round(grid_half_m / pixel_m) + 1` (4097: one
/// look image is then 128 MiB, the CFAR's work arrays about 1 GiB; the default is 251).
pub const MAX_GRID_SIDE_PX: usize = 4097;

/// Most pixels of a CFAR guard or training band (`processing.cfar_guard_px`,
/// `processing.cfar_train_px`): the grid's side.
pub const MAX_CFAR_BAND_PX: usize = MAX_GRID_SIDE_PX;

/// A whole scene file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SceneFile {
    /// `[objects]`.
    pub objects: ObjectsConfig,
    /// `[radar]`.
    pub radar: RadarConfig,
    /// `[processing]`.
    pub processing: ProcessingConfig,
    /// `[clutter]` (left out when serialised at its defaults: clutter off).
    #[serde(skip_serializing_if = "ClutterConfig::is_default")]
    pub clutter: ClutterConfig,
}

fn finite(field: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(RadarError::config(
            field,
            format!("{v} is not a finite number"),
        ))
    }
}

fn positive(field: &str, v: f64) -> Result<()> {
    finite(field, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(RadarError::config(field, format!("{v} must be > 0")))
    }
}

fn non_negative(field: &str, v: f64) -> Result<()> {
    finite(field, v)?;
    if v >= 0.0 {
        Ok(())
    } else {
        Err(RadarError::config(field, format!("{v} must be >= 0")))
    }
}

impl SceneFile {
    /// Parses a TOML scene; the error names the file and the field.
    pub fn from_toml_str(text: &str, path: &str) -> Result<Self> {
        let s: SceneFile =
            toml::from_str(text).map_err(|e| RadarError::format(path, "TOML", e.to_string()))?;
        s.validate()?;
        Ok(s)
    }

    /// Reads and validates a scene file.
    pub fn from_path(path: &std::path::Path) -> Result<Self> {
        let text = planner::files::read_text_bounded(path, planner::files::MAX_INPUT_FILE_BYTES)
            .map_err(|e| RadarError::read(path, e))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The scene's digest: FNV-1a (64 bits) of its canonical JSON form, every value in a fixed
    /// order with the defaults filled in, so that two files describing the same scene
    /// (comments, key order, defaults written out or left out) have the same digest and any
    /// changed value gives another. Every process of a mission must read the same scene: the
    /// digest travels with the aperture requests and the IQ frames, and a mismatch is refused
    /// by name. Never 0 ([`SceneFile::NO_DIGEST`] marks a frame of no scene).
    pub fn digest(&self) -> u64 {
        // serialising plain data to a string cannot fail; the name keeps a failure distinct
        let text = serde_json::to_string(self).unwrap_or_else(|e| format!("unserialisable: {e}"));
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in b"cellsar scene 1\0".iter().chain(text.as_bytes()) {
            h ^= u64::from(*b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        h.max(1)
    }

    /// The digest of no scene (a frame of a tool that names none).
    pub const NO_DIGEST: u64 = 0;

    /// Checks every table, and the values that depend on several (the upsampled range
    /// profile, `fft_size × upsample`, is at most [`MAX_PROFILE_SAMPLES`]).
    pub fn validate(&self) -> Result<()> {
        self.objects.validate()?;
        self.radar.validate()?;
        self.processing.validate()?;
        self.clutter.validate()?;
        let profile = self.radar.fft_size.saturating_mul(self.processing.upsample);
        if profile > MAX_PROFILE_SAMPLES {
            return Err(RadarError::config(
                "processing.upsample",
                format!(
                    "{} × radar.fft_size = {} makes range profiles of {profile} samples (at most \
                     {MAX_PROFILE_SAMPLES})",
                    self.processing.upsample, self.radar.fft_size
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
