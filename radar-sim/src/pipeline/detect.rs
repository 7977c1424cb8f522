//! CFAR detection on the multilook image ([`Processor::detect`]).

use crate::backproject::Grid;
use crate::cfar::{
    ca_alpha, ca_cfar, cluster_edited, outside_peaks, CfarParams, Detection, ExactResponse,
    LookImages, RangeResponse, ResponseModel,
};
use crate::error::{RadarError, Result};
use crate::track::{Aperture, PulseMeta};
use crate::waveform::C_MPS;
use planner::geometry::{self as pg, Length, Vector2};

use super::Processor;

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

impl Processor {
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
                // the geometry at the look's altitude (H_t of a free mission)
                let params = &planner::altitude::params_at(params, m.pos_m[2]);
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
    /// predicted cell at the image centre, mid-aperture. `band`: the multilook image of the
    /// guard band ([`super::RadarSetup::guard_grid`], on the same scale), whose peaks outside
    /// the grid above the CFAR threshold of the image-wide floor suppress the grid's skirts and
    /// sidelobes of objects beyond its edge ([`crate::cfar::cluster_with_outside`]).
    pub fn detect(
        &self,
        ap: &Aperture,
        pulses: &[PulseMeta],
        multilook: &[f32],
        band: Option<(&Grid, &[f32])>,
    ) -> Result<Detected> {
        self.detect_edited(ap, pulses, multilook, band, None)
    }

    /// The exact point response of the looks of aperture `ap` compressed into `c`
    /// ([`ExactResponse`]: the pulses' positions and slow-time weights, the range taper over the
    /// occupied subcarriers).
    pub fn exact_response(&self, c: &super::Compressed, ap: &Aperture) -> ExactResponse {
        let num = &self.setup.num;
        let ppl = ap.pulses_per_look.max(1);
        ExactResponse::new(
            self.setup.geometry(),
            c.pulses.clone(),
            (0..ap.looks).map(|l| l * ppl..(l + 1) * ppl).collect(),
            RangeResponse::new(
                self.setup.scene.processing.range_weighting,
                num.fft_size,
                num.subcarrier_index(0),
                num.subcarriers,
            ),
        )
    }

    /// Per pulse of `pulses` the echo amplitude of a unit-RCS point at ground position `q_m`
    /// (the link budget of [`Processor::expected_snr_db`]: antenna gains, ranges, the cyclic
    /// prefix's overlap), for [`ExactResponse::response`].
    pub fn pulse_gains(&self, pulses: &[PulseMeta], q_m: [f64; 2]) -> Vec<f64> {
        let geom = self.setup.geometry();
        let (n, cp) = (self.setup.num.fft_size, self.setup.num.cp_samples);
        let unit = crate::scene::SceneObject {
            id: 0,
            x_m: q_m[0],
            y_m: q_m[1],
            rcs_m2: 1.0,
            phase_rad: 0.0,
            landmark: None,
        };
        pulses
            .iter()
            .map(|p| {
                let delay = geom.delay_samples(q_m, p.pos_m, p.window_delay_samples);
                super::cp_overlap_factor(delay, n, cp)
                    * self.link.echo_power_w(&unit, p.pos_m, p.heading).sqrt()
            })
            .collect()
    }

    /// [`Processor::detect`] with, given the complex look images `looks`, sidelobe editing
    /// against the exact point response as well ([`cluster_edited`]).
    pub fn detect_edited(
        &self,
        ap: &Aperture,
        pulses: &[PulseMeta],
        multilook: &[f32],
        band: Option<(&Grid, &[f32])>,
        looks: Option<LookImages<'_>>,
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
        let mut params = planner::altitude::params_at(&self.setup.params, mid.pos_m[2]);
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
        let outside = match band {
            Some((bg, img)) => {
                let threshold = ca_alpha(cfar.pfa, map.median_cells.max(1.0), cfar.looks)
                    * map.floor.max(f64::MIN_POSITIVE);
                outside_peaks(img, bg, &grid, threshold)
            }
            None => Vec::new(),
        };
        let started = std::time::Instant::now();
        let edited = looks.is_some();
        let detections = cluster_edited(
            multilook,
            &map,
            &grid,
            &outside,
            pc.cluster_radius_m.unwrap_or(d_min / 2.0),
            ap.index,
            Some(&model),
            looks,
        );
        tracing::debug!(
            aperture = ap.index,
            exact_editing = edited,
            elapsed_ms = started.elapsed().as_secs_f64() * 1e3,
            "peaks, non-maximum suppression and sidelobe editing"
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
}
