//! The `[processing]` table: canceller, range filter, weightings, backprojection grid, CFAR;
//! and its validation.

use serde::{Deserialize, Serialize};

use super::{finite, non_negative, positive, MAX_CFAR_BAND_PX, MAX_GRID_SIDE_PX};
use crate::error::{RadarError, Result};

/// Direct-path canceller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CancellerKind {
    /// No cancellation.
    None,
    /// ECA: one set of weights for all pulses of a look (coherent processing interval).
    Eca,
    /// ECA-B: one set of weights per batch of `batch_pulses` pulses.
    EcaB,
}

/// Range-compression filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RangeFilter {
    /// Matched filter: multiply by conj(X) per subcarrier (best SNR; data-dependent sidelobes
    /// with QAM).
    Matched,
    /// OFDM reciprocal filter: divide by X per subcarrier (data-independent sinc response).
    Reciprocal,
}

/// Amplitude weighting (taper) of a spectrum or an aperture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Weighting {
    /// Uniform: −3 dB main-lobe width 0.886 / bandwidth, −13.3 dB sidelobes.
    None,
    /// Hann: width 1.44 / bandwidth, −31.5 dB sidelobes.
    Hann,
    /// Hamming: width 1.30 / bandwidth, −42.7 dB sidelobes.
    Hamming,
}

impl Weighting {
    /// Coherence factor ∫W⁴ / (∫W²)² (W normalised to unit length): the intensity
    /// correlation length of the response in units of 1/bandwidth (1 for none).
    pub fn coherence_factor(self) -> f64 {
        let n = 4096;
        let w = self.weights(n);
        let s2: f64 = w.iter().map(|x| x * x).sum::<f64>() / n as f64;
        let s4: f64 = w.iter().map(|x| x.powi(4)).sum::<f64>() / n as f64;
        s4 / (s2 * s2)
    }

    /// The taper as `a0 − a1 cos(2πx)`, x ∈ [0, 1] across the band (or the aperture).
    fn cosine_coefficients(self) -> (f64, f64) {
        match self {
            Weighting::None => (1.0, 0.0),
            Weighting::Hann => (0.5, 0.5),
            Weighting::Hamming => (0.54, 0.46),
        }
    }

    /// Amplitude of the point response at `u` resolution units (1/bandwidth) from its peak,
    /// normalised to 1 at the peak (continuous taper): `(a0 sinc u + a1/2 (sinc(u−1) +
    /// sinc(u+1))) / a0`, first null at 1 (none) or 2 (Hann, Hamming).
    pub fn amplitude_response(self, u: f64) -> f64 {
        let sinc = |x: f64| {
            if x.abs() < 1e-12 {
                1.0
            } else {
                let px = std::f64::consts::PI * x;
                px.sin() / px
            }
        };
        let (a0, a1) = self.cosine_coefficients();
        (a0 * sinc(u) + 0.5 * a1 * (sinc(u - 1.0) + sinc(u + 1.0))) / a0
    }

    /// Second moment `∫ x² w(x)² dx / ∫ w(x)² dx` (x ∈ [−1/2, 1/2]) of the squared taper, the
    /// noise's power spectrum across the band: `4π²` times it is the curvature −ρ''(0) of the
    /// noise's correlation in resolution units (1/12 for none, 0.0200 for Hann).
    pub fn spectral_second_moment(self) -> f64 {
        let n = 4096;
        let w = self.weights(n);
        let (mut s0, mut s2) = (0.0, 0.0);
        for (i, v) in w.iter().enumerate() {
            let x = (i as f64 + 0.5) / n as f64 - 0.5;
            s0 += v * v;
            s2 += x * x * v * v;
        }
        s2 / s0
    }

    /// −3 dB main-lobe width in units of 1/bandwidth (0.886 for none).
    pub fn mainlobe_factor(self) -> f64 {
        match self {
            Weighting::None => 0.885_892_941_378_9,
            Weighting::Hann => 1.440_004,
            Weighting::Hamming => 1.302_322,
        }
    }

    /// Weight of sample `i` of `n` (symmetric, peak 1).
    pub fn weight(self, i: usize, n: usize) -> f64 {
        if n <= 1 {
            return 1.0;
        }
        let x = (i as f64 + 0.5) / n as f64; // in (0, 1), symmetric about 0.5
        let c = (std::f64::consts::TAU * x).cos();
        match self {
            Weighting::None => 1.0,
            Weighting::Hann => 0.5 - 0.5 * c,
            Weighting::Hamming => 0.54 - 0.46 * c,
        }
    }

