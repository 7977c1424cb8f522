//! Bounds on what a run may produce, checked before anything is simulated: the IQ of a whole
//! recording (what `simulate` writes to disk, what the echo service streams) and the memory of
//! one aperture (what `process` and the processor service hold at once: its IQ, plus its look
//! images with `processing.save_complex`).
//!
//! The IQ of a run is `Σ_apertures pulses × samples_per_pulse × 8` bytes (complex64), with
//! `pulses = looks × round(look_s × prf_hz)` per landmark window and `samples_per_pulse =
//! symbols_per_pulse × fft_size`. The default scene on the 300-s default missions makes
//! 30 000 pulses × 4096 samples = 0.92 GiB, 31 MiB per aperture (every mission in `missions/`
//! makes at most 1.8 GiB); the defaults ([`DEFAULT_MAX_IQ_GIB`] = 16 GiB,
//! [`DEFAULT_MAX_APERTURE_GIB`] = 2 GiB) leave a margin of 17× and 64×, and are raised with
//! `--max-iq-gib` / `--max-aperture-gib`.

use serde::{Deserialize, Serialize};

use crate::error::{RadarError, Result};
use crate::pipeline::RadarSetup;
use crate::track::Aperture;

/// Bytes in a GiB.
pub const GIB: f64 = (1u64 << 30) as f64;

/// Bytes of one complex64 IQ sample.
pub const IQ_SAMPLE_BYTES: u64 = 8;

/// Default largest IQ of a whole run, GiB (`--max-iq-gib`).
pub const DEFAULT_MAX_IQ_GIB: f64 = 16.0;

/// Default largest memory of one aperture (IQ + saved complex looks), GiB
/// (`--max-aperture-gib`).
pub const DEFAULT_MAX_APERTURE_GIB: f64 = 2.0;

/// The limits a run is checked against.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IqLimits {
    /// Largest IQ of the whole run, bytes.
    pub max_total_bytes: u64,
    /// Largest memory of one aperture, bytes.
    pub max_aperture_bytes: u64,
}

impl Default for IqLimits {
    fn default() -> Self {
        Self {
            max_total_bytes: (DEFAULT_MAX_IQ_GIB * GIB) as u64,
            max_aperture_bytes: (DEFAULT_MAX_APERTURE_GIB * GIB) as u64,
        }
    }
}

impl IqLimits {
    /// Limits from GiB values; the error names the option (`--max-iq-gib`,
    /// `--max-aperture-gib`) when a value is not a positive finite number.
    pub fn from_gib(max_iq_gib: f64, max_aperture_gib: f64) -> Result<Self> {
        let bytes = |flag: &str, v: f64| -> Result<u64> {
            if v.is_finite() && v > 0.0 {
                // f64 → u64 saturates; 2^64 bytes is no real limit anyway
                Ok((v * GIB) as u64)
            } else {
                Err(RadarError::config(
                    flag,
                    format!("{v} is not a positive number of GiB"),
                ))
            }
        };
        Ok(Self {
            max_total_bytes: bytes("--max-iq-gib", max_iq_gib)?,
            max_aperture_bytes: bytes("--max-aperture-gib", max_aperture_gib)?,
        })
    }
}

/// `bytes` in GiB, with three significant digits below 1 GiB.
fn gib(bytes: u64) -> String {
    let v = bytes as f64 / GIB;
    if v >= 1.0 {
        format!("{v:.1}")
    } else if v >= 1e-3 {
        format!("{v:.3}")
    } else {
        format!("{v:.2e}")
    }
}

/// What a run will produce, from the apertures alone (before simulating).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IqBudget {
    /// Pulses of all apertures.
    pub pulses: u64,
    /// Complex samples per pulse.
    pub samples_per_pulse: u64,
    /// Seconds of apertures (looks × look length, summed).
    pub aperture_s: f64,
    /// IQ of all apertures, bytes.
    pub total_bytes: u64,
    /// The aperture that needs the most memory, and its bytes (IQ + saved looks).
    pub largest_aperture: Option<(usize, u64)>,
    /// Its IQ alone, bytes.
    pub largest_aperture_iq_bytes: u64,
    /// Bytes of one complex look image (kept per look with `processing.save_complex`).
    pub look_image_bytes: u64,
}

