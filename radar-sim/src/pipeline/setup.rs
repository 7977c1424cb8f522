//! [`RadarSetup`]: everything fixed by a mission's parameters and a scene file.

use crate::antenna::Antenna;
use crate::backproject::{BpGeometry, Grid};
use crate::config::SceneFile;
use crate::error::{RadarError, Result};
use crate::scene::SceneObject;
use crate::synth::Synthesizer;
use crate::track::{plan_apertures, plan_pulses, Aperture, PulseMeta, Track};
use crate::waveform::Numerology;

/// Everything fixed by a mission's parameters and a scene file.
#[derive(Debug, Clone)]
pub struct RadarSetup {
    /// The mission parameters (geometry, B, λ, T_d, d_min, ...).
    pub params: planner::Params,
    /// The scene file, its `[radar]` resolved ([`crate::config::RadarConfig::resolve`]: under
    /// `[radar.nr]` the PRF, symbols per pulse, numerology and CP are the cell's).
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
        // under [radar.nr] the PRF, symbols per pulse, numerology and CP follow from the cell
        let (radar, nr) = scene.radar.resolve(params.bandwidth_hz)?;
        let scene = &SceneFile {
            radar,
            ..scene.clone()
        };
        let num =
            Numerology::new(&scene.radar, params.bandwidth_hz, params.wavelength_m)?.with_nr(nr)?;
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

    /// The guard band's grid of aperture `ap`: the image grid and the band around it
    /// (`processing.guard_band_m`), at [`crate::config::GUARD_BAND_PIXEL_FACTOR`] times the
    /// image's pixel spacing; `None` with the band off.
    pub fn guard_grid(&self, ap: &Aperture) -> Option<Grid> {
        let pc = &self.scene.processing;
        let band = pc.guard_band_width_m();
        (band > 0.0).then(|| {
            Grid::square(
                ap.centre_m,
                pc.grid_half_m + band,
                pc.pixel_m * crate::config::GUARD_BAND_PIXEL_FACTOR as f64,
            )
        })
    }
}
