//! The `[radar]` table: waveform, PRF, link budget, receive antenna, motion model; its
//! validation and the values derived from it.

use serde::{Deserialize, Serialize};

use super::{finite, positive, NrConfig, BOLTZMANN_J_PER_K, MAX_SAMPLES_PER_PULSE};
use crate::error::{RadarError, Result};
use crate::nr::Reference;

/// Widest occupied band, Hz: 400 MHz, the widest NR channel (FR2, 3GPP TS 38.101-2 Table
/// 5.3.5-1; the mission's `bandwidth_hz` has the same bound).
pub const MAX_BANDWIDTH_HZ: f64 = planner::params::bounds::MAX_BANDWIDTH_HZ;

/// Least subcarrier spacing, Hz: 3.75 kHz, LTE NB-IoT's narrowest (3GPP TS 36.211 10.1).
pub const MIN_SUBCARRIER_SPACING_HZ: f64 = 3.75e3;

/// Largest subcarrier spacing, Hz: 960 kHz, NR numerology μ = 6 (3GPP TS 38.211 Table 4.2-1).
pub const MAX_SUBCARRIER_SPACING_HZ: f64 = 960e3;

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
    /// BS antenna gain, dBi: in every direction (isotropic model), or the sector's peak under
    /// `[radar.bs_antenna]`. Default 15.
    pub tx_gain_dbi: f64,
    /// System losses, dB. Default 3.
    pub system_loss_db: f64,
    /// Receiver noise figure F, dB. Default 5.
    pub noise_figure_db: f64,
    /// Reference noise temperature T0, K. Default 290.
    pub noise_temperature_k: f64,
    /// Receive antenna length along track L_a, m. Default 0.5.
    pub antenna_length_m: f64,
    /// Receive antenna height W_a, m. Default 0.5 (gives the the default r_s = 200 m).
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
    /// What the UAV's processor knows of the transmitted signal: `ideal` (every value),
    /// `pilots` (the reference signals' REs only) or `reconstructed` (the pilots and the data
    /// decided hard from its own direct-path recording). The last two need `[radar.nr]`.
    /// Default ideal.
    #[serde(skip_serializing_if = "is_ideal")]
    pub reference: Reference,
    /// The 5G NR cell that illuminates (`[radar.nr]`); absent: one OFDM symbol of
    /// `modulation` on every subcarrier per pulse, at `prf_hz`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nr: Option<NrConfig>,
    /// The BS's sectored antenna (`[radar.bs_antenna]`, TR 38.901's element pattern with
    /// `tx_gain_dbi` as its peak gain) for the direct path and the illumination; absent: an
    /// isotropic `tx_gain_dbi` in every direction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bs_antenna: Option<BsAntennaConfig>,
}

/// The `[radar.bs_antenna]` table: a sector of TR 38.901 Table 7.3-1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BsAntennaConfig {
    /// Sector azimuth, degrees from +x counter-clockwise. Default: towards the mission frame's
    /// origin (the landmarks' area) from the BS.
    pub azimuth_deg: Option<f64>,
    /// Electrical down-tilt below the horizon, degrees, −90..=90. Default: towards the origin
    /// on the ground, atan(H_b / horizontal distance).
    pub downtilt_deg: Option<f64>,
    /// Half-power beamwidth in both planes, degrees, in (0, 360]. Default 65.
    pub beamwidth_deg: f64,
    /// Front-to-back ratio A_max, dB, > 0. Default 30.
    pub front_to_back_db: f64,
    /// Side-lobe limit of the vertical cut SLA_V, dB, > 0. Default 30.
    pub sidelobe_db: f64,
}

impl Default for BsAntennaConfig {
    fn default() -> Self {
        Self {
            azimuth_deg: None,
            downtilt_deg: None,
            beamwidth_deg: 65.0,
            front_to_back_db: 30.0,
            sidelobe_db: 30.0,
        }
    }
}

impl BsAntennaConfig {
    /// Checks the values; errors name the field.
    pub fn validate(&self) -> Result<()> {
        if let Some(a) = self.azimuth_deg {
            finite("radar.bs_antenna.azimuth_deg", a)?;
        }
        if let Some(t) = self.downtilt_deg {
            finite("radar.bs_antenna.downtilt_deg", t)?;
            if t.abs() > 90.0 {
                return Err(RadarError::config(
                    "radar.bs_antenna.downtilt_deg",
                    format!("{t} must lie in -90..=90"),
                ));
            }
        }
        positive("radar.bs_antenna.beamwidth_deg", self.beamwidth_deg)?;
        if self.beamwidth_deg > 360.0 {
            return Err(RadarError::config(
                "radar.bs_antenna.beamwidth_deg",
                format!("{} must be at most 360", self.beamwidth_deg),
            ));
        }
        positive("radar.bs_antenna.front_to_back_db", self.front_to_back_db)?;
        positive("radar.bs_antenna.sidelobe_db", self.sidelobe_db)
    }

