//! What processing an aperture gives: [`Compressed`] pulses and the [`ApertureResult`].

use rustfft::num_complex::{Complex32, Complex64};

use crate::backproject::{BpPulse, Grid};
use crate::cancel::CancelStats;
use crate::cfar::Detection;
use crate::scoring::Score;
use crate::track::Aperture;
use planner::geometry as pg;

/// Range-compressed pulses of one aperture, ready for backprojection.
#[derive(Debug, Clone)]
pub struct Compressed {
    /// Per pulse: position, window delay, profile start, weight.
    pub pulses: Vec<BpPulse>,
    /// Profile windows, pulses × `m`.
    pub profiles: Vec<Complex32>,
    /// Profile window length.
    pub m: usize,
    /// Compressed spectra Z per pulse (kept on request, for exact evaluation).
    pub spectra: Option<Vec<Vec<Complex64>>>,
    /// Canceller metrics over all pulses.
    pub cancel: CancelStats,
}

/// The image products and scores of one aperture.
#[derive(Debug, Clone)]
pub struct ApertureResult {
    /// The aperture.
    pub aperture: Aperture,
    /// Its grid.
    pub grid: Grid,
    /// Mean over looks of |I|² / (per-look noise variance): unit-mean noise, SNR for targets.
    pub multilook: Vec<f32>,
    /// Complex look images (when `save_complex`).
    pub looks: Vec<Vec<Complex32>>,
    /// Detections.
    pub detections: Vec<Detection>,
    /// Scoring against the truth in the image.
    pub score: Score,
    /// Canceller metrics.
    pub cancel: CancelStats,
    /// CFAR exceedance pixels among the clear pixels.
    pub false_alarm_pixels: usize,
    /// Clear pixels: outside every truth object's gate, where the objects' predicted responses
    /// sum to less than [`CLEAR_SIGNAL`](super::CLEAR_SIGNAL) of the thermal noise, and in no
    /// exceedance region that
    /// reaches an object's gate.
    pub clear_pixels: usize,
    /// Expected CFAR exceedance pixels on noise over the clear pixels: P_fa × `clear_pixels`.
    pub design_false_alarm_pixels: f64,
    /// Expected false-alarm detections (noise peaks the CFAR passes) outside every truth
    /// object's gate, by design: the Euler-characteristic density of the multilook noise field
    /// at the CFAR's threshold ([`crate::cfar::expected_peaks_per_m2`]) times that area.
    pub design_false_alarms: f64,
    /// Pixels tested against the image-wide noise estimate (too few training cells of their
    /// own); no pixel is left untested.
    pub cfar_fallback_pixels: usize,
    /// Predicted resolution cell at the image centre (general geometry, the unweighted
    /// 1/B and 1/T cell the planner constrains).
    pub cell: pg::ResolutionCell,
    /// −3 dB main-lobe factors of the (range, azimuth) weightings: the cell's widths times
    /// these are the −3 dB widths of the image's response.
    pub mainlobe_factors: [f64; 2],
    /// Predicted echo power per sample at the receiver, mean over the aperture's pulses
    /// (the link budget of the truth objects), W.
    pub echo_power_w: f64,
    /// Predicted power per sample after cancellation without any direct path left: the echo
    /// power plus the thermal noise that the projection keeps
    /// ([`crate::cancel::CancelStats::noise_retained`]), W.
    pub predicted_floor_w: f64,
    /// Whether the scene has a direct path.
    pub direct_path: bool,
    /// The image's noise floor as the CFAR estimated it ([`crate::cfar::image_floor`]), in
    /// units of the thermal noise.
    pub image_floor: f64,
    /// The floor predicted from the truth: thermal noise plus the echoes' inter-symbol
    /// interference ([`Processor::isi_power_w`](super::Processor::isi_power_w)), in units of the
    /// thermal noise.
    pub predicted_image_floor: f64,
    /// The matching gate used, m.
    pub gate_m: f64,
    /// Per-look noise variance of the complex image, W.
    pub noise_var: f64,
    /// Pixels per coherence area (independent cell) used by the CFAR.
    pub pixels_per_cell: f64,
}

impl ApertureResult {
    /// Worst −3 dB width of the image's response at the centre: the longest chord of the
    /// cell's ellipse with the weightings' main-lobe factors on the range and Doppler widths
    /// ([`pg::cell_ellipse_axes_m`]), m.
    pub fn worst_width_mainlobe_m(&self) -> f64 {
        pg::cell_ellipse_axes_m(
            self.mainlobe_factors[0] * self.cell.range_width_m,
            self.mainlobe_factors[1] * self.cell.along_track_width_m,
            self.cell.psi_rad.sin(),
        )
        .0
    }
}
