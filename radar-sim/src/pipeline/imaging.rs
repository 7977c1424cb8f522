//! Look images and resolution measurements ([`Processor::image_look`],
//! [`Processor::measure_resolution`], ...).

use rayon::prelude::*;
use rustfft::num_complex::{Complex32, Complex64};

use crate::backproject::{backproject, Grid};
use crate::error::{RadarError, Result};
use crate::resolution::{cut_directions, half_power_width, ResolutionReport};
use crate::track::PulseMeta;
use crate::waveform::C_MPS;
use planner::geometry::{self as pg, Length, Vector2};

use super::{Compressed, Processor};

impl Processor {
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
        // the geometry at the look's altitude (H_t of a free mission)
        let params = &planner::altitude::params_at(
            &self.setup.params,
            (first.pos_m[2] + last.pos_m[2]) / 2.0,
        );
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
    pub(super) fn exact_value(
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
        let mut params = planner::altitude::params_at(
            &self.setup.params,
            (first.pos_m[2] + last.pos_m[2]) / 2.0,
        );
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
        // the predicted −3 dB ellipse (the weighted widths) and its major axis, measured too
        let (range_pred, along_pred) = (fr * cell.range_width_m, fa * cell.along_track_width_m);
        let (worst_pred, minor_pred) =
            pg::cell_ellipse_axes_m(range_pred, along_pred, cell.psi_rad.sin());
        let major_dir = pg::cell_ellipse_major_direction(gh, range_pred, dh, along_pred);
        let region = crate::resolution::PsfRegion::measure(
            &power,
            target_m,
            36,
            &[gh, dh, vr, va, major_dir],
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
            worst_width_m: longest,
            worst_width_pred_m: worst_pred,
            minor_width_pred_m: minor_pred,
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
}
