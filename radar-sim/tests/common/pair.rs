//! Two point objects imaged along a planned track, for each of [`PHASES`] relative phases and
//! for their average: the chain is linear without the direct path and the canceller, so each
//! object's look images are formed once and combined (the average over the phases is the image
//! of two objects with independent random phases: the cross terms cancel exactly).

use planner::geometry::{self as pg, Length, Vector2, RIGHT_TURN};
use radar_sim::config::SceneFile;
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::scoring::{score, TruthInImage};
use radar_sim::synth::Components;
use radar_sim::track::PlannedTrack;
use rustfft::num_complex::{Complex32, Complex64};

/// Relative phases imaged (k·2π/PHASES).
pub const PHASES: usize = 8;

/// The unit iso-range direction (the long side of a near-blind cell) at `slot` for a landmark
/// at `landmark_m`.
pub fn iso_range_direction(
    m: &planner::Mission,
    traj: &planner::Trajectory,
    slot: usize,
    landmark_m: [f64; 2],
) -> [f64; 2] {
    let g = pg::bistatic_range_gradient(m.params(), traj.q(slot), landmark_m);
    let g = Vector2::from(g);
    (RIGHT_TURN.inverse() * g * (1.0 / g.length())).into()
}

/// Two objects of 10 m² `d_m` apart along `e`, centred on `centre_m`.
pub fn pair_along(centre_m: [f64; 2], e: [f64; 2], d_m: f64) -> Vec<SceneObject> {
    let h = d_m / 2.0;
    [-h, h]
        .iter()
        .enumerate()
        .map(|(id, &s)| SceneObject {
            id,
            x_m: centre_m[0] + s * e[0],
            y_m: centre_m[1] + s * e[1],
            rcs_m2: 10.0,
            phase_rad: 0.0,
            landmark: None,
        })
        .collect()
}

/// The scene of the pair tests: `scene` with the direct path and the canceller off (the chain
/// is then linear) and a 40 m image half-width.
pub fn linear(mut scene: SceneFile) -> SceneFile {
    scene.radar.direct_path = false;
    scene.processing.canceller = radar_sim::config::CancellerKind::None;
    scene.processing.grid_half_m = 40.0;
    scene
}

/// Per relative phase and for the phase average: (detections within 30 m of the pair's
/// centre, objects matched within d_min/2), imaging aperture `aperture` of the mission along
/// `traj`.
pub fn pair_detections(
    m: &planner::Mission,
    traj: &planner::Trajectory,
    scene: &SceneFile,
    aperture: usize,
    objects: &[SceneObject],
) -> (Vec<(usize, usize)>, (usize, usize)) {
    let setup = RadarSetup::new(m.params(), scene).unwrap();
    let aps = setup.apertures(m).unwrap();
    let ap = &aps[aperture];
    let centre = [
        (objects[0].x_m + objects[1].x_m) / 2.0,
        (objects[0].y_m + objects[1].y_m) / 2.0,
    ];
    let track = PlannedTrack::new(traj.clone(), m.params().altitude_m);
    let pulses = setup.pulses(&track, ap);
    let proc = Processor::new(setup.clone()).unwrap();
    let grid = setup.grid(ap);
    let ppl = ap.pulses_per_look;
    // look images of each object alone and of the noise alone
    let parts: Vec<Vec<Vec<Complex32>>> = [Some(0), Some(1), None]
        .iter()
        .map(|which| {
            let (objs, comps) = match which {
                Some(i) => (
                    vec![objects[*i]],
                    Components {
                        direct: false,
                        echoes: true,
                        noise: false,
                    },
                ),
                None => (
                    Vec::new(),
                    Components {
                        direct: false,
                        echoes: false,
                        noise: true,
                    },
                ),
            };
            let iq = setup
                .synthesizer(objs)
                .unwrap()
                .synthesize_frame(&pulses, comps)
                .unwrap();
            let c = proc
                .compress(&grid, &pulses, &iq, ppl, None, false)
                .unwrap();
            (0..ap.looks)
                .map(|l| proc.image_look(&grid, &c, l * ppl..(l + 1) * ppl).unwrap())
                .collect()
        })
        .collect();
    let scale = (1.0 / (proc.look_noise_var(ppl) * ap.looks as f64)) as f32;
    let truth: Vec<TruthInImage> = objects
        .iter()
        .map(|o| TruthInImage {
            id: o.id,
            pos_m: o.pos_m(),
            expected_snr_db: 30.0,
            landmark: None,
        })
        .collect();
    let gate = m.params().d_min_m / 2.0;
    let count = |ml: &[f32]| -> (usize, usize) {
        let d = proc.detect(ap, &pulses, ml, None).unwrap().detections;
        let near: Vec<_> = d
            .into_iter()
            .filter(|x| (x.x_m - centre[0]).hypot(x.y_m - centre[1]) < 30.0)
            .collect();
        let s = score(&truth, &near, gate);
        (
            near.len(),
            s.outcomes.iter().filter(|o| o.detection.is_some()).count(),
        )
    };
    let mut mean = vec![0f32; grid.pixels()];
    let mut per_phase = Vec::new();
    for k in 0..PHASES {
        let rot = Complex64::from_polar(1.0, std::f64::consts::TAU * k as f64 / PHASES as f64);
        let rot = Complex32::new(rot.re as f32, rot.im as f32);
        let mut ml = vec![0f32; grid.pixels()];
        for ((a, b), n) in parts[0].iter().zip(&parts[1]).zip(&parts[2]) {
            for (i, o) in ml.iter_mut().enumerate() {
                *o += (a[i] + rot * b[i] + n[i]).norm_sqr() * scale;
            }
        }
        per_phase.push(count(&ml));
        for (a, b) in mean.iter_mut().zip(&ml) {
            *a += b / PHASES as f32;
        }
    }
    (per_phase, count(&mean))
}
