//! Distributed ground clutter: the constant-γ model under the objects (`[clutter]`,
//! [`crate::config::ClutterConfig`]).
//!
//! **Reflectivity.** The ground's bistatic backscatter coefficient is the constant-γ model in
//! its bistatic form, `σ⁰ = γ √(sin ψ_i sin ψ_s)` (the geometric mean of the grazing angles
//! of incidence, from the BS, and of scattering, towards the UAV: Willis, *Bistatic Radar*,
//! ch. 9; monostatic it is `γ sin ψ`, Long, *Radar Reflectivity of Land and Sea*). On the flat
//! ground `sin ψ_i = H_b / |BS − p|` and `sin ψ_s = z_UAV / |UAV − p|`, the UAV at the
//! aperture's middle pulse. γ comes from a terrain table
//! ([`crate::config::Terrain`], 10 GHz values scaled to the carrier by Barton's
//! `5 log10(f / 10 GHz)` dB) or is given.
//!
//! **Scatterers.** The ground is a fixed lattice of spacing `s` anchored at the origin; node
//! (i, j) holds one scatterer placed uniformly within its `s × s` cell (jitter), with a uniform
//! phase and a power `σ⁰ s² E`, E ~ Exp(1) (a Rayleigh amplitude): the mean RCS per unit area
//! is σ⁰ and the image of many such scatterers per resolution cell is speckle. The node's
//! draws come from its own stream of the seeded ChaCha generator, so a node is the same
//! scatterer in every aperture whose patch holds it (the landmarks' patches overlap), and the
//! run is deterministic. `s = √(A_min / k)`, k scatterers per resolution cell
//! (`clutter.scatterers_per_cell`) of the smallest cell area `A_min` over the run's looks
//! ([`look_resolution_areas_m2`]).
//!
//! **Patch.** Each aperture synthesises the nodes of the square around its landmark of
//! half-width `clutter.half_width_m` (default: the image's half-width plus the guard band).
//! Ground beyond it is left out: with tapered responses its sidelobes in the image are
//! negligible, but the mirror ambiguities of far ground (e.g. through the antenna's back
//! lobe) are not modelled.
//!
//! **Image power.** A pixel's mean clutter power is `σ⁰ A` times the point response's peak
//! power per unit RCS, with `A = β_r β_a / |a_r × a_a|` the response's integrated area
//! (`a_r = g B / c` the range cells per metre, `a_a = ∇f_D T` the Doppler cells per metre,
//! β = `n Σw² / (Σw)²` each taper's noise bandwidth in cells: 1 untapered, 1.5 Hann) —
//! the closed form `tests/clutter.rs` checks the images against.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::config::{ClutterConfig, Weighting};
use crate::error::{RadarError, Result};
use crate::pipeline::RadarSetup;
use crate::scene::SceneObject;
use crate::synth::Synthesizer;
use crate::track::{dist3, Aperture, PulseMeta, Track};
use crate::waveform::C_MPS;
use planner::geometry as pg;

/// Most clutter scatterers in one aperture's patch (56 MB of scatterers, 40 MB of paths per
/// synthesis thread).
pub const MAX_CLUTTER_SCATTERERS: usize = 1_000_000;

/// A taper's noise bandwidth in resolution cells, `n Σw² / (Σw)²` over `n` samples (1 for no
/// taper, 1.5 for Hann): the integral of its normalised power response.
pub fn noise_bandwidth_cells(w: Weighting, n: usize) -> f64 {
    let ws = w.weights(n.max(1));
    let s1: f64 = ws.iter().sum();
    let s2: f64 = ws.iter().map(|x| x * x).sum();
    if s1 > 0.0 {
        ws.len() as f64 * s2 / (s1 * s1)
    } else {
        1.0
    }
}

/// Integrated area of a look's power response, m²: `β_r β_a / |a_r × a_a|` for range cells per
/// metre `a_r`, Doppler cells per metre `a_a` and the tapers' noise bandwidths `β`
/// ([`noise_bandwidth_cells`]); ∞ for parallel gradients (a blind geometry).
pub fn resolution_area_m2(
    range_cells_per_m: [f64; 2],
    doppler_cells_per_m: [f64; 2],
    beta_range: f64,
    beta_azimuth: f64,
) -> f64 {
    let (a, b) = (range_cells_per_m, doppler_cells_per_m);
    let cross = (a[0] * b[1] - a[1] * b[0]).abs();
    if cross > 0.0 {
        beta_range * beta_azimuth / cross
    } else {
        f64::INFINITY
    }
}

