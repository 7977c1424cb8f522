//! The streaming API: a [`RadarSetup`] fixes the mission, scene and radar; a [`Synthesizer`]
//! produces frames of pulses one at a time ([`synthesize_frames`]); a [`Processor`] turns the
//! pulses of one aperture into range profiles ([`Processor::compress`]), look images
//! ([`Processor::image_look`]) and detections ([`Processor::process_aperture`]).
//!
//! Frame layout (also on the wire and in `iq/*.npy`): `pulses × samples` complex f32,
//! row-major, little-endian interleaved (re, im); a pulse holds `symbols_per_pulse` FFT windows
//! of N samples each, symbol-major; [`PulseMeta`] carries each pulse's time, symbol index, UAV
//! position/velocity/heading and receiver window delay.

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::{Complex32, Complex64};
use rustfft::{Fft, FftPlanner};

use crate::antenna::Antenna;
use crate::backproject::{backproject, profile_windows, BpGeometry, BpPulse, Grid};
use crate::cancel::{CancelStats, Canceller, SymbolWindow};
use crate::cfar::{ca_cfar, cluster, expected_peaks_per_m2, CfarParams, Detection, ResponseModel};
use crate::compress::RangeCompressor;
use crate::config::{CancellerKind, RangeFilter, SceneFile};
use crate::error::{RadarError, Result};
use crate::resolution::{cut_directions, half_power_width, ResolutionReport};
use crate::scene::SceneObject;
use crate::scoring::{score, Score, TruthInImage};
use crate::synth::{Components, Synthesizer};
use crate::track::{plan_apertures, plan_pulses, Aperture, PulseMeta, Track};
use crate::waveform::{Numerology, C_MPS};
use planner::geometry::{self as pg, Length, Vector2};

/// Everything fixed by a mission's parameters and a scene file.
#[derive(Debug, Clone)]
pub struct RadarSetup {
    /// The mission parameters (geometry, B, λ, T_d, d_min, ...).
    pub params: planner::Params,
    /// The scene file.
    pub scene: SceneFile,
    /// The resolved OFDM numerology.
    pub num: Numerology,
    /// The receive antenna.
    pub antenna: Antenna,
    /// BS antenna position (x, y, H_b), m.
    pub bs_m: [f64; 3],
    /// Coherent look length, s.
    pub look_s: f64,
}

impl RadarSetup {
    /// Resolves a setup; errors name the bad field.
    pub fn new(params: &planner::Params, scene: &SceneFile) -> Result<Self> {
        params
            .validate()
            .map_err(|e| RadarError::config("params", e.to_string()))?;
        scene.validate()?;
        let num = Numerology::new(&scene.radar, params.bandwidth_hz, params.wavelength_m)?;
        let antenna = Antenna::new(
            &scene.radar,
            params.wavelength_m,
            params.observation_angle_rad,
        );
        Ok(Self {
            params: params.clone(),
            scene: scene.clone(),
            antenna,
            bs_m: [params.bs_m[0], params.bs_m[1], params.bs_height_m],
            look_s: scene.processing.look_s.unwrap_or(params.integration_time_s),
            num,
        })
    }

    /// Backprojection constants.
    pub fn geometry(&self) -> BpGeometry {
        BpGeometry {
            bs_m: self.bs_m,
            fs_hz: self.num.sample_rate_hz(),
            upsample: self.scene.processing.upsample,
            wavelength_m: self.num.wavelength_m(),
        }
    }

    /// The synthesiser for `objects`.
    pub fn synthesizer(&self, objects: Vec<SceneObject>) -> Result<Synthesizer> {
        Synthesizer::new(
            self.num.clone(),
            &self.scene.radar,
            self.antenna,
            self.bs_m,
            objects,
        )
    }

    /// The scene's objects for `mission` (landmarks first when included).
    pub fn objects(&self, mission: &planner::Mission) -> Result<Vec<SceneObject>> {
        let lm: Vec<[f64; 2]> = mission
            .schedule()
            .landmarks
            .iter()
            .map(|w| w.pos_m())
            .collect();
        crate::scene::generate(&self.scene.objects, &lm, self.params.d_min_m)
    }

    /// One aperture per landmark window of `mission`.
    pub fn apertures(&self, mission: &planner::Mission) -> Result<Vec<Aperture>> {
        let windows: Vec<_> = mission
            .schedule()
            .landmarks
            .iter()
            .enumerate()
            .map(|(i, w)| (w.pos_m(), Some(i), w.from_s.max(0.0), w.to_s))
            .collect();
        if windows.is_empty() {
            return Err(RadarError::Mismatch(
                "the mission has no landmark windows: nothing to image".into(),
            ));
        }
        plan_apertures(&windows, self.look_s, self.scene.radar.prf_hz)
    }

    /// The pulses of aperture `ap` along `track`.
    pub fn pulses(&self, track: &dyn Track, ap: &Aperture) -> Vec<PulseMeta> {
        plan_pulses(track, &self.num, self.bs_m, ap, self.scene.radar.prf_hz)
    }

    /// The image grid of aperture `ap`.
    pub fn grid(&self, ap: &Aperture) -> Grid {
        Grid::square(
            ap.centre_m,
            self.scene.processing.grid_half_m,
            self.scene.processing.pixel_m,
        )
    }
}

/// Receives one frame: its pulse metadata and `pulses × samples` IQ.
pub type FrameSink<'a> = dyn FnMut(&[PulseMeta], &[Complex32]) -> Result<()> + 'a;

/// One batch's output: per-pulse profile windows, kept spectra, canceller metrics.
type BatchOut = (Vec<Vec<Complex32>>, Vec<Vec<Complex64>>, CancelStats);

