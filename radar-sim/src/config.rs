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
//! [processing]         # canceller, range filter, backprojection grid, CFAR
//! canceller = "eca-b"
//! ```

use serde::{Deserialize, Serialize};

use crate::error::{RadarError, Result};

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

/// The `[objects]` table: the random scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObjectsConfig {
    /// Fixed number of objects (exclusive with `intensity_per_km2`). Default 40.
    pub count: Option<usize>,
    /// Intensity of the Poisson process, objects per km² (exclusive with `count`).
    pub intensity_per_km2: Option<f64>,
    /// Radius R of the disk, m. Default 300.
    pub radius_m: f64,
    /// Centre of the disk (x, y), m. Default: the centre of the landmarks' bounding box.
    pub center_m: Option<[f64; 2]>,
    /// Seed of the object process (positions, RCS spread, reflection phases). Default 1.
    pub seed: u64,
    /// Least distance between two objects (and between an object and a landmark), m.
    /// Default: the mission's d_min. 0 gives a plain Poisson process.
    pub min_separation_m: Option<f64>,
    /// Radar cross-section of each object, m². Default 10.
    pub rcs_m2: f64,
    /// Objects' RCS drawn uniformly in dB within ± this spread around `rcs_m2`. Default 0.
    pub rcs_spread_db: f64,
    /// Add the mission's landmarks as objects. Default true.
    pub include_landmarks: bool,
    /// RCS of a landmark object, m². Default 10.
    pub landmark_rcs_m2: f64,
}

impl Default for ObjectsConfig {
    fn default() -> Self {
        Self {
            count: None,
            intensity_per_km2: None,
            radius_m: 300.0,
            center_m: None,
            seed: 1,
            min_separation_m: None,
            rcs_m2: 10.0,
            rcs_spread_db: 0.0,
            include_landmarks: true,
            landmark_rcs_m2: 10.0,
        }
    }
}

/// QAM order of the BS data symbols.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Modulation {
    /// 4-QAM.
    Qpsk,
    /// 16-QAM.
    Qam16,
    /// 64-QAM.
    Qam64,
    /// 256-QAM.
    Qam256,
}

impl Modulation {
    /// Bits per symbol.
    pub fn bits(self) -> u32 {
        match self {
            Modulation::Qpsk => 2,
            Modulation::Qam16 => 4,
            Modulation::Qam64 => 6,
            Modulation::Qam256 => 8,
        }
    }
}

/// How the UAV's motion enters the echoes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MotionModel {
    /// Geometry frozen at the pulse centre for the whole pulse (classic SAR assumption).
    StopAndHop,
    /// Each symbol uses the geometry at its own centre, and each path carries its Doppler shift
    /// within the symbol (the envelope delay stays frozen at the symbol centre: its drift over one
    /// symbol is below 1e-3 of a sample at 50 m/s).
    IntraPulse,
}