/// Per look of `ap` (its pulses `pulses`): the range and Doppler cells per metre at ground point
/// `point_m` (the middle pulse's position, the velocity over the look, the look's duration), as
/// the processor's response model takes them.
pub fn look_gradients(
    setup: &RadarSetup,
    ap: &Aperture,
    pulses: &[PulseMeta],
    point_m: [f64; 2],
) -> Vec<([f64; 2], [f64; 2])> {
    let b = setup.num.bandwidth_hz();
    pulses
        .chunks(ap.pulses_per_look.max(1))
        .filter(|c| c.len() >= 2)
        .map(|c| {
            let (a, z) = (&c[0], &c[c.len() - 1]);
            let m = &c[c.len() / 2];
            let dt = (z.t_s - a.t_s).max(1e-9);
            let v = [
                (z.pos_m[0] - a.pos_m[0]) / dt,
                (z.pos_m[1] - a.pos_m[1]) / dt,
            ];
            let u = [m.pos_m[0], m.pos_m[1]];
            let t = c.len() as f64 / setup.scene.radar.prf_hz;
            // the geometry at the look's altitude (a free mission's H_t; a fixed one's H exactly)
            let params = &planner::altitude::params_at(&setup.params, m.pos_m[2]);
            let g = pg::bistatic_range_gradient(params, u, point_m);
            let d = pg::doppler_gradient(params, u, v, point_m);
            ([g[0] * b / C_MPS, g[1] * b / C_MPS], [d[0] * t, d[1] * t])
        })
        .collect()
}

/// The integrated response area ([`resolution_area_m2`]) of each look of `ap` at `point_m`, m².
pub fn look_resolution_areas_m2(
    setup: &RadarSetup,
    ap: &Aperture,
    pulses: &[PulseMeta],
    point_m: [f64; 2],
) -> Vec<f64> {
    let pc = &setup.scene.processing;
    let beta_r = noise_bandwidth_cells(pc.range_weighting, setup.num.subcarriers);
    let beta_a = noise_bandwidth_cells(pc.azimuth_weighting, ap.pulses_per_look);
    look_gradients(setup, ap, pulses, point_m)
        .into_iter()
        .map(|(r, a)| resolution_area_m2(r, a, beta_r, beta_a))
        .collect()
}

/// The bistatic constant-γ reflectivity `γ √(sin ψ_i sin ψ_s)` at ground point `p_m` for a
/// transmitter at `tx_m` and a receiver at `rx_m` (x, y, height), linear `gamma`.
pub fn sigma0(gamma: f64, tx_m: [f64; 3], rx_m: [f64; 3], p_m: [f64; 2]) -> f64 {
    let q = [p_m[0], p_m[1], 0.0];
    let sin_grazing = |a: [f64; 3]| {
        let r = dist3(a, q);
        if r > 0.0 {
            (a[2] / r).clamp(0.0, 1.0)
        } else {
            1.0
        }
    };
    gamma * (sin_grazing(tx_m) * sin_grazing(rx_m)).sqrt()
}

/// The ground clutter of a run: the lattice, γ and the patch size.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundClutter {
    /// γ, linear.
    pub gamma: f64,
    /// Lattice spacing s, m.
    pub spacing_m: f64,
    /// Half-width of each aperture's square patch, m.
    pub half_width_m: f64,
    /// Seed of the lattice's draws.
    pub seed: u64,
}