    /// The weights of an `n`-point window.
    pub fn weights(self, n: usize) -> Vec<f64> {
        (0..n).map(|i| self.weight(i, n)).collect()
    }
}

/// The guard band's pixel spacing over the image's ([`ProcessingConfig::guard_band_m`]): 4,
/// 1.6 m at the default 0.4 m, about half the range cell of the default 150 MHz (3 m with the
/// Hann taper), so that a peak in the band is sampled within 1 dB.
pub const GUARD_BAND_PIXEL_FACTOR: usize = 4;

/// Default width of the guard band ([`ProcessingConfig::guard_band_m`]), m: 100. The
/// responses that reach into an image from beyond its edge are those of objects whose main
/// lobe's skirt or sidelobes extend that far, which depends on the resolution cell and not on
/// the image's size; in near-blind geometry the cell is tens to a hundred and more metres long.
/// On the main job a 50 m band leaves 3 false alarms (objects' responses from beyond it adding
/// up), 100 m leaves 1, within the CFAR design's bound, at +10 % of the processing's CPU time.
pub const DEFAULT_GUARD_BAND_M: f64 = 100.0;

/// The `[processing]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProcessingConfig {
    /// Canceller. Default ECA-B.
    pub canceller: CancellerKind,
    /// Canceller taps before the direct-path sample (earlier delays). Default 4.
    pub taps_before: usize,
    /// Canceller taps at and after the direct-path sample. Default 16 (≈ 20 m of excess range).
    pub taps_after: usize,
    /// Doppler bins on each side of zero in the canceller subspace. Default 0 (stop-and-hop);
    /// use 1 with the intra-pulse motion model.
    pub doppler_bins: usize,
    /// Spacing of the canceller's Doppler bins, Hz. Default: a quarter of the subcarrier spacing.
    pub doppler_spacing_hz: Option<f64>,
    /// Pulses per ECA-B batch. Default 1.
    pub batch_pulses: usize,
    /// Diagonal loading of the canceller Gram matrix, relative to its mean diagonal. Default 1e-9.
    pub diagonal_loading: f64,
    /// Range-compression filter. Default reciprocal.
    pub range_filter: RangeFilter,
    /// Spectral weighting in range. Default none (main-lobe factor 0.886).
    pub range_weighting: Weighting,
    /// Slow-time weighting over each look. Default none.
    pub azimuth_weighting: Weighting,
    /// Upsampling factor of the range profile before linear interpolation. Default 8.
    pub upsample: usize,
    /// Half-size of the square image grid around each landmark, m (the grid is at most
    /// [`MAX_GRID_SIDE_PX`] pixels a side). Default 50.
    pub grid_half_m: f64,
    /// Pixel spacing, m. Default 0.4.
    pub pixel_m: f64,
    /// Coherent look length, s. Default: the mission's T_d.
    pub look_s: Option<f64>,
    /// Design false-alarm probability per pixel of the CA-CFAR. Default 1e-6.
    pub pfa: f64,
    /// CFAR guard half-width, pixels. Default: automatic, the bounding box of twice the
    /// predicted resolution cell (a parallelogram) so that no training pixel correlates with
    /// the cell under test.
    pub cfar_guard_px: Option<usize>,
    /// CFAR training band width, pixels. Default 16.
    pub cfar_train_px: usize,
    /// Width of the guard band around the image grid, m: the band is imaged too, on a grid
    /// [`GUARD_BAND_PIXEL_FACTOR`] times coarser, and its peaks above the CFAR threshold take
    /// part in detection (non-maximum suppression, sidelobe editing) without being
    /// detections, so that a response of an object beyond the grid's edge (its main lobe's
    /// skirt, its sidelobes) is recognised as that object's and not reported. Default
    /// [`DEFAULT_GUARD_BAND_M`] (100 m) whatever `grid_half_m`; 0 turns the band off.
    pub guard_band_m: Option<f64>,
    /// Detections closer than this are merged into one cluster, m. Default: half the mission's d_min.
    pub cluster_radius_m: Option<f64>,
    /// A detection matches a truth object within this distance, m. Default: d_min / 2.
    pub match_radius_m: Option<f64>,
    /// Save each look's complex image as NPY. Default false.
    pub save_complex: bool,
}