/// The `[radar]` table: waveform, PRF, link budget, receive antenna, motion model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RadarConfig {
    /// Pulse repetition frequency: how often the processor takes one pulse (a group of
    /// `symbols_per_pulse` OFDM symbols) from the BS's continuous stream, Hz. Default 100
    /// (≥ 2 V / L_a up to 25 m/s: the along-track sample spacing stays ≤ L_a / 2). At most
    /// [`RadarConfig::max_prf_hz`] (48 kHz at the defaults: one pulse per symbol).
    pub prf_hz: f64,
    /// OFDM symbols per pulse, 1..=64, with `symbols_per_pulse × fft_size` ≤
    /// [`MAX_SAMPLES_PER_PULSE`]. Default 1.
    pub symbols_per_pulse: usize,
    /// Subcarrier spacing Δf, Hz. Default 60 kHz (NR numerology μ = 2).
    pub subcarrier_spacing_hz: f64,
    /// FFT size N; the sample rate is N Δf. Default 4096 (245.76 MHz).
    pub fft_size: usize,
    /// Cyclic prefix, samples. Default 1024 (NR extended CP at 60 kHz, 4.17 µs = 1249 m of
    /// bistatic excess range).
    pub cp_samples: usize,
    /// Occupied bandwidth B, Hz; default: the mission's `bandwidth_hz`.
    pub bandwidth_hz: Option<f64>,
    /// Data modulation. Default QPSK.
    pub modulation: Modulation,
    /// BS transmit power over the band, W. Default 40.
    pub tx_power_w: f64,
    /// BS antenna gain (isotropic model), dBi. Default 15.
    pub tx_gain_dbi: f64,
    /// System losses, dB. Default 3.
    pub system_loss_db: f64,
    /// Receiver noise figure F, dB. Default 5.
    pub noise_figure_db: f64,
    /// Reference noise temperature T0, K. Default 290.
    pub noise_temperature_k: f64,
    /// Receive antenna length along track L_a, m. Default 0.5.
    pub antenna_length_m: f64,
    /// Receive antenna height W_a, m. Default 0.5 (gives the SPEC's r_s = 200 m).
    pub antenna_height_m: f64,
    /// Least gain in front of the antenna relative to the peak, dB. Default −30.
    pub sidelobe_floor_db: f64,
    /// Gain behind the antenna relative to the peak, dB. Default −30.
    pub backlobe_db: f64,
    /// Motion model. Default stop-and-hop.
    pub motion: MotionModel,
    /// Seed of the BS data and of the receiver noise. Default 7.
    pub seed: u64,
    /// Add thermal noise kT0F per sample bandwidth. Default true.
    pub thermal_noise: bool,
    /// Include the direct path BS → UAV. Default true.
    pub direct_path: bool,
}

impl Default for RadarConfig {
    fn default() -> Self {
        Self {
            prf_hz: 100.0,
            symbols_per_pulse: 1,
            subcarrier_spacing_hz: 60e3,
            fft_size: 4096,
            cp_samples: 1024,
            bandwidth_hz: None,
            modulation: Modulation::Qpsk,
            tx_power_w: 40.0,
            tx_gain_dbi: 15.0,
            system_loss_db: 3.0,
            noise_figure_db: 5.0,
            noise_temperature_k: 290.0,
            antenna_length_m: 0.5,
            antenna_height_m: 0.5,
            sidelobe_floor_db: -30.0,
            backlobe_db: -30.0,
            motion: MotionModel::StopAndHop,
            seed: 7,
            thermal_noise: true,
            direct_path: true,
        }
    }
}

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
            cluster_radius_m: None,
            match_radius_m: None,
            save_complex: false,
        }
    }
}

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

impl ObjectsConfig {
    /// Checks every value; the error names the first bad field.
    pub fn validate(&self) -> Result<()> {
        if self.count.is_some() && self.intensity_per_km2.is_some() {
            return Err(RadarError::config(
                "objects.count",
                "give either `count` or `intensity_per_km2`, not both",
            ));
        }
        if let Some(i) = self.intensity_per_km2 {
            non_negative("objects.intensity_per_km2", i)?;
        }
        if let Some(n) = self.count {
            if n > MAX_OBJECTS {
                return Err(RadarError::config(
                    "objects.count",
                    format!("{n} objects: at most {MAX_OBJECTS}"),
                ));
            }
        }
        positive("objects.radius_m", self.radius_m)?;
        if let Some(mean) = self.mean_poisson_count() {
            if mean > MAX_OBJECTS as f64 {
                return Err(RadarError::config(
                    "objects.intensity_per_km2",
                    format!(
                        "gives {mean:.0} objects on average in a disk of radius {} m (at most {MAX_OBJECTS})",
                        self.radius_m
                    ),
                ));
            }
        }
        if let Some(c) = self.center_m {
            finite("objects.center_m[0]", c[0])?;
            finite("objects.center_m[1]", c[1])?;
        }
        if let Some(d) = self.min_separation_m {
            non_negative("objects.min_separation_m", d)?;
        }
        positive("objects.rcs_m2", self.rcs_m2)?;
        non_negative("objects.rcs_spread_db", self.rcs_spread_db)?;
        positive("objects.landmark_rcs_m2", self.landmark_rcs_m2)?;
        Ok(())
    }