impl GroundClutter {
    /// The clutter of `setup`'s scene for the apertures `aps` flown along `track`; `None` when
    /// `[clutter]` is off. The spacing gives `clutter.scatterers_per_cell` scatterers in the
    /// smallest look resolution area at any aperture's centre.
    pub fn for_run(
        setup: &RadarSetup,
        track: &dyn Track,
        aps: &[Aperture],
    ) -> Result<Option<Self>> {
        let cfg = &setup.scene.clutter;
        if !cfg.enabled {
            return Ok(None);
        }
        let min_area = aps
            .iter()
            .flat_map(|ap| {
                let pulses = setup.pulses(track, ap);
                look_resolution_areas_m2(setup, ap, &pulses, ap.centre_m)
            })
            .fold(f64::INFINITY, f64::min);
        if !min_area.is_finite() {
            return Err(RadarError::Mismatch(
                "clutter: no aperture has a look with a finite resolution cell to size the \
                 scatterer lattice by"
                    .into(),
            ));
        }
        let spacing = (min_area / cfg.scatterers_per_cell).sqrt();
        let pc = &setup.scene.processing;
        let half = cfg
            .half_width_m
            .unwrap_or(pc.grid_half_m + pc.guard_band_width_m());
        Self::new(cfg, C_MPS / setup.num.wavelength_m(), spacing, half).map(Some)
    }

    /// The clutter of `cfg` at carrier `carrier_hz` with lattice spacing `spacing_m` and patch
    /// half-width `half_width_m`; refuses a patch of more than [`MAX_CLUTTER_SCATTERERS`].
    pub fn new(
        cfg: &ClutterConfig,
        carrier_hz: f64,
        spacing_m: f64,
        half_width_m: f64,
    ) -> Result<Self> {
        cfg.validate()?;
        if !(spacing_m.is_finite() && spacing_m > 0.0) {
            return Err(RadarError::config(
                "clutter.scatterers_per_cell",
                format!("gives a lattice spacing of {spacing_m} m"),
            ));
        }
        let side = (2.0 * half_width_m / spacing_m).floor() + 1.0;
        if side * side > MAX_CLUTTER_SCATTERERS as f64 {
            return Err(RadarError::config(
                "clutter.scatterers_per_cell",
                format!(
                    "{} per cell puts scatterers {spacing_m:.3} m apart: {:.0} in a patch of \
                     half-width {half_width_m} m (clutter.half_width_m), at most \
                     {MAX_CLUTTER_SCATTERERS}",
                    cfg.scatterers_per_cell,
                    side * side
                ),
            ));
        }
        Ok(Self {
            gamma: cfg.gamma_linear(carrier_hz),
            spacing_m,
            half_width_m,
            seed: cfg.seed,
        })
    }

    /// The scatterers of the square patch around `centre_m` for a BS at `bs_m` and the UAV at
    /// `uav_m` (their σ⁰), ids from `first_id`.
    pub fn scatterers(
        &self,
        centre_m: [f64; 2],
        bs_m: [f64; 3],
        uav_m: [f64; 3],
        first_id: usize,
    ) -> Result<Vec<SceneObject>> {
        let s = self.spacing_m;
        let h = self.half_width_m;
        let index = |v: f64, up: bool| -> Result<i64> {
            let k = if up { (v / s).ceil() } else { (v / s).floor() };
            if k.abs() < i32::MAX as f64 {
                Ok(k as i64)
            } else {
                Err(RadarError::config(
                    "clutter.half_width_m",
                    format!("patch edge {v} m is beyond the lattice's ±2³¹ nodes of {s} m"),
                ))
            }
        };
        let (i0, i1) = (
            index(centre_m[0] - h, true)?,
            index(centre_m[0] + h, false)?,
        );
        let (j0, j1) = (
            index(centre_m[1] - h, true)?,
            index(centre_m[1] + h, false)?,
        );
        let base = ChaCha8Rng::seed_from_u64(self.seed ^ 0xC1A7_7E40_0000_0001);
        let cell_area = s * s;
        let mut out = Vec::new();
        for j in j0..=j1 {
            for i in i0..=i1 {
                let mut rng = base.clone();
                rng.set_stream((u64::from(i as i32 as u32) << 32) | u64::from(j as i32 as u32));
                let (u, v): (f64, f64) = (rng.gen(), rng.gen());
                let e = -(1.0 - rng.gen::<f64>()).ln();
                let phase = rng.gen_range(0.0..std::f64::consts::TAU);
                let p = [(i as f64 + u - 0.5) * s, (j as f64 + v - 0.5) * s];
                out.push(SceneObject {
                    id: first_id + out.len(),
                    x_m: p[0],
                    y_m: p[1],
                    rcs_m2: sigma0(self.gamma, bs_m, uav_m, p) * cell_area * e,
                    phase_rad: phase,
                    landmark: None,
                });
            }
        }
        Ok(out)
    }