/// Synthesises the pulses of one aperture in frames of at most `frame_pulses`, handing each
/// frame (its pulse metadata and `pulses × samples` IQ) to `sink` before the next is made.
pub fn synthesize_frames(
    synth: &Synthesizer,
    pulses: &[PulseMeta],
    frame_pulses: usize,
    comps: Components,
    sink: &mut FrameSink<'_>,
) -> Result<()> {
    for chunk in pulses.chunks(frame_pulses.max(1)) {
        let iq = synth.synthesize_frame(chunk, comps)?;
        sink(chunk, &iq)?;
    }
    Ok(())
}

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
    /// sum to less than [`CLEAR_SIGNAL`] of the thermal noise, and in no exceedance region that
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
    /// interference ([`Processor::isi_power_w`]), in units of the thermal noise.
    pub predicted_image_floor: f64,
    /// The matching gate used, m.
    pub gate_m: f64,
    /// Per-look noise variance of the complex image, W.
    pub noise_var: f64,
    /// Pixels per coherence area (independent cell) used by the CFAR.
    pub pixels_per_cell: f64,
}

impl ApertureResult {
    /// Worst −3 dB width of the image's response at the centre: the cell's principal chords
    /// times the weightings' main-lobe factors, max(f_r × cross-track, f_a × iso-range), m.
    pub fn worst_width_mainlobe_m(&self) -> f64 {
        (self.mainlobe_factors[0] * self.cell.cross_track_width_m)
            .max(self.mainlobe_factors[1] * self.cell.iso_range_width_m)
    }
}

/// A pixel counts as clear (noise only, for the pixel-level false-alarm count) where the truth
/// objects' predicted responses sum to less than this, in units of the thermal noise (−10 dB),
/// and it is in no exceedance region that reaches an object's gate.
pub const CLEAR_SIGNAL: f64 = 0.1;

/// Objects within this many grid half-widths outside the grid are counted for the clear pixels
/// (their responses reach into the image).
pub const NEAR_OBJECT_REACH: f64 = 2.0;

/// Coherent amplitude factor of a path `delay_samples` into a CP-free window of `n` samples
/// with `cp` samples of cyclic prefix: the fraction of the window that still holds the
/// symbol's own data, `max(0, 1 − (max(Δ − N_cp, 0) + max(−Δ, 0)) / N)` (the rest carries the
/// neighbouring symbol, uncorrelated with the reference).
pub fn cp_overlap_factor(delay_samples: f64, n: usize, cp: usize) -> f64 {
    let spill = (delay_samples - cp as f64).max(0.0) + (-delay_samples).max(0.0);
    (1.0 - spill / n as f64).max(0.0)
}

/// CFAR guard half-widths (x, y) in pixels and pixels per coherence area for the response at
/// a point with bistatic range gradient `g` and Doppler gradient `d` (ground vectors).
///
/// The response is separable in the range coordinate g·x and the Doppler coordinate d·x. Its
/// intensity-correlation area is `c_r c_a δ_r δ_a / sin ψ` (c: the weighting's
/// [`crate::config::Weighting::coherence_factor`], δ_r = c/(B|g|), δ_a = 1/(T|d|)); the guard is
/// the bounding box of the parallelogram |g·x| ≤ c_r c/B, |d·x| ≤ c_a/T (the main lobe out to
/// its first nulls), at most `max_guard_px` (x, y): bounded by the grid, so that the pixels
/// of the image's centre keep training cells (censoring keeps a strong return's main lobe out
/// of them where the guard is short of it).
pub fn cfar_geometry(
    g: [f64; 2],
    d: [f64; 2],
    bandwidth_hz: f64,
    look_s: f64,
    pc: &crate::config::ProcessingConfig,
    pixel_m: f64,
    max_guard_px: (usize, usize),
) -> (usize, usize, f64) {
    let cr = pc.range_weighting.coherence_factor();
    let ca = pc.azimuth_weighting.coherence_factor();
    let (gn, dn) = (Vector2::from(g).length(), Vector2::from(d).length());
    let dr = C_MPS / (bandwidth_hz * gn.max(1e-9));
    let da = 1.0 / (look_s * dn.max(1e-12));
    let s = if gn > 0.0 && dn > 0.0 {
        (Vector2::from(g).perp(&Vector2::from(d)) / (gn * dn))
            .abs()
            .max(0.05)
    } else {
        0.05
    };
    let area = cr * ca * dr * da / s;
    // e1 ⟂ g (iso-range), e2 ⟂ d (iso-Doppler)
    let e1 = [-g[1] / gn.max(1e-12), g[0] / gn.max(1e-12)];
    let e2 = [-d[1] / dn.max(1e-12), d[0] / dn.max(1e-12)];
    let ea = ca * da / s;
    let eb = cr * dr / s;
    let x = ea * e1[0].abs() + eb * e2[0].abs();
    let y = ea * e1[1].abs() + eb * e2[1].abs();
    let px = |v: f64, max: usize| {
        let p = (v / pixel_m).ceil();
        if p.is_finite() {
            (p.max(1.0) as usize).clamp(1, max.max(1))
        } else {
            max.max(1)
        }
    };
    (
        px(x, max_guard_px.0),
        px(y, max_guard_px.1),
        (area / (pixel_m * pixel_m)).max(1.0),
    )
}

/// CFAR output of one aperture's multilook image.
#[derive(Debug, Clone)]
pub struct Detected {
    /// Detections (non-maximum suppression within the cluster radius), strongest first.
    pub detections: Vec<Detection>,
    /// The CFAR exceedance map and noise estimates.
    pub map: crate::cfar::CfarMap,
    /// The CFAR settings used.
    pub cfar: CfarParams,
    /// Predicted resolution cell at the image centre, mid-aperture.
    pub cell: pg::ResolutionCell,
    /// Pixels per coherence area used by the CFAR.
    pub pixels_per_cell: f64,
    /// The point-response model used for sidelobe editing and the design false-alarm count.
    pub model: ResponseModel,
}