impl IqBudget {
    /// The budget of `apertures` under `setup`'s scene.
    pub fn new(setup: &RadarSetup, apertures: &[Aperture]) -> Self {
        let radar = &setup.scene.radar;
        let pc = &setup.scene.processing;
        let spp = radar.samples_per_pulse() as u64;
        let side = pc.grid_side_px().max(0.0) as u64;
        let look_image_bytes = side.saturating_mul(side).saturating_mul(IQ_SAMPLE_BYTES);
        let mut b = Self {
            pulses: 0,
            samples_per_pulse: spp,
            aperture_s: 0.0,
            total_bytes: 0,
            largest_aperture: None,
            largest_aperture_iq_bytes: 0,
            look_image_bytes,
        };
        for ap in apertures {
            let pulses = ap.pulses() as u64;
            let iq = pulses.saturating_mul(spp).saturating_mul(IQ_SAMPLE_BYTES);
            let images = if pc.save_complex {
                (ap.looks as u64).saturating_mul(look_image_bytes)
            } else {
                0
            };
            let mem = iq.saturating_add(images);
            b.pulses = b.pulses.saturating_add(pulses);
            b.total_bytes = b.total_bytes.saturating_add(iq);
            b.aperture_s += ap.looks as f64 * ap.look_s;
            if b.largest_aperture.is_none_or(|(_, m)| mem > m) {
                b.largest_aperture = Some((ap.index, mem));
                b.largest_aperture_iq_bytes = iq;
            }
        }
        b
    }

    /// Refuses the run when it exceeds either limit ([`IqBudget::check_total`],
    /// [`IqBudget::check_aperture`]).
    pub fn check(&self, setup: &RadarSetup, limits: &IqLimits) -> Result<()> {
        self.check_total(setup, limits)?;
        self.check_aperture(limits)
    }

    /// Refuses the run when its IQ exceeds `limits.max_total_bytes`; the error names the scene
    /// fields that set the size and the option that raises the limit.
    pub fn check_total(&self, setup: &RadarSetup, limits: &IqLimits) -> Result<()> {
        let radar = &setup.scene.radar;
        if self.total_bytes > limits.max_total_bytes {
            return Err(RadarError::config(
                "radar.prf_hz",
                format!(
                    "the run would make {} GiB of IQ, above the limit of {} GiB: {} s of \
                     apertures × prf_hz {} Hz = {} pulses × {} samples (symbols_per_pulse {} × \
                     fft_size {}) × 8 bytes; lower radar.prf_hz, radar.symbols_per_pulse or \
                     radar.fft_size, shorten the mission, or raise the limit with --max-iq-gib",
                    gib(self.total_bytes),
                    gib(limits.max_total_bytes),
                    self.aperture_s,
                    radar.prf_hz,
                    self.pulses,
                    self.samples_per_pulse,
                    radar.symbols_per_pulse,
                    radar.fft_size
                ),
            ));
        }
        Ok(())
    }