    /// The synthesiser of aperture `ap` (pulses `pulses`): `objects` and the clutter of its
    /// patch, σ⁰ at its middle pulse.
    pub fn synthesizer(
        &self,
        setup: &RadarSetup,
        objects: &[SceneObject],
        ap: &Aperture,
        pulses: &[PulseMeta],
    ) -> Result<Synthesizer> {
        let uav = pulses
            .get(pulses.len() / 2)
            .map(|p| p.pos_m)
            .ok_or_else(|| RadarError::Mismatch(format!("aperture {} has no pulses", ap.index)))?;
        let clutter = self.scatterers(ap.centre_m, setup.bs_m, uav, objects.len())?;
        tracing::info!(
            aperture = ap.index,
            scatterers = clutter.len(),
            spacing_m = self.spacing_m,
            "ground clutter"
        );
        let mut all = objects.to_vec();
        all.extend(clutter);
        setup.synthesizer(all)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clutter(spacing: f64, half: f64) -> GroundClutter {
        let cfg = ClutterConfig {
            enabled: true,
            gamma_db: Some(-10.0),
            ..Default::default()
        };
        GroundClutter::new(&cfg, 3.5e9, spacing, half).unwrap()
    }

    #[test]
    fn noise_bandwidths_of_the_tapers() {
        assert!((noise_bandwidth_cells(Weighting::None, 1000) - 1.0).abs() < 1e-12);
        assert!((noise_bandwidth_cells(Weighting::Hann, 4096) - 1.5).abs() < 1e-3);
        // Hamming: (0.54² + 0.46²/2) / 0.54² = 1.3628
        assert!((noise_bandwidth_cells(Weighting::Hamming, 4096) - 1.3628).abs() < 1e-3);
    }

    #[test]
    fn sigma0_is_gamma_times_the_grazing_sines() {
        // monostatic at 30° grazing: γ sin ψ
        let tx = [0.0, 0.0, 50.0];
        let p = [50.0 * 3f64.sqrt(), 0.0];
        assert!((sigma0(0.1, tx, tx, p) - 0.05).abs() < 1e-12);
        // bistatic: the geometric mean of sin 30° and sin 90° (receiver overhead)
        let rx = [p[0], p[1], 20.0];
        assert!((sigma0(0.1, tx, rx, p) - 0.1 * 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn lattice_is_deterministic_shared_between_patches_and_has_mean_sigma0() {
        let c = clutter(0.5, 10.0);
        let (bs, uav) = ([1000.0, 0.0, 30.0], [0.0, -200.0, 100.0]);
        let a = c.scatterers([0.0, 0.0], bs, uav, 7).unwrap();
        assert_eq!(a, c.scatterers([0.0, 0.0], bs, uav, 7).unwrap());
        assert_eq!(a.len(), 41 * 41);
        assert_eq!(a[0].id, 7);
        // an overlapping patch holds the same scatterers where they overlap
        let b = c.scatterers([5.0, 0.0], bs, uav, 0).unwrap();
        let common: Vec<_> = a.iter().filter(|o| o.x_m >= -5.25 + 0.5).collect();
        for o in &common {
            assert!(
                b.iter()
                    .any(|q| q.x_m == o.x_m && q.y_m == o.y_m && q.phase_rad == o.phase_rad),
                "{o:?}"
            );
        }
        // every scatterer within its node's cell; the mean RCS per unit area is σ⁰
        let mut ratio = 0.0;
        for o in &a {
            let (i, j) = ((o.x_m / 0.5).round(), (o.y_m / 0.5).round());
            assert!((o.x_m - i * 0.5).abs() <= 0.25 && (o.y_m - j * 0.5).abs() <= 0.25);
            ratio += o.rcs_m2 / (sigma0(c.gamma, bs, uav, o.pos_m()) * 0.25);
        }
        let mean = ratio / a.len() as f64;
        // E ~ Exp(1): the mean of 1681 has a standard deviation of 1/41
        assert!((mean - 1.0).abs() < 4.0 / 41.0, "{mean}");
    }

    #[test]
    fn too_dense_a_lattice_is_refused_by_name() {
        let cfg = ClutterConfig {
            enabled: true,
            ..Default::default()
        };
        let e = GroundClutter::new(&cfg, 3.5e9, 0.01, 100.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("clutter.scatterers_per_cell"), "{e}");
    }
}
