//! The predicted point response of a multilook image ([`ResponseModel`]): what the
//! detections' sidelobe editing compares neighbours against.

/// Relative scale margin of the response model (linearisation over the grid and the
/// aperture): offsets are shrunk by this fraction before the envelope is read.
pub const MODEL_SCALE_MARGIN: f64 = 0.15;

/// Absolute margin of the response model, resolution cells (peak positions on the pixel grid).
pub const MODEL_CELL_MARGIN: f64 = 0.25;

/// Envelope table step and extent, resolution units.
const ENV_STEP: f64 = 1.0 / 32.0;
const ENV_MAX: f64 = 64.0;

/// `max_{|v| ≥ |u|} |ŵ(v)|²` on a grid of [`ENV_STEP`] up to [`ENV_MAX`]: the response itself
/// inside the main lobe, the next sidelobe peak beyond it.
fn envelope_table(w: crate::config::Weighting) -> Vec<f64> {
    let n = (ENV_MAX / ENV_STEP).round() as usize + 1;
    let mut t: Vec<f64> = (0..n)
        .map(|i| w.amplitude_response(i as f64 * ENV_STEP).powi(2))
        .collect();
    for i in (0..n - 1).rev() {
        t[i] = t[i].max(t[i + 1]);
    }
    t
}

fn envelope_at(t: &[f64], u: f64) -> f64 {
    let u = u.abs();
    if !u.is_finite() {
        return 0.0;
    }
    let last = t.len() - 1;
    if u >= ENV_MAX {
        // beyond the table: at most the 1/u² decay of the unweighted response
        return t[last] * (ENV_MAX / u).powi(2);
    }
    t[((u / ENV_STEP) as usize).min(last)]
}

/// The predicted point response of the multilook image, linearised at the image centre: in each
/// look separable in the range coordinate `u_r = (g·Δ) B / c` and the Doppler coordinate
/// `u_a = (∇f_D·Δ) T` (ground offset Δ from the peak, in resolution cells), with the range and
/// azimuth tapers' responses; the multilook response is the mean over the looks.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseModel {
    /// Per look: (range cells per metre of ground offset `g B / c`, Doppler cells per metre
    /// `∇f_D T`), 1/m.
    pub looks: Vec<([f64; 2], [f64; 2])>,
    /// Range (spectral) taper.
    pub range_weighting: crate::config::Weighting,
    /// Azimuth (slow-time) taper.
    pub azimuth_weighting: crate::config::Weighting,
    range_env: Vec<f64>,
    azimuth_env: Vec<f64>,
}

impl ResponseModel {
    /// The model for the looks' (range, Doppler) cells per metre and the two tapers.
    pub fn new(
        looks: Vec<([f64; 2], [f64; 2])>,
        range_weighting: crate::config::Weighting,
        azimuth_weighting: crate::config::Weighting,
    ) -> Self {
        Self {
            looks,
            range_weighting,
            azimuth_weighting,
            range_env: envelope_table(range_weighting),
            azimuth_env: envelope_table(azimuth_weighting),
        }
    }

    /// Upper envelope of the normalised multilook power response at ground offset `d_m` from
    /// the peak: the mean over the looks of the product of the range and azimuth responses'
    /// envelopes, each read at the offset shrunk by [`MODEL_SCALE_MARGIN`] and
    /// [`MODEL_CELL_MARGIN`] (1 at 0).
    pub fn envelope(&self, d_m: [f64; 2]) -> f64 {
        if self.looks.is_empty() {
            return 0.0;
        }
        let shrink = |u: f64| (u.abs() * (1.0 - MODEL_SCALE_MARGIN) - MODEL_CELL_MARGIN).max(0.0);
        self.looks
            .iter()
            .map(|(r, a)| {
                let ur = r[0] * d_m[0] + r[1] * d_m[1];
                let ua = a[0] * d_m[0] + a[1] * d_m[1];
                envelope_at(&self.range_env, shrink(ur))
                    * envelope_at(&self.azimuth_env, shrink(ua))
            })
            .sum::<f64>()
            / self.looks.len() as f64
    }

    /// `√det Λ` of the image noise's component Gaussian fields, 1/m² (mean over the looks):
    /// Λ = 4π² (μ_r a_r a_rᵀ + μ_a a_a a_aᵀ), a the cells per metre, μ the tapers' squared
    /// second moments ([`crate::config::Weighting::spectral_second_moment`]).
    pub fn noise_curvature_per_m2(&self) -> f64 {
        if self.looks.is_empty() {
            return 0.0;
        }
        let cross = self
            .looks
            .iter()
            .map(|(a, b)| (a[0] * b[1] - a[1] * b[0]).abs())
            .sum::<f64>()
            / self.looks.len() as f64;
        4.0 * std::f64::consts::PI.powi(2)
            * (self.range_weighting.spectral_second_moment()
                * self.azimuth_weighting.spectral_second_moment())
            .sqrt()
            * cross
    }
}