    /// Refuses the run when one aperture needs more than `limits.max_aperture_bytes` of
    /// memory; the error names the scene field that sets the size and the option that raises
    /// the limit.
    pub fn check_aperture(&self, limits: &IqLimits) -> Result<()> {
        if let Some((index, mem)) = self.largest_aperture {
            if mem > limits.max_aperture_bytes {
                let images = mem - self.largest_aperture_iq_bytes;
                let (field, detail) = if images > self.largest_aperture_iq_bytes {
                    (
                        "processing.save_complex",
                        format!(
                            "{} GiB of saved complex look images ({} MiB each; turn off \
                             processing.save_complex, or raise processing.pixel_m or lower \
                             processing.grid_half_m) and {} GiB of IQ",
                            gib(images),
                            self.look_image_bytes >> 20,
                            gib(self.largest_aperture_iq_bytes)
                        ),
                    )
                } else {
                    (
                        "radar.prf_hz",
                        format!(
                            "{} GiB of IQ (lower radar.prf_hz, radar.symbols_per_pulse or \
                             radar.fft_size)",
                            gib(self.largest_aperture_iq_bytes)
                        ),
                    )
                };
                return Err(RadarError::config(
                    field,
                    format!(
                        "aperture {index} would need {} GiB of memory, above the limit of \
                         {} GiB: {detail}; or raise the limit with --max-aperture-gib",
                        gib(mem),
                        gib(limits.max_aperture_bytes)
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The budget of `mission` under `setup`, checked against `limits` (planning, simulating and
/// processing need nothing more than the mission's landmark windows and the scene).
pub fn check_mission(
    setup: &RadarSetup,
    mission: &planner::Mission,
    limits: &IqLimits,
) -> Result<IqBudget> {
    let aps = setup.apertures(mission)?;
    let b = IqBudget::new(setup, &aps);
    b.check(setup, limits)?;
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SceneFile;

    fn mission() -> planner::Mission {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        planner::Mission::from_path(&root.join("../missions/default-30m.toml")).unwrap()
    }

    fn scene() -> SceneFile {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        SceneFile::from_path(&root.join("scenes/default.toml")).unwrap()
    }

    #[test]
    fn the_default_run_is_well_within_the_limits() {
        let m = mission();
        let setup = RadarSetup::new(m.params(), &scene()).unwrap();
        let b = check_mission(&setup, &m, &IqLimits::default()).unwrap();
        // 30 windows of 10 s at 100 Hz, 4096 samples per pulse
        assert_eq!(b.pulses, 30_000);
        assert_eq!(b.total_bytes, 30_000 * 4096 * 8);
        assert!(
            b.total_bytes as f64 / GIB < DEFAULT_MAX_IQ_GIB / 16.0,
            "{b:?}"
        );
        let (_, ap) = b.largest_aperture.unwrap();
        assert!((ap as f64 / GIB) < DEFAULT_MAX_APERTURE_GIB / 64.0, "{b:?}");
    }

    #[test]
    fn a_run_above_the_limit_is_refused_naming_the_field_and_the_option() {
        let m = mission();
        let mut sc = scene();
        sc.radar.prf_hz = 40_000.0; // below the symbol rate, but 400× the IQ
        let setup = RadarSetup::new(m.params(), &sc).unwrap();
        let e = check_mission(&setup, &m, &IqLimits::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("radar.prf_hz") && e.contains("GiB of IQ") && e.contains("--max-iq-gib"),
            "{e}"
        );
        // raised limits let it through
        let big = IqLimits::from_gib(1e4, 1e3).unwrap();
        check_mission(&setup, &m, &big).unwrap();
        // one aperture above its own limit
        let small = IqLimits::from_gib(1e4, 1.0).unwrap();
        let e = check_mission(&setup, &m, &small).unwrap_err().to_string();
        assert!(
            e.contains("aperture 0") && e.contains("--max-aperture-gib"),
            "{e}"
        );
    }

    #[test]
    fn saved_complex_looks_count_towards_an_aperture() {
        let m = mission();
        let mut sc = scene();
        sc.processing.save_complex = true;
        sc.processing.grid_half_m = 800.0; // 4001² pixels: 122 MiB per look, 10 looks
        let setup = RadarSetup::new(m.params(), &sc).unwrap();
        let e = check_mission(&setup, &m, &IqLimits::from_gib(16.0, 1.0).unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("processing.save_complex"), "{e}");
    }

    #[test]
    fn bad_limits_name_the_flag() {
        let e = IqLimits::from_gib(f64::NAN, 1.0).unwrap_err().to_string();
        assert!(e.contains("--max-iq-gib"), "{e}");
        let e = IqLimits::from_gib(1.0, 0.0).unwrap_err().to_string();
        assert!(e.contains("--max-aperture-gib"), "{e}");
    }
}
