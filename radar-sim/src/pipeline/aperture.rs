//! Processing and scoring one aperture ([`Processor::process_aperture`]).

use rustfft::num_complex::Complex32;

use crate::backproject::Grid;
use crate::cancel::CancelStats;
use crate::cfar::{expected_peaks_per_m2, CfarMap, LookImages, ResponseModel};
use crate::error::{RadarError, Result};
use crate::scene::SceneObject;
use crate::scoring::{score, TruthInImage};
use crate::track::{Aperture, PulseMeta};

use super::{ApertureResult, Detected, Processor};

/// A pixel counts as clear (noise only, for the pixel-level false-alarm count) where the truth
/// objects' predicted responses sum to less than this, in units of the thermal noise (−10 dB),
/// and it is in no exceedance region that reaches an object's gate.
pub const CLEAR_SIGNAL: f64 = 0.1;

/// Objects within this many grid half-widths outside the grid are counted for the clear pixels
/// (their responses reach into the image).
pub const NEAR_OBJECT_REACH: f64 = 2.0;

/// One aperture's images and detections, before scoring.
pub(super) struct Imaged {
    /// The multilook image, power over noise.
    multilook: Vec<f32>,
    /// The complex look images (kept with `processing.save_complex`).
    looks: Vec<Vec<Complex32>>,
    /// CFAR's detections.
    det: Detected,
    /// The noise variance of one look image.
    noise_var: f64,
}

impl Processor {
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
        // the guard band (coarser, around the grid): the range windows cover it too
        let band_grid = self.setup.guard_grid(ap);
        let c = self.compress(
            band_grid.as_ref().unwrap_or(&grid),
            pulses,
            iq,
            ppl,
            Some(ap.centre_m),
            false,
        )?;
        let noise_var = self.look_noise_var(ppl);
        let mut multilook = vec![0f32; grid.pixels()];
        let mut band = vec![0f32; band_grid.as_ref().map_or(0, Grid::pixels)];
        // the complex look images are kept for the exact sidelobe editing
        let mut looks = Vec::with_capacity(ap.looks);
        let mut band_looks = Vec::new();
        let s = (1.0 / (noise_var * ap.looks as f64)) as f32;
        for l in 0..ap.looks {
            let img = self.image_look(&grid, &c, l * ppl..(l + 1) * ppl)?;
            for (o, v) in multilook.iter_mut().zip(&img) {
                *o += v.norm_sqr() * s;
            }
            looks.push(img);
            if let Some(bg) = &band_grid {
                let img = self.image_look(bg, &c, l * ppl..(l + 1) * ppl)?;
                for (o, v) in band.iter_mut().zip(&img) {
                    *o += v.norm_sqr() * s;
                }
                band_looks.push(img);
            }
        }
        let exact = self.exact_response(&c, ap);
        let gains = |q: [f64; 2]| self.pulse_gains(pulses, q);
        let ghost_model = super::ghost::GhostModel::new(self, pulses, ppl, ap.looks);
        let ghosts = |q: [f64; 2], peak: f64| {
            ghost_model
                .as_ref()
                .map(|g| g.profiles(q, peak))
                .unwrap_or_default()
        };
        let det = self.detect_edited(
            ap,
            pulses,
            &multilook,
            band_grid.as_ref().map(|g| (g, band.as_slice())),
            Some(LookImages {
                response: &exact,
                grid: &looks,
                band_grid,
                band: &band_looks,
                scale: f64::from(s),
                gains: &gains,
                ghosts: ghost_model.is_some().then_some(&ghosts as _),
            }),
        )?;
        if !pc.save_complex {
            looks = Vec::new();
        }
        let echo_power_w = self.echo_power_w(objects, pulses);
        let floor_w =
            echo_power_w + self.noise_power_w() * c.cancel.noise_retained(self.setup.num.fft_size);
        let image_floor_pred = 1.0 + self.isi_power_w(objects, pulses) / self.noise_power_w();
        let imaged = Imaged {
            multilook,
            looks,
            det,
            noise_var,
        };
        self.score_aperture(
            ap,
            pulses,
            imaged,
            (c.cancel, echo_power_w, floor_w, image_floor_pred),
            objects,
        )
    }

    pub(super) fn score_aperture(
        &self,
        ap: &Aperture,
        pulses: &[PulseMeta],
        imaged: Imaged,
        (cancel, echo_power_w, predicted_floor_w, predicted_image_floor): (
            CancelStats,
            f64,
            f64,
            f64,
        ),
        objects: &[SceneObject],
    ) -> Result<ApertureResult> {
        let Imaged {
            multilook,
            looks,
            det,
            noise_var,
        } = imaged;
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
        let snr_lin =
            |o: &SceneObject| Self::mean_look_snr(&self.look_snrs_db(o, pulses, ppl, ap.looks));
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
        let (fa_px, clear, outside_gates) = false_alarm_pixels(&grid, &map, &near, &models, gate);
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

/// Pixel-level false alarms of `map` on `grid` (see `Processor::score_aperture`): the CFAR
/// exceedance pixels among the clear pixels, the clear pixels, and the pixels outside every
/// object's gate, as `(false alarm pixels, clear pixels, pixels outside the gates)`.
fn false_alarm_pixels(
    grid: &Grid,
    map: &CfarMap,
    near: &[(&SceneObject, f64)],
    models: &[ResponseModel],
    gate: f64,
) -> (usize, usize, usize) {
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
            for ((o, lin), m) in near.iter().zip(models) {
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
    (fa_px, clear, outside_gates)
}