    /// The sector of a BS at `bs_m` (x, y, H_b).
    pub fn sector(&self, bs_m: [f64; 3]) -> crate::antenna::SectorAntenna {
        let az = self
            .azimuth_deg
            .map_or_else(|| (-bs_m[1]).atan2(-bs_m[0]), f64::to_radians);
        let tilt = self
            .downtilt_deg
            .map_or_else(|| bs_m[2].atan2(bs_m[0].hypot(bs_m[1])), f64::to_radians);
        crate::antenna::SectorAntenna {
            azimuth_rad: az,
            downtilt_rad: tilt,
            beamwidth_rad: self.beamwidth_deg.to_radians(),
            front_to_back_db: self.front_to_back_db,
            sidelobe_db: self.sidelobe_db,
        }
    }
}

fn is_ideal(r: &Reference) -> bool {
    *r == Reference::Ideal
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
            reference: Reference::Ideal,
            nr: None,
            bs_antenna: None,
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
        if !(MIN_SUBCARRIER_SPACING_HZ..=MAX_SUBCARRIER_SPACING_HZ)
            .contains(&self.subcarrier_spacing_hz)
        {
            return Err(RadarError::config(
                "radar.subcarrier_spacing_hz",
                format!(
                    "{} Hz must lie in [{MIN_SUBCARRIER_SPACING_HZ}, {MAX_SUBCARRIER_SPACING_HZ}] \
                     Hz (from NB-IoT's 3.75 kHz to NR's 960 kHz)",
                    self.subcarrier_spacing_hz
                ),
            ));
        }
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
        for (field, v, what) in [
            (
                "radar.system_loss_db",
                self.system_loss_db,
                "a loss: a negative one would be a gain",
            ),
            (
                "radar.noise_figure_db",
                self.noise_figure_db,
                "a receiver adds noise: F >= 1",
            ),
        ] {
            finite(field, v)?;
            if v < 0.0 {
                return Err(RadarError::config(
                    field,
                    format!("{v} dB must be >= 0 dB ({what})"),
                ));
            }
        }
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
        if let Some(a) = &self.bs_antenna {
            a.validate()?;
        }
        self.validate_reference()
    }

    /// The reference and the NR cell: `pilots` and `reconstructed` need `[radar.nr]`,
    /// `reconstructed` the direct path; the cell's own values are checked with the PRBs that
    /// `radar.nr.prbs` or `radar.bandwidth_hz` give (else the most a PRS allows, 272: the
    /// mission's band is checked in [`RadarConfig::resolve`]).
    fn validate_reference(&self) -> Result<()> {
        match (&self.nr, self.reference) {
            (None, Reference::Pilots | Reference::Reconstructed) => {
                let name = if self.reference == Reference::Pilots {
                    "pilots"
                } else {
                    "reconstructed"
                };
                return Err(RadarError::config(
                    "radar.reference",
                    format!(
                        "\"{name}\" needs the NR cell's signal: add a [radar.nr] table \
                         (without it every subcarrier carries data and only \"ideal\" applies)"
                    ),
                ));
            }
            (Some(_), Reference::Reconstructed) if !self.direct_path => {
                return Err(RadarError::config(
                    "radar.reference",
                    "\"reconstructed\" demodulates the direct path, which radar.direct_path = \
                     false leaves out",
                ))
            }
            _ => {}
        }
        if let Some(nr) = &self.nr {
            let prbs = match (nr.prbs, self.bandwidth_hz) {
                (Some(n), _) => n,
                (None, Some(b)) => nr.resolved_prbs(b, "radar.bandwidth_hz")?,
                (None, None) => crate::nr::signals::PRS_MAX_PRBS,
            };
            nr.illumination(prbs, self.seed)?;
        }
        Ok(())
    }

    /// Sample rate f_s = N Δf, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.fft_size as f64 * self.subcarrier_spacing_hz
    }

    /// The number of subcarriers that occupy bandwidth `bandwidth_hz` (B / Δf, rounded): an
    /// error naming `field` unless B is finite, > 0, at most [`MAX_BANDWIDTH_HZ`] and gives
    /// 2 ..= fft_size − 2 of them.
    pub fn subcarriers_for(&self, field: &str, bandwidth_hz: f64) -> Result<usize> {
        positive(field, bandwidth_hz)?;
        if bandwidth_hz > MAX_BANDWIDTH_HZ {
            return Err(RadarError::config(
                field,
                format!(
                    "B = {bandwidth_hz} Hz is wider than {MAX_BANDWIDTH_HZ} Hz, the widest NR \
                     channel (3GPP TS 38.101-2)"
                ),
            ));
        }
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