    /// Mean number of Poisson objects, λ π R² (`None` when `count` fixes it or no intensity is
    /// given).
    pub fn mean_poisson_count(&self) -> Option<f64> {
        match (self.count, self.intensity_per_km2) {
            (None, Some(lambda)) => {
                Some(lambda * std::f64::consts::PI * self.radius_m * self.radius_m / 1e6)
            }
            _ => None,
        }
    }
}

impl RadarConfig {
    /// Checks every value, against the signal model too (a pulse takes whole OFDM symbols of
    /// the BS's stream, so at most one pulse per `symbols_per_pulse` symbols; the occupied band
    /// must fit the sample rate); the error names the first bad field and the limit.
    pub fn validate(&self) -> Result<()> {
        positive("radar.prf_hz", self.prf_hz)?;
        if self.symbols_per_pulse == 0 || self.symbols_per_pulse > 64 {
            return Err(RadarError::config(
                "radar.symbols_per_pulse",
                format!("{} must lie in 1..=64", self.symbols_per_pulse),
            ));
        }
        positive("radar.subcarrier_spacing_hz", self.subcarrier_spacing_hz)?;
        if !(16..=1 << 20).contains(&self.fft_size) {
            return Err(RadarError::config(
                "radar.fft_size",
                format!("{} must lie in 16..=1048576", self.fft_size),
            ));
        }
        if self.cp_samples >= self.fft_size {
            return Err(RadarError::config(
                "radar.cp_samples",
                format!(
                    "{} must be below fft_size = {}",
                    self.cp_samples, self.fft_size
                ),
            ));
        }
        if self.samples_per_pulse() > MAX_SAMPLES_PER_PULSE {
            return Err(RadarError::config(
                "radar.symbols_per_pulse",
                format!(
                    "{} symbols of fft_size = {} samples make {} samples per pulse (at most {MAX_SAMPLES_PER_PULSE})",
                    self.symbols_per_pulse,
                    self.fft_size,
                    self.samples_per_pulse()
                ),
            ));
        }
        let max_prf = self.max_prf_hz();
        if self.prf_hz > max_prf {
            return Err(RadarError::config(
                "radar.prf_hz",
                format!(
                    "{} Hz is above {max_prf} Hz, the most the signal model can produce: the BS \
                     sends {} OFDM symbols per second (sample rate {} Hz / (fft_size {} + \
                     cp_samples {}) samples per symbol) and a pulse takes symbols_per_pulse = {} \
                     of them",
                    self.prf_hz,
                    self.symbol_rate_hz(),
                    self.sample_rate_hz(),
                    self.fft_size,
                    self.cp_samples,
                    self.symbols_per_pulse
                ),
            ));
        }
        if let Some(b) = self.bandwidth_hz {
            self.subcarriers_for("radar.bandwidth_hz", b)?;
        }
        positive("radar.tx_power_w", self.tx_power_w)?;
        finite("radar.tx_gain_dbi", self.tx_gain_dbi)?;
        finite("radar.system_loss_db", self.system_loss_db)?;
        finite("radar.noise_figure_db", self.noise_figure_db)?;
        positive("radar.noise_temperature_k", self.noise_temperature_k)?;
        positive("radar.antenna_length_m", self.antenna_length_m)?;
        positive("radar.antenna_height_m", self.antenna_height_m)?;
        finite("radar.sidelobe_floor_db", self.sidelobe_floor_db)?;
        finite("radar.backlobe_db", self.backlobe_db)?;
        if self.sidelobe_floor_db > 0.0 || self.backlobe_db > 0.0 {
            return Err(RadarError::config(
                "radar.sidelobe_floor_db",
                "floors are relative to the peak gain and must be <= 0 dB",
            ));
        }
        Ok(())
    }