/// The processor of one setup.
pub struct Processor {
    setup: RadarSetup,
    canceller: Canceller,
    compressor: RangeCompressor,
    fft: Arc<dyn Fft<f64>>,
    ifft: Arc<dyn Fft<f64>>,
    link: Synthesizer,
}

impl std::fmt::Debug for Processor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Processor")
            .field("canceller", &self.canceller)
            .field("compressor", &self.compressor)
            .finish_non_exhaustive()
    }
}

impl Processor {
    /// A processor for `setup`.
    pub fn new(setup: RadarSetup) -> Result<Self> {
        let pc = &setup.scene.processing;
        let canceller = Canceller::new(pc, &setup.num)?;
        let compressor =
            RangeCompressor::new(&setup.num, pc.range_filter, pc.range_weighting, pc.upsample);
        let mut planner = FftPlanner::new();
        let fft = planner.plan_fft_forward(setup.num.fft_size);
        let ifft = planner.plan_fft_inverse(setup.num.fft_size);
        let link = setup.synthesizer(Vec::new())?;
        Ok(Self {
            setup,
            canceller,
            compressor,
            fft,
            ifft,
            link,
        })
    }

    /// The setup.
    pub fn setup(&self) -> &RadarSetup {
        &self.setup
    }

    /// The range compressor.
    pub fn compressor(&self) -> &RangeCompressor {
        &self.compressor
    }

    /// Variance of one profile sample from thermal noise, W.
    pub fn profile_noise_var(&self) -> f64 {
        let num = &self.setup.num;
        let pc = &self.setup.scene.processing;
        let w = pc.range_weighting.weights(num.subcarriers);
        let s1: f64 = w.iter().sum();
        let s2: f64 = w.iter().map(|x| x * x).sum();
        let f2 = match pc.range_filter {
            RangeFilter::Matched => 1.0,
            RangeFilter::Reciprocal => num.mean_inverse_power(),
        };
        let spp = self.setup.scene.radar.symbols_per_pulse as f64;
        self.link.noise_power_w() * f2 * s2 * num.subcarriers as f64
            / (num.fft_size as f64 * spp * s1 * s1)
    }

    /// Slow-time weights of a look of `n` pulses.
    pub fn look_weights(&self, n: usize) -> Vec<f32> {
        self.setup
            .scene
            .processing
            .azimuth_weighting
            .weights(n)
            .into_iter()
            .map(|w| w as f32)
            .collect()
    }

    /// Per-look noise variance of an image pixel, W.
    pub fn look_noise_var(&self, n: usize) -> f64 {
        let w = self.look_weights(n);
        self.profile_noise_var() * w.iter().map(|x| (*x as f64).powi(2)).sum::<f64>()
    }

    /// Expected per-look image SNR of `obj` over `pulses` (one look), dB:
    /// (Σ w f √P)² / (Σ w² σ_p²), with f the [`cp_overlap_factor`] of the echo's delay in the
    /// pulse's window (1 inside the cyclic prefix; an echo beyond it shares the window with the
    /// previous symbol and loses that fraction of its coherent gain).
    pub fn expected_snr_db(&self, obj: &SceneObject, pulses: &[PulseMeta]) -> f64 {
        let w = self.look_weights(pulses.len());
        let geom = self.setup.geometry();
        let (n, cp) = (self.setup.num.fft_size, self.setup.num.cp_samples);
        let amp: f64 = pulses
            .iter()
            .zip(&w)
            .map(|(p, w)| {
                let delay = geom.delay_samples(obj.pos_m(), p.pos_m, p.window_delay_samples);
                *w as f64
                    * cp_overlap_factor(delay, n, cp)
                    * self.link.echo_power_w(obj, p.pos_m, p.heading).sqrt()
            })
            .sum();
        10.0 * (amp * amp / self.look_noise_var(pulses.len())).log10()
    }

