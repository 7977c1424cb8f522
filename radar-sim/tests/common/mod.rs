//! Shared helpers of the integration tests.
#![allow(dead_code, missing_docs, clippy::unwrap_used, clippy::expect_used)]

use radar_sim::config::SceneFile;
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::track::{plan_apertures, plan_pulses, Aperture, LinearTrack, PulseMeta};

/// A UAV flying with `heading_deg` at `speed` whose sensing centre passes `target` at t = `t_mid`.
pub fn track_through(
    params: &planner::Params,
    target: [f64; 2],
    heading_deg: f64,
    speed: f64,
    t_mid: f64,
) -> LinearTrack {
    LinearTrack::through(params, target, heading_deg, speed, t_mid)
}

pub fn object(id: usize, p: [f64; 2], rcs: f64) -> SceneObject {
    SceneObject {
        id,
        x_m: p[0],
        y_m: p[1],
        rcs_m2: rcs,
        phase_rad: 0.3 * id as f64,
        landmark: None,
    }
}

/// One aperture of `looks` looks centred on `centre` starting at t0.
pub fn aperture(setup: &RadarSetup, centre: [f64; 2], t0: f64, looks: usize) -> Aperture {
    let t1 = t0 + looks as f64 * setup.look_s;
    plan_apertures(
        &[(centre, Some(0), t0, t1)],
        setup.look_s,
        setup.scene.radar.prf_hz,
    )
    .unwrap()
    .remove(0)
}

pub fn pulses(setup: &RadarSetup, track: &LinearTrack, ap: &Aperture) -> Vec<PulseMeta> {
    plan_pulses(track, &setup.num, setup.bs_m, ap, setup.scene.radar.prf_hz)
}

pub fn processor(params: &planner::Params, scene: &SceneFile) -> Processor {
    Processor::new(RadarSetup::new(params, scene).unwrap()).unwrap()
}