    /// Sample rate f_s = N Δf, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.fft_size as f64 * self.subcarrier_spacing_hz
    }

    /// The number of subcarriers that occupy bandwidth `bandwidth_hz` (B / Δf, rounded): an
    /// error naming `field` unless B is finite, > 0 and gives 2 ..= fft_size − 2 of them.
    pub fn subcarriers_for(&self, field: &str, bandwidth_hz: f64) -> Result<usize> {
        positive(field, bandwidth_hz)?;
        let sc = (bandwidth_hz / self.subcarrier_spacing_hz).round();
        if sc < 2.0 || sc > self.fft_size.saturating_sub(2) as f64 {
            return Err(RadarError::config(
                field,
                format!(
                    "B = {bandwidth_hz} Hz gives {sc} subcarriers of {} Hz; need 2..={} \
                     (fft_size − 2): the band must lie within the sample rate {} Hz",
                    self.subcarrier_spacing_hz,
                    self.fft_size.saturating_sub(2),
                    self.sample_rate_hz()
                ),
            ));
        }
        // in 2 ..= fft_size − 2, so a whole number that fits
        Ok(sc as usize)
    }

    /// OFDM symbols the BS sends per second, f_s / (N + N_cp) (48 kHz at the defaults).
    pub fn symbol_rate_hz(&self) -> f64 {
        self.sample_rate_hz() / (self.fft_size + self.cp_samples) as f64
    }

    /// Highest PRF the signal model can produce: one pulse per `symbols_per_pulse` symbols,
    /// f_s / ((N + N_cp) symbols_per_pulse), Hz.
    pub fn max_prf_hz(&self) -> f64 {
        self.symbol_rate_hz() / self.symbols_per_pulse.max(1) as f64
    }

    /// Complex samples per pulse, `symbols_per_pulse × fft_size`.
    pub fn samples_per_pulse(&self) -> usize {
        self.symbols_per_pulse.saturating_mul(self.fft_size)
    }

    /// Noise variance of one complex sample, σ² = k T0 F f_s, W.
    pub fn noise_power_w(&self) -> f64 {
        BOLTZMANN_J_PER_K
            * self.noise_temperature_k
            * 10f64.powf(self.noise_figure_db / 10.0)
            * self.sample_rate_hz()
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
        let text = std::fs::read_to_string(path).map_err(|e| RadarError::read(path, e))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Checks every table, and the values that depend on several (the upsampled range
    /// profile, `fft_size × upsample`, is at most [`MAX_PROFILE_SAMPLES`]).
    pub fn validate(&self) -> Result<()> {
        self.objects.validate()?;
        self.radar.validate()?;
        self.processing.validate()?;
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
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_round_trip() {
        let s = SceneFile::default();
        s.validate().unwrap();
        let text = toml::to_string(&s).unwrap();
        let back = SceneFile::from_toml_str(&text, "x.toml").unwrap();
        assert_eq!(back, s);
        assert!((s.radar.sample_rate_hz() - 245.76e6).abs() < 1.0);
        // kT0F fs with F = 5 dB at 245.76 MHz: −85.0 dBm.
        let dbm = 10.0 * (s.radar.noise_power_w() * 1e3).log10();
        assert!((dbm - (-85.04)).abs() < 0.05, "{dbm}");
    }

    #[test]
    fn errors_name_the_field() {
        let e = SceneFile::from_toml_str("[radar]\nprf_hz = -1\n", "s.toml").unwrap_err();
        assert!(e.to_string().contains("radar.prf_hz"), "{e}");
        let e = SceneFile::from_toml_str("[radar]\nprfhz = 1\n", "s.toml").unwrap_err();
        assert!(
            e.to_string().contains("s.toml") && e.to_string().contains("prfhz"),
            "{e}"
        );
        let e = SceneFile::from_toml_str("[objects]\ncount = 3\nintensity_per_km2 = 2\n", "s.toml")
            .unwrap_err();
        assert!(e.to_string().contains("objects.count"), "{e}");
        let e = SceneFile::from_toml_str("[radar]\ncp_samples = 5000\n", "s.toml").unwrap_err();
        assert!(e.to_string().contains("radar.cp_samples"), "{e}");
    }

    fn err(text: &str) -> String {
        SceneFile::from_toml_str(text, "s.toml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn prf_is_bounded_by_the_symbol_rate() {
        let r = RadarConfig::default();
        assert!((r.symbol_rate_hz() - 48_000.0).abs() < 1e-6);
        assert!((r.max_prf_hz() - 48_000.0).abs() < 1e-6);
        // at the limit: one pulse per symbol
        SceneFile::from_toml_str("[radar]\nprf_hz = 48000\n", "s.toml").unwrap();
        for prf in ["1e5", "1e7", "48000.5"] {
            let e = err(&format!("[radar]\nprf_hz = {prf}\n"));
            assert!(
                e.contains("radar.prf_hz")
                    && e.contains("48000 Hz")
                    && e.contains("symbols_per_pulse"),
                "{e}"
            );
        }
        // 4 symbols per pulse: at most 12 kHz
        let e = err("[radar]\nprf_hz = 20000\nsymbols_per_pulse = 4\n");
        assert!(e.contains("radar.prf_hz") && e.contains("12000 Hz"), "{e}");
    }

    #[test]
    fn sizes_that_would_exhaust_memory_are_refused_by_field() {
        // samples per pulse
        let e = err(
            "[radar]\nfft_size = 1048576\nsymbols_per_pulse = 2\ncp_samples = 0\nprf_hz = 10\n",
        );
        assert!(
            e.contains("radar.symbols_per_pulse") && e.contains("2097152"),
            "{e}"
        );
        // the band must fit the sample rate
        let e = err("[radar]\nbandwidth_hz = 300e6\n");
        assert!(
            e.contains("radar.bandwidth_hz") && e.contains("245760000"),
            "{e}"
        );
        SceneFile::from_toml_str("[radar]\nbandwidth_hz = 150e6\n", "s.toml").unwrap();
        // grid
        let e = err("[processing]\ngrid_half_m = 1000\npixel_m = 0.4\n");
        assert!(
            e.contains("processing.grid_half_m") && e.contains("5001"),
            "{e}"
        );
        SceneFile::from_toml_str(
            "[processing]\ngrid_half_m = 819.2\npixel_m = 0.4\n",
            "s.toml",
        )
        .unwrap();
        // CFAR bands
        let e = err("[processing]\ncfar_train_px = 1000000\n");
        assert!(e.contains("processing.cfar_train_px"), "{e}");
        let e = err("[processing]\ncfar_guard_px = 1000000\n");
        assert!(e.contains("processing.cfar_guard_px"), "{e}");
        // upsampled range profile
        let e = err("[radar]\nfft_size = 262144\ncp_samples = 0\n[processing]\nupsample = 32\n");
        assert!(
            e.contains("processing.upsample") && e.contains("8388608"),
            "{e}"
        );
        // objects: the Poisson mean is checked by validate, not only when generating
        let e = err("[objects]\nintensity_per_km2 = 1e9\nradius_m = 400\n");
        assert!(e.contains("objects.intensity_per_km2"), "{e}");
        let e = err("[objects]\ncount = 2000000\n");
        assert!(e.contains("objects.count"), "{e}");
    }

    #[test]
    fn weighting_factors() {
        assert!((Weighting::None.mainlobe_factor() - 0.886).abs() < 1e-3);
        assert!((Weighting::None.coherence_factor() - 1.0).abs() < 1e-12);
        assert!((Weighting::Hann.coherence_factor() - 35.0 / 18.0).abs() < 1e-3);
        let w = Weighting::Hann.weights(8);
        assert!((w[0] - w[7]).abs() < 1e-12 && w[3] > 0.9);
    }
}