    /// Predicted echo power per sample at the receiver, W: the link budget of `objects`
    /// summed, mean over `pulses`.
    pub fn echo_power_w(&self, objects: &[SceneObject], pulses: &[PulseMeta]) -> f64 {
        if pulses.is_empty() {
            return 0.0;
        }
        pulses
            .iter()
            .map(|p| {
                objects
                    .iter()
                    .map(|o| self.link.echo_power_w(o, p.pos_m, p.heading))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / pulses.len() as f64
    }

    /// Predicted power per sample of the echoes' inter-symbol interference, W, mean over
    /// `pulses`: an echo with [`cp_overlap_factor`] f < 1 leaves `P (1 − f²)` of its power
    /// uncorrelated with the reference (the neighbouring symbol's data), which range
    /// compression spreads like white noise, raising the image's floor.
    pub fn isi_power_w(&self, objects: &[SceneObject], pulses: &[PulseMeta]) -> f64 {
        if pulses.is_empty() {
            return 0.0;
        }
        let geom = self.setup.geometry();
        let (n, cp) = (self.setup.num.fft_size, self.setup.num.cp_samples);
        pulses
            .iter()
            .map(|p| {
                objects
                    .iter()
                    .map(|o| {
                        let delay = geom.delay_samples(o.pos_m(), p.pos_m, p.window_delay_samples);
                        let f = cp_overlap_factor(delay, n, cp);
                        self.link.echo_power_w(o, p.pos_m, p.heading) * (1.0 - f * f)
                    })
                    .sum::<f64>()
            })
            .sum::<f64>()
            / pulses.len() as f64
    }

    /// Thermal noise power per complex sample at the receiver, W.
    pub fn noise_power_w(&self) -> f64 {
        self.link.noise_power_w()
    }

    /// Cancels and range-compresses `pulses` (IQ: pulses × samples) for imaging on `grid`.
    /// `looks` gives the pulses per look (ECA batches never cross looks).
    pub fn compress(
        &self,
        grid: &Grid,
        pulses: &[PulseMeta],
        iq: &[Complex32],
        pulses_per_look: usize,
        target_m: Option<[f64; 2]>,
        keep_spectra: bool,
    ) -> Result<Compressed> {
        let num = &self.setup.num;
        let spp = self.setup.scene.radar.symbols_per_pulse;
        let n = num.fft_size;
        if iq.len() != pulses.len() * spp * n {
            return Err(RadarError::Shape {
                what: "IQ frame".into(),
                expected: format!("{} pulses × {} samples", pulses.len(), spp * n),
                found: format!("{} samples", iq.len()),
            });
        }
        let geom = self.setup.geometry();
        let raw: Vec<([f64; 3], i64)> = pulses
            .iter()
            .map(|p| (p.pos_m, p.window_delay_samples))
            .collect();
        let (j0s, m) = profile_windows(&geom, grid, &raw);
        let pc = &self.setup.scene.processing;
        let batch = match pc.canceller {
            CancellerKind::None => 1,
            CancellerKind::EcaB => pc.batch_pulses,
            CancellerKind::Eca => pulses_per_look.max(1),
        };
        // batches never cross looks
        let ppl = pulses_per_look.max(1);
        let mut ranges = Vec::new();
        let mut s = 0;
        while s < pulses.len() {
            let look_end = ((s / ppl) + 1) * ppl;
            let e = (s + batch).min(look_end).min(pulses.len());
            ranges.push(s..e);
            s = e;
        }
        let fs = num.sample_rate_hz();
        let ns = num.symbol_samples() as f64;
        let results: Vec<Result<BatchOut>> = ranges
            .par_iter()
            .map(|r| {
                let mut windows = Vec::with_capacity(r.len() * spp);
                for (k, p) in pulses[r.clone()].iter().enumerate() {
                    let rd = crate::track::dist3(p.pos_m, self.setup.bs_m);
                    let dp = rd * fs / C_MPS - p.window_delay_samples as f64;
                    for s in 0..spp {
                        let off = ((r.start + k) * spp + s) * n;
                        let mut spec: Vec<Complex64> = iq[off..off + n]
                            .iter()
                            .map(|v| Complex64::new(v.re as f64, v.im as f64))
                            .collect();
                        self.fft.process(&mut spec);
                        let m_sym = p.symbol + s as u64;
                        windows.push(SymbolWindow {
                            spectrum: spec,
                            data: Arc::new(num.symbol_data(m_sym)),
                            t_s: (m_sym as f64 * ns
                                + num.cp_samples as f64
                                + p.window_delay_samples as f64)
                                / fs,
                            dp_delay_samples: dp,
                        });
                    }
                }
                let mid = &pulses[(r.start + r.end) / 2];
                let td =
                    target_m.map(|t| geom.delay_samples(t, mid.pos_m, mid.window_delay_samples));
                let stats = self.canceller.cancel_batch(
                    &mut windows,
                    td,
                    self.fft.as_ref(),
                    self.ifft.as_ref(),
                )?;
                let mut profs = Vec::with_capacity(r.len());
                let mut specs = Vec::new();
                for (k, pi) in r.clone().enumerate() {
                    let z = self.compressor.spectrum(&windows[k * spp..(k + 1) * spp]);
                    profs.push(self.compressor.profile_window(&z, j0s[pi], m));
                    if keep_spectra {
                        specs.push(z);
                    }
                }
                Ok((profs, specs, stats))
            })
            .collect();
        let mut profiles = Vec::with_capacity(pulses.len() * m);
        let mut spectra = keep_spectra.then(Vec::new);
        let mut cancel = CancelStats::default();
        for r in results {
            let (p, z, st) = r?;
            for v in p {
                profiles.extend_from_slice(&v);
            }
            if let Some(s) = spectra.as_mut() {
                s.extend(z);
            }
            cancel.add(&st);
        }
        let mut bp = Vec::with_capacity(pulses.len());
        for (k, (p, j0)) in pulses.iter().zip(&j0s).enumerate() {
            let w = self.look_weights(ppl.min(pulses.len()));
            bp.push(BpPulse {
                pos_m: p.pos_m,
                window_delay_samples: p.window_delay_samples,
                j0: *j0,
                weight: w.get(k % ppl).copied().unwrap_or(1.0),
            });
        }
        Ok(Compressed {
            pulses: bp,
            profiles,
            m,
            spectra,
            cancel,
        })
    }

    /// The complex image of pulses `range` of `c` on `grid`.
    pub fn image_look(
        &self,
        grid: &Grid,
        c: &Compressed,
        range: std::ops::Range<usize>,
    ) -> Result<Vec<Complex32>> {
        let m = c.m;
        backproject(
            &self.setup.geometry(),
            grid,
            &c.pulses[range.clone()],
            &c.profiles[range.start * m..range.end * m],
            m,
            32,
        )
    }

    /// Exact (sinc-interpolated, f64) image values at `points` from the kept spectra.
    pub fn image_points_exact(
        &self,
        c: &Compressed,
        range: std::ops::Range<usize>,
        points: &[[f64; 2]],
    ) -> Result<Vec<Complex64>> {
        let spectra = c.spectra.as_ref().ok_or_else(|| RadarError::Numerical {
            stage: "exact image".into(),
            reason: "compress() was called without keep_spectra".into(),
        })?;
        let geom = self.setup.geometry();
        let lam = geom.wavelength_m;
        Ok(points
            .par_iter()
            .map(|p| {
                let mut acc = Complex64::new(0.0, 0.0);
                for k in range.clone() {
                    let pl = &c.pulses[k];
                    let r = geom.bistatic_range_m(*p, pl.pos_m);
                    let d = r * geom.fs_hz / C_MPS - pl.window_delay_samples as f64;
                    let cyc = r / lam;
                    acc += self.compressor.evaluate(&spectra[k], d)
                        * Complex64::from_polar(
                            pl.weight as f64,
                            std::f64::consts::TAU * (cyc - cyc.floor()),
                        );
                }
                acc
            })
            .collect())
    }

    /// Measures the −3 dB range and Doppler widths of a point target at `target_m` from the
    /// exact image of pulses `range` (one look) and compares them with the predictions.
    pub fn measure_resolution(
        &self,
        c: &Compressed,
        pulses: &[PulseMeta],
        range: std::ops::Range<usize>,
        target_m: [f64; 2],
    ) -> Result<ResolutionReport> {
        let ps = &pulses[range.clone()];
        let (first, last) = match (ps.first(), ps.last()) {
            (Some(a), Some(b)) if ps.len() >= 2 => (a, b),
            _ => {
                return Err(RadarError::Mismatch(
                    "resolution check needs at least 2 pulses".into(),
                ))
            }
        };
        let params = &self.setup.params;
        let uc = [
            (first.pos_m[0] + last.pos_m[0]) / 2.0,
            (first.pos_m[1] + last.pos_m[1]) / 2.0,
        ];
        let dt = last.t_s - first.t_s;
        let vel: [f64; 2] = (Vector2::new(
            last.pos_m[0] - first.pos_m[0],
            last.pos_m[1] - first.pos_m[1],
        ) * (1.0 / dt))
            .into();
        let g = pg::bistatic_range_gradient(params, uc, target_m);
        let d = pg::doppler_gradient(params, uc, vel, target_m);
        let (vr, va) = cut_directions(g, d).ok_or_else(|| {
            RadarError::Mismatch("degenerate geometry: zero range or Doppler gradient".into())
        })?;
        let pc = &self.setup.scene.processing;
        let t_look = ps.len() as f64 / self.setup.scene.radar.prf_hz;
        let fr = pc.range_weighting.mainlobe_factor();
        let fa = pc.azimuth_weighting.mainlobe_factor();
        let b = self.setup.num.bandwidth_hz();
        let range_general = fr * C_MPS / (b * Vector2::from(g).length());
        let az_general = fa / (t_look * Vector2::from(d).length());
        let measure = |dir: [f64; 2], proj: f64| -> Result<f64> {
            // width along the cut ≈ predicted ground width / |cos| of the mapping
            let expect = proj.max(1e-3);
            let step = expect / 30.0;
            let s: Vec<f64> = (-105..=105).map(|i| i as f64 * step).collect();
            let pts: Vec<[f64; 2]> = s
                .iter()
                .map(|t| [target_m[0] + t * dir[0], target_m[1] + t * dir[1]])
                .collect();
            let img = self.image_points_exact(c, range.clone(), &pts)?;
            let pw: Vec<f64> = img.iter().map(|v| v.norm_sqr()).collect();
            half_power_width(&s, &pw).ok_or_else(|| RadarError::Numerical {
                stage: "resolution".into(),
                reason: "the response does not fall by 3 dB within the cut".into(),
            })
        };
        let gn = Vector2::from(g).length();
        let dn = Vector2::from(d).length();
        let cr = Vector2::from(g).dot(&Vector2::from(vr)).abs() / gn; // ground width along g = W_cut · cr
        let ca = Vector2::from(d).dot(&Vector2::from(va)).abs() / dn;
        let w_r = measure(vr, range_general / cr.max(1e-6))?;
        let w_a = measure(va, az_general / ca.max(1e-6))?;
        let cell = pg::ResolutionCell::new(params, uc, vel, target_m);
        Ok(ResolutionReport {
            range_measured_m: w_r * cr,
            range_general_m: range_general,
            range_paper_m: pg::range_resolution_paper_m(params, target_m),
            azimuth_measured_m: w_a * ca,
            azimuth_general_m: az_general,
            azimuth_paper_m: pg::azimuth_resolution_paper_m(params, Vector2::from(vel).length()),
            mainlobe_factor: fr,
            azimuth_mainlobe_factor: fa,
            bistatic_angle_deg: pg::bistatic_angle_rad(params, uc, target_m).to_degrees(),
            psi_deg: cell.psi_rad.to_degrees(),
        })
    }

    /// Exact (sinc-interpolated, f64) image value at `p` from the kept spectra of pulses
    /// `range` of `c` (sequential; see [`Processor::image_points_exact`] for many points).
    fn exact_value(
        &self,
        c: &Compressed,
        spectra: &[Vec<Complex64>],
        range: std::ops::Range<usize>,
        p: [f64; 2],
    ) -> Complex64 {
        let geom = self.setup.geometry();
        let mut acc = Complex64::new(0.0, 0.0);
        for k in range {
            let pl = &c.pulses[k];
            let r = geom.bistatic_range_m(p, pl.pos_m);
            let d = r * geom.fs_hz / C_MPS - pl.window_delay_samples as f64;
            let cyc = r / geom.wavelength_m;
            acc += self.compressor.evaluate(&spectra[k], d)
                * Complex64::from_polar(
                    pl.weight as f64,
                    std::f64::consts::TAU * (cyc - cyc.floor()),
                );
        }
        acc
    }

    /// Measures the −3 dB region of the point response of a target at `target_m` in the exact
    /// image of pulses `range` (one look, noise-free data, `compress(.., keep_spectra = true)`)
    /// in 36 directions plus the four principal ones (g, the Doppler gradient, the iso-Doppler
    /// and the iso-range lines), and compares its principal widths with the predicted cell.
    pub fn measure_cell(
        &self,
        c: &Compressed,
        pulses: &[PulseMeta],
        range: std::ops::Range<usize>,
        target_m: [f64; 2],
    ) -> Result<crate::resolution::CellReport> {
        let spectra = c.spectra.as_ref().ok_or_else(|| RadarError::Numerical {
            stage: "cell measurement".into(),
            reason: "compress() was called without keep_spectra".into(),
        })?;
        let ps = &pulses[range.clone()];
        let (first, last) = match (ps.first(), ps.last()) {
            (Some(a), Some(b)) if ps.len() >= 2 => (a, b),
            _ => {
                return Err(RadarError::Mismatch(
                    "cell measurement needs at least 2 pulses".into(),
                ))
            }
        };
        let uc = [
            (first.pos_m[0] + last.pos_m[0]) / 2.0,
            (first.pos_m[1] + last.pos_m[1]) / 2.0,
        ];
        let vel: [f64; 2] = (Vector2::new(
            last.pos_m[0] - first.pos_m[0],
            last.pos_m[1] - first.pos_m[1],
        ) * (1.0 / (last.t_s - first.t_s)))
            .into();
        let mut params = self.setup.params.clone();
        params.integration_time_s = ps.len() as f64 / self.setup.scene.radar.prf_hz;
        params.bandwidth_hz = self.setup.num.bandwidth_hz();
        let cell = pg::ResolutionCell::new(&params, uc, vel, target_m);
        let g = pg::bistatic_range_gradient(&params, uc, target_m);
        let d = pg::doppler_gradient(&params, uc, vel, target_m);
        let (vr, va) = cut_directions(g, d).ok_or_else(|| {
            RadarError::Mismatch("degenerate geometry: zero range or Doppler gradient".into())
        })?;
        let gh: [f64; 2] = (Vector2::from(g) * (1.0 / Vector2::from(g).length())).into();
        let dh: [f64; 2] = (Vector2::from(d) * (1.0 / Vector2::from(d).length())).into();
        let pc = &self.setup.scene.processing;
        let fr = pc.range_weighting.mainlobe_factor();
        let fa = pc.azimuth_weighting.mainlobe_factor();
        let peak = self
            .exact_value(c, spectra, range.clone(), target_m)
            .norm_sqr();
        if peak.is_nan() || peak <= 0.0 {
            return Err(RadarError::Numerical {
                stage: "cell measurement".into(),
                reason: "no response at the target".into(),
            });
        }
        let power = |p: [f64; 2]| self.exact_value(c, spectra, range.clone(), p).norm_sqr() / peak;
        let smallest = (fr * cell.range_width_m).min(fa * cell.along_track_width_m);
        let max_m = (50.0 * smallest).max(3000.0);
        let region = crate::resolution::PsfRegion::measure(
            &power,
            target_m,
            36,
            &[gh, dh, vr, va],
            0.05 * smallest,
            max_m,
        )
        .ok_or_else(|| RadarError::Numerical {
            stage: "cell measurement".into(),
            reason: format!("the response does not fall by 3 dB within {max_m:.0} m"),
        })?;
        let cross = region.chord_m(vr);
        let iso = region.chord_m(va);
        let (longest, dir) = region.longest_chord();
        Ok(crate::resolution::CellReport {
            bandwidth_hz: params.bandwidth_hz,
            bistatic_angle_deg: pg::bistatic_angle_rad(&params, uc, target_m).to_degrees(),
            psi_deg: cell.psi_rad.to_degrees(),
            range_width_m: region.caliper_m(gh),
            range_width_pred_m: fr * cell.range_width_m,
            along_track_width_m: region.caliper_m(dh),
            along_track_width_pred_m: fa * cell.along_track_width_m,
            cross_track_width_m: cross,
            cross_track_width_pred_m: fr * cell.cross_track_width_m,
            iso_range_width_m: iso,
            iso_range_width_pred_m: fa * cell.iso_range_width_m,
            worst_width_m: cross.max(iso),
            worst_width_pred_m: (fr * cell.cross_track_width_m).max(fa * cell.iso_range_width_m),
            longest_chord_m: longest,
            longest_chord_deg: dir.to_degrees(),
            chord_along_g_m: region.chord_m(gh),
            paper_range_m: pg::range_resolution_paper_m(&params, target_m),
            paper_azimuth_m: pg::azimuth_resolution_paper_m(&params, Vector2::from(vel).length()),
            planner_worst_width_m: cell.worst_width_m,
            mainlobe_factors: [fr, fa],
            region,
            axes: [gh, dh],
        })
    }

    /// Processes one aperture: cancellation, compression, look images, multilook, CFAR,
    /// clustering, scoring against `objects` inside the grid.
    pub fn process_aperture(
        &self,
        ap: &Aperture,
        pulses: &[PulseMeta],
        iq: &[Complex32],
        objects: &[SceneObject],
    ) -> Result<ApertureResult> {
        if pulses.len() != ap.pulses() {
            return Err(RadarError::Shape {
                what: format!("aperture {} pulses", ap.index),
                expected: ap.pulses().to_string(),
                found: pulses.len().to_string(),
            });
        }
        let grid = self.setup.grid(ap);
        let pc = &self.setup.scene.processing;
        let ppl = ap.pulses_per_look;
        let c = self.compress(&grid, pulses, iq, ppl, Some(ap.centre_m), false)?;
        let noise_var = self.look_noise_var(ppl);
        let mut multilook = vec![0f32; grid.pixels()];
        let mut looks = Vec::new();
        for l in 0..ap.looks {
            let img = self.image_look(&grid, &c, l * ppl..(l + 1) * ppl)?;
            let s = (1.0 / (noise_var * ap.looks as f64)) as f32;
            for (o, v) in multilook.iter_mut().zip(&img) {
                *o += v.norm_sqr() * s;
            }
            if pc.save_complex {
                looks.push(img);
            }
        }
        let det = self.detect(ap, pulses, &multilook)?;
        let echo_power_w = self.echo_power_w(objects, pulses);
        let floor_w =
            echo_power_w + self.noise_power_w() * c.cancel.noise_retained(self.setup.num.fft_size);
        let image_floor_pred = 1.0 + self.isi_power_w(objects, pulses) / self.noise_power_w();
        self.score_aperture(
            ap,
            pulses,
            multilook,
            looks,
            det,
            (c.cancel, echo_power_w, floor_w, image_floor_pred),
            noise_var,
            objects,
        )
    }

    /// Per look of `ap` (from its own pulses: the middle one's position, the velocity over the
    /// look): the range cells per metre `g B / c` and the Doppler cells per metre `∇f_D T` at
    /// ground point `point_m` (a [`ResponseModel`]'s looks).
    pub fn look_gradients(
        &self,
        ap: &Aperture,
        pulses: &[PulseMeta],
        point_m: [f64; 2],
    ) -> Vec<([f64; 2], [f64; 2])> {
        let b = self.setup.num.bandwidth_hz();
        let params = &self.setup.params;
        pulses
            .chunks(ap.pulses_per_look.max(1))
            .filter(|c| c.len() >= 2)
            .map(|c| {
                let (a, z) = (&c[0], &c[c.len() - 1]);
                let m = &c[c.len() / 2];
                let v: [f64; 2] = (Vector2::new(z.pos_m[0] - a.pos_m[0], z.pos_m[1] - a.pos_m[1])
                    * (1.0 / (z.t_s - a.t_s).max(1e-9)))
                .into();
                let u = [m.pos_m[0], m.pos_m[1]];
                let t = c.len() as f64 / self.setup.scene.radar.prf_hz;
                (
                    (Vector2::from(pg::bistatic_range_gradient(params, u, point_m)) * (b / C_MPS))
                        .into(),
                    (Vector2::from(pg::doppler_gradient(params, u, v, point_m)) * t).into(),
                )
            })
            .collect()
    }

    /// CFAR detection and clustering on the multilook image of aperture `ap` (mean over its
    /// looks of |I|² / per-look noise variance), with the guard and coherence area of the
    /// predicted cell at the image centre, mid-aperture.
    pub fn detect(
        &self,
        ap: &Aperture,
        pulses: &[PulseMeta],
        multilook: &[f32],
    ) -> Result<Detected> {
        let grid = self.setup.grid(ap);
        if multilook.len() != grid.pixels() || pulses.is_empty() {
            return Err(RadarError::Shape {
                what: format!("aperture {} multilook image", ap.index),
                expected: format!("{} pixels, ≥ 1 pulse", grid.pixels()),
                found: format!("{} pixels, {} pulses", multilook.len(), pulses.len()),
            });
        }
        let pc = &self.setup.scene.processing;
        // predicted cell at the image centre, mid-aperture
        let mid = &pulses[pulses.len() / 2];
        let (a, b) = (&pulses[0], &pulses[pulses.len() - 1]);
        let vel: [f64; 2] = (Vector2::new(b.pos_m[0] - a.pos_m[0], b.pos_m[1] - a.pos_m[1])
            * (1.0 / (b.t_s - a.t_s).max(1e-9)))
        .into();
        let vel = if Vector2::from(vel).length() > 1e-9 {
            vel
        } else {
            [mid.heading[0] * 1e-9, mid.heading[1] * 1e-9]
        };
        let mut params = self.setup.params.clone();
        params.integration_time_s = self.setup.look_s;
        let cell = pg::ResolutionCell::new(&params, [mid.pos_m[0], mid.pos_m[1]], vel, ap.centre_m);
        let uc = [mid.pos_m[0], mid.pos_m[1]];
        let g = pg::bistatic_range_gradient(&params, uc, ap.centre_m);
        let d = pg::doppler_gradient(&params, uc, vel, ap.centre_m);
        let b = self.setup.num.bandwidth_hz();
        // the guard stays inside the grid: every pixel keeps a training band on each side
        let max_guard = |n: usize| ((n.saturating_sub(1)) / 2).saturating_sub(pc.cfar_train_px);
        let (gx, gy, ppc) = cfar_geometry(
            g,
            d,
            b,
            self.setup.look_s,
            pc,
            grid.spacing_m,
            (max_guard(grid.nx), max_guard(grid.ny)),
        );
        let cfar = CfarParams {
            pfa: pc.pfa,
            guard_x_px: pc.cfar_guard_px.unwrap_or(gx),
            guard_y_px: pc.cfar_guard_px.unwrap_or(gy),
            train_px: pc.cfar_train_px,
            looks: ap.looks,
            pixels_per_cell: ppc,
            // the image is normalised to the per-look thermal noise variance
            known_floor: Some(1.0),
        };
        let map = ca_cfar(multilook, grid.nx, grid.ny, &cfar);
        let per_look = self.look_gradients(ap, pulses, ap.centre_m);
        let per_look = if per_look.is_empty() {
            vec![(
                (Vector2::from(g) * (b / C_MPS)).into(),
                (Vector2::from(d) * self.setup.look_s).into(),
            )]
        } else {
            per_look
        };
        let model = ResponseModel::new(per_look, pc.range_weighting, pc.azimuth_weighting);
        let d_min = self.setup.params.d_min_m;
        let detections = cluster(
            multilook,
            &map,
            &grid,
            pc.cluster_radius_m.unwrap_or(d_min / 2.0),
            ap.index,
            Some(&model),
        );
        Ok(Detected {
            detections,
            map,
            cfar,
            cell,
            pixels_per_cell: ppc,
            model,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn score_aperture(
        &self,
        ap: &Aperture,
        pulses: &[PulseMeta],
        multilook: Vec<f32>,
        looks: Vec<Vec<Complex32>>,
        det: Detected,
        (cancel, echo_power_w, predicted_floor_w, predicted_image_floor): (
            CancelStats,
            f64,
            f64,
            f64,
        ),
        noise_var: f64,
        objects: &[SceneObject],
    ) -> Result<ApertureResult> {
        let grid = self.setup.grid(ap);
        let pc = &self.setup.scene.processing;
        let ppl = ap.pulses_per_look;
        let d_min = self.setup.params.d_min_m;
        let Detected {
            detections: dets,
            map,
            cfar,
            cell,
            pixels_per_cell: ppc,
            model,
        } = det;
        let gate = pc.match_radius_m.unwrap_or(d_min / 2.0);
        // truth inside the grid (one pixel margin), and the objects near enough for their
        // responses to reach into it, with the mean over looks of the expected per-look SNR
        let margin = grid.spacing_m;
        let half_x = (grid.nx as f64 - 1.0) / 2.0 * grid.spacing_m - margin;
        let half_y = (grid.ny as f64 - 1.0) / 2.0 * grid.spacing_m - margin;
        let snr_lin = |o: &SceneObject| -> f64 {
            (0..ap.looks)
                .map(|l| {
                    10f64.powf(self.expected_snr_db(o, &pulses[l * ppl..(l + 1) * ppl]) / 10.0)
                })
                .sum::<f64>()
                / ap.looks as f64
        };
        let reach = NEAR_OBJECT_REACH * half_x.max(half_y);
        let near: Vec<(&SceneObject, f64)> = objects
            .iter()
            .filter(|o| {
                (o.x_m - grid.centre_m[0]).abs() <= half_x + reach
                    && (o.y_m - grid.centre_m[1]).abs() <= half_y + reach
            })
            .map(|o| (o, snr_lin(o)))
            .collect();
        // each object's response linearised at the object itself
        let models: Vec<ResponseModel> = near
            .iter()
            .map(|(o, _)| {
                ResponseModel::new(
                    self.look_gradients(ap, pulses, o.pos_m()),
                    pc.range_weighting,
                    pc.azimuth_weighting,
                )
            })
            .collect();
        let truth: Vec<TruthInImage> = near
            .iter()
            .filter(|(o, _)| {
                (o.x_m - grid.centre_m[0]).abs() <= half_x
                    && (o.y_m - grid.centre_m[1]).abs() <= half_y
            })
            .map(|(o, lin)| TruthInImage {
                id: o.id,
                pos_m: o.pos_m(),
                expected_snr_db: 10.0 * lin.log10(),
                landmark: o.landmark,
            })
            .collect();
        let sc = score(&truth, &dets, gate);
        // pixel-level false alarms where the image is noise: outside every object's gate, and
        // where the objects' predicted responses (expected SNR × the response envelope, incl.
        // sidelobes) stay below CLEAR_SIGNAL of the thermal noise
        let mut fa_px = 0;
        let mut clear = 0;
        // pixels outside every object's gate: where a detection is a false alarm
        let mut outside_gates = 0usize;
        let in_gate = |x: f64, y: f64| {
            near.iter()
                .any(|(o, _)| (o.x_m - x).hypot(o.y_m - y) <= gate)
        };
        // exceedance regions that reach an object's gate are its response (where the linear
        // response model misses it: near-blind geometry)
        let (label, sizes) = crate::cfar::components(&map.hits, grid.nx, grid.ny);
        let mut signal_region = vec![false; sizes.len()];
        for (i, l) in label.iter().enumerate() {
            if *l != usize::MAX
                && !signal_region[*l]
                && in_gate(grid.x(i % grid.nx), grid.y(i / grid.nx))
            {
                signal_region[*l] = true;
            }
        }
        for iy in 0..grid.ny {
            for ix in 0..grid.nx {
                let (x, y) = (grid.x(ix), grid.y(iy));
                if in_gate(x, y) {
                    continue;
                }
                let l = label[iy * grid.nx + ix];
                if l != usize::MAX && signal_region[l] {
                    outside_gates += 1;
                    continue;
                }
                outside_gates += 1;
                let mut signal = 0.0;
                for ((o, lin), m) in near.iter().zip(&models) {
                    signal += lin * m.envelope([x - o.x_m, y - o.y_m]);
                    if signal >= CLEAR_SIGNAL {
                        break;
                    }
                }
                if signal < CLEAR_SIGNAL {
                    clear += 1;
                    if map.hits[iy * grid.nx + ix] {
                        fa_px += 1;
                    }
                }
            }
        }
        let area_m2 = outside_gates as f64 * grid.spacing_m * grid.spacing_m;
        let design_false_alarms = area_m2
            * expected_peaks_per_m2(
                cfar.pfa,
                map.median_cells,
                cfar.looks,
                model.noise_curvature_per_m2(),
            );
        Ok(ApertureResult {
            aperture: ap.clone(),
            grid,
            multilook,
            looks,
            detections: dets,
            score: sc,
            cancel,
            false_alarm_pixels: fa_px,
            clear_pixels: clear,
            design_false_alarm_pixels: cfar.pfa * clear as f64,
            design_false_alarms,
            cfar_fallback_pixels: map.fallback_pixels,
            cell,
            mainlobe_factors: [
                pc.range_weighting.mainlobe_factor(),
                pc.azimuth_weighting.mainlobe_factor(),
            ],
            echo_power_w,
            predicted_floor_w,
            direct_path: self.setup.scene.radar.direct_path,
            image_floor: map.floor,
            predicted_image_floor,
            gate_m: gate,
            noise_var,
            pixels_per_cell: ppc,
        })
    }
}
