//! Issue 6, the two-object test: two objects d_min apart along the iso-range direction of a
//! near-blind slot merge into one detection when imaged along a plan made with
//! `--resolution paper`, and are both detected along a plan made with `--resolution general`
//! (the same planner calls as `cellsar-planner plan missions/two-objects.toml --resolution ..`).
//!
//! The general plan keeps the worst cell width at d_min, the Rayleigh distance: whether two
//! coherent point echoes that far apart show a dip between them depends on their relative
//! phase. The test therefore images the pair for eight relative phases (the chain is linear
//! without the direct path and canceller: each object's look images are formed once and
//! combined) and detects on each image and on their mean, which is the image of two objects
//! with independent random phases (the cross terms cancel exactly over the eight phases).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use planner::evaluate::ResolutionMode;
use planner::geometry::{self as pg, Length, Vector2, RIGHT_TURN};
use radar_sim::config::{CancellerKind, SceneFile};
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::scoring::{score, TruthInImage};
use radar_sim::synth::Components;
use radar_sim::track::PlannedTrack;
use rustfft::num_complex::{Complex32, Complex64};

const PHASES: usize = 8;

fn mission() -> planner::Mission {
    planner::Mission::from_path(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("missions/two-objects.toml"),
    )
    .unwrap()
}

fn plan(m: &planner::Mission, resolution: ResolutionMode) -> planner::Trajectory {
    let opts = planner::PlanOptions {
        resolution,
        ..Default::default()
    };
    let r = planner::plan(m, &opts).unwrap();
    assert!(r.evaluation.is_feasible(), "{resolution:?} plan infeasible");
    r.trajectory
}

/// Worst cell width over the landmark's slots, at the middle one, and the iso-range unit
/// direction at the middle slot.
fn cell_facts(m: &planner::Mission, traj: &planner::Trajectory) -> (f64, f64, [f64; 2]) {
    let slots: Vec<usize> = (1..=m.slots())
        .filter(|t| m.schedule().slot_landmark[t - 1].is_some())
        .collect();
    let p = m.params();
    let lm = [0.0, 0.0];
    let cell = |t: usize| pg::ResolutionCell::new(p, traj.q(t), traj.velocity_mps(t), lm);
    let worst = slots
        .iter()
        .map(|t| cell(*t).worst_width_m)
        .fold(0.0, f64::max);
    let mid = slots[slots.len() / 2];
    let g = pg::bistatic_range_gradient(p, traj.q(mid), lm);
    let g = Vector2::from(g);
    let e = (RIGHT_TURN.inverse() * g * (1.0 / g.length())).into();
    (worst, cell(mid).worst_width_m, e)
}

/// Per relative phase (k·2π/8) and for the phase average: (detections within 30 m of the
/// landmark, objects matched within d_min/2).
fn detections(
    m: &planner::Mission,
    traj: &planner::Trajectory,
    objects: &[SceneObject],
) -> (Vec<(usize, usize)>, (usize, usize)) {
    let mut scene = SceneFile::default(); // unweighted: main lobes as the cell predicts
    scene.radar.direct_path = false;
    scene.processing.canceller = CancellerKind::None;
    scene.processing.grid_half_m = 40.0;
    let setup = RadarSetup::new(m.params(), &scene).unwrap();
    let aps = setup.apertures(m).unwrap();
    assert_eq!(aps.len(), 1);
    let ap = &aps[0];
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
        let d = proc.detect(ap, &pulses, ml).unwrap().detections;
        let near: Vec<_> = d
            .into_iter()
            .filter(|x| x.x_m.hypot(x.y_m) < 30.0)
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

#[test]
fn paper_plan_merges_general_plan_resolves() {
    let m = mission();
    let d_min = m.params().d_min_m;
    let paper = plan(&m, ResolutionMode::Paper);
    let general = plan(&m, ResolutionMode::General);
    let (pw, pmid, e) = cell_facts(&m, &paper);
    let (gw, gmid, _) = cell_facts(&m, &general);
    println!(
        "worst cell width over the landmark's slots: paper plan {pw:.1} m (middle slot {pmid:.1}), general plan {gw:.1} m (middle {gmid:.1}); d_min {d_min} m"
    );
    assert!(
        pmid > 1.4 * d_min,
        "the paper plan is not near blind: {pmid}"
    );
    assert!(
        gw <= d_min * (1.0 + 1e-6),
        "the general plan violates its bound: {gw}"
    );
    // the pair: d_min apart along the iso-range line of the paper plan's middle slot
    let h = d_min / 2.0;
    let objects: Vec<SceneObject> = [-h, h]
        .iter()
        .enumerate()
        .map(|(id, &s)| SceneObject {
            id,
            x_m: s * e[0],
            y_m: s * e[1],
            rcs_m2: 10.0,
            phase_rad: 0.0,
            landmark: None,
        })
        .collect();
    let (pp, pm) = detections(&m, &paper, &objects);
    let (gp, gm) = detections(&m, &general, &objects);
    println!("relative phase: (detections near the pair, objects matched) paper | general");
    for k in 0..PHASES {
        println!("  {k}·π/4: {:?} | {:?}", pp[k], gp[k]);
    }
    println!("  random phases (mean image): {pm:?} | {gm:?}");
    // paper plan: one merged detection, whatever the phases
    assert_eq!(pm.0, 1, "paper plan, random phases: {pm:?}");
    assert!(pp.iter().all(|x| x.0 == 1), "paper plan: {pp:?}");
    // general plan: both objects detected and matched
    assert_eq!(gm, (2, 2), "general plan, random phases: {gm:?}");
    // per phase: coherent echoes at the Rayleigh distance are resolved for part of the phases
    // (here 4 of 8); along the paper plan for none
    let resolved = gp.iter().filter(|x| **x == (2, 2)).count();
    assert!(
        resolved >= 2,
        "general plan resolves only {resolved} of {PHASES} phases"
    );
}