impl Default for ProcessingConfig {
    fn default() -> Self {
        Self {
            canceller: CancellerKind::EcaB,
            taps_before: 4,
            taps_after: 16,
            doppler_bins: 0,
            doppler_spacing_hz: None,
            batch_pulses: 1,
            diagonal_loading: 1e-9,
            range_filter: RangeFilter::Reciprocal,
            range_weighting: Weighting::None,
            azimuth_weighting: Weighting::None,
            upsample: 8,
            grid_half_m: 50.0,
            pixel_m: 0.4,
            look_s: None,
            pfa: 1e-6,
            cfar_guard_px: None,
            cfar_train_px: 16,
            guard_band_m: None,
            cluster_radius_m: None,
            match_radius_m: None,
            save_complex: false,
        }
    }
}

impl ProcessingConfig {
    /// Checks every value; the error names the first bad field.
    pub fn validate(&self) -> Result<()> {
        if self.taps_before + self.taps_after == 0 && self.canceller != CancellerKind::None {
            return Err(RadarError::config(
                "processing.taps_after",
                "the canceller needs at least one tap",
            ));
        }
        if self.taps_before + self.taps_after > 256 {
            return Err(RadarError::config(
                "processing.taps_after",
                "at most 256 taps in all",
            ));
        }
        if self.doppler_bins > 8 {
            return Err(RadarError::config("processing.doppler_bins", "at most 8"));
        }
        if let Some(d) = self.doppler_spacing_hz {
            positive("processing.doppler_spacing_hz", d)?;
        }
        if self.batch_pulses == 0 {
            return Err(RadarError::config(
                "processing.batch_pulses",
                "must be >= 1",
            ));
        }
        non_negative("processing.diagonal_loading", self.diagonal_loading)?;
        if !(1..=64).contains(&self.upsample) {
            return Err(RadarError::config(
                "processing.upsample",
                "must lie in 1..=64",
            ));
        }
        positive("processing.grid_half_m", self.grid_half_m)?;
        positive("processing.pixel_m", self.pixel_m)?;
        let n = self.grid_side_px();
        if n > MAX_GRID_SIDE_PX as f64 {
            return Err(RadarError::config(
                "processing.grid_half_m",
                format!(
                    "±{} m at pixel_m = {} m makes a grid {n:.0} pixels wide (at most \
                     {MAX_GRID_SIDE_PX})",
                    self.grid_half_m, self.pixel_m
                ),
            ));
        }
        if let Some(t) = self.look_s {
            positive("processing.look_s", t)?;
        }
        finite("processing.pfa", self.pfa)?;
        if !(self.pfa > 0.0 && self.pfa < 0.5) {
            return Err(RadarError::config("processing.pfa", "must lie in (0, 0.5)"));
        }
        if !(1..=MAX_CFAR_BAND_PX).contains(&self.cfar_train_px) {
            return Err(RadarError::config(
                "processing.cfar_train_px",
                format!("{} must lie in 1..={MAX_CFAR_BAND_PX}", self.cfar_train_px),
            ));
        }
        if let Some(g) = self.cfar_guard_px {
            if g > MAX_CFAR_BAND_PX {
                return Err(RadarError::config(
                    "processing.cfar_guard_px",
                    format!("{g} must be at most {MAX_CFAR_BAND_PX}"),
                ));
            }
        }
        if let Some(g) = self.guard_band_m {
            non_negative("processing.guard_band_m", g)?;
        }
        let g = self.guard_band_width_m();
        let side = 2.0 * (self.grid_half_m + g) / (GUARD_BAND_PIXEL_FACTOR as f64 * self.pixel_m);
        if side > MAX_GRID_SIDE_PX as f64 {
            let which = if self.guard_band_m.is_some() {
                ""
            } else {
                " (the default; set a narrower band or 0)"
            };
            return Err(RadarError::config(
                "processing.guard_band_m",
                format!(
                    "{g} m{which} makes the guard band's grid {side:.0} pixels wide (at most \
                     {MAX_GRID_SIDE_PX})"
                ),
            ));
        }
        if let Some(r) = self.cluster_radius_m {
            non_negative("processing.cluster_radius_m", r)?;
        }
        if let Some(r) = self.match_radius_m {
            positive("processing.match_radius_m", r)?;
        }
        Ok(())
    }

    /// Pixels on a side of the image grid, 2 round(grid_half_m / pixel_m) + 1 (as
    /// [`crate::backproject::Grid::square`] makes it), as f64 so that huge values compare.
    pub fn grid_side_px(&self) -> f64 {
        2.0 * (self.grid_half_m / self.pixel_m).round() + 1.0
    }

    /// Width of the guard band, m ([`ProcessingConfig::guard_band_m`], its default resolved).
    pub fn guard_band_width_m(&self) -> f64 {
        self.guard_band_m.unwrap_or(DEFAULT_GUARD_BAND_M)
    }
}
