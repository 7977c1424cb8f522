//! The radar confirms the worst direction of the resolution cell: its longest chord, the major
//! axis of the ellipse of J = (B/c)² g gᵀ + T_d² d dᵀ (`planner::geometry::cell_ellipse_axes_m`),
//! not the parallelogram's longer side (the larger of the cross-track and iso-range widths),
//! which the planner's best effort held within 0.95 d_min before it measured the ellipse.
//!
//! `data/old-best-effort/trajectory.csv` is that best effort of the default mission
//! (`missions/default-30m.toml`, the paper's dynamics; see its README). Today's evaluator finds
//! windows where every slot's parallelogram sides are within 0.95 d_min and yet the median
//! ellipse is wider than d_min. In the one with the widest ellipse, two objects d_min apart
//! along the ellipse's major axis at the landmark are imaged with the main job's radar and
//! processing, unweighted (the planner's d_min is the unweighted cell, 1/B and 1/T_d), along
//! that old plan and along today's best effort (planned here with the default options, what
//! `cellsar-planner plan missions/default-30m.toml` plans).
//!
//! The pair is in quadrature: object 2's look images are rotated, look by look, so that at the
//! midpoint its phase leads object 1's by π/2. The two responses then add in intensity (an
//! anti-phase pair always shows a null between its objects, an in-phase pair merges even
//! beyond the −3 dB chord). The planner's cell along a line is, to second order about the
//! peak, the Rayleigh distance of the unweighted response along it (the separable
//! sinc²(α u) sinc²(β u) is 1 − (π²/3)(α² + β²) u² + …, and the ellipse's chord w along the
//! line is 1/√(α² + β²)): two such responses in quadrature exactly w apart show the Rayleigh
//! dip 10 lg(π²/8) = 0.91 dB between their maxima ([`rayleigh_dip_db`]), a deeper one when
//! farther apart, a shallower one when closer. So the pair is resolved in the planner's sense
//! where the profile along the line through both has two maxima with at least that dip between
//! them, and merged where the dip is shallower; the dips measured in the images agree with those
//! of that response model on each plan's geometry. The detector, on the image of the pair with
//! random phases (the intensity sum, `common/pair.rs`), reports one detection along the old plan
//! and both objects along today's.
//!
//! The contrast is Rayleigh's, the planner's own convention, not the −3 dB chord's: the old
//! plan's cells there exceed d_min by less than the unweighted main lobe's 1/0.886 (their −3 dB
//! chord is below d_min), so along both plans the midpoint is darker than the objects.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::f64::consts::PI;
use std::path::Path;

use planner::evaluate::{evaluate, Evaluation};
use planner::geometry::{bistatic_range_gradient, cell_ellipse_major_direction, ResolutionCell};
use planner::params::SPEED_OF_LIGHT_MPS;
use planner::shortfall::ResolutionShortfall;
use planner::{Mission, Trajectory};
use radar_sim::backproject::Grid;
use radar_sim::config::{SceneFile, Weighting};
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::synth::Components;
use radar_sim::track::{Aperture, PlannedTrack};
use rustfft::num_complex::Complex32;

#[path = "common/pair.rs"]
#[allow(dead_code)] // iso_range_direction: the pair here lies along the ellipse's major axis
mod pair;

/// The dip between the maxima of two equal sinc² responses in quadrature (adding in intensity)
/// one Rayleigh distance (peak to first null) apart: 10 lg(1 / (2 sinc²(½))) = 10 lg(π²/8),
/// 0.912 dB.
fn rayleigh_dip_db() -> f64 {
    10.0 * (PI * PI / 8.0).log10()
}

/// How far a dip measured in the image may lie from the response model's, dB (the model
/// neglects the amplitude changes within a look, the look's curved sweep of the range gradient
/// and the imaging grid's interpolation).
const MODEL_TOLERANCE_DB: f64 = 0.15;

/// The best effort planned by the parallelogram's sides: 0.95 d_min, and the planner's
/// exact-geometry margin on top.
const OLD_SIDE_BOUND_REL: f64 = 0.95 * (1.0 + 1e-3);

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

/// The cell of one landmark window along a plan, by today's evaluator.
#[derive(Debug, Clone)]
struct WindowCell {
    landmark: usize,
    /// Largest parallelogram side max(cross-track, iso-range) over the window's slots, m.
    max_side_m: f64,
    /// Median and largest ellipse major axis (the worst width) over the slots, m.
    median_ellipse_m: f64,
    max_ellipse_m: f64,
}

fn window_cells(m: &Mission, traj: &Trajectory, ev: &Evaluation) -> Vec<WindowCell> {
    ResolutionShortfall::new(m, ev)
        .windows
        .iter()
        .map(|w| {
            let max_side_m = (w.first_slot..=w.last_slot)
                .map(|t| {
                    let c = ResolutionCell::new(
                        m.params(),
                        traj.q(t),
                        traj.velocity_mps(t),
                        m.target_m(t).unwrap(),
                    );
                    // the evaluator's worst width is this cell's ellipse
                    let e = ev.slots[t - 1].worst_width_m;
                    assert!((c.worst_width_m - e).abs() <= 1e-9 * e, "slot {t}");
                    c.cross_track_width_m.max(c.iso_range_width_m)
                })
                .fold(0.0, f64::max);
            WindowCell {
                landmark: w.landmark,
                max_side_m,
                median_ellipse_m: w.median_worst_width_m,
                max_ellipse_m: w.max_worst_width_m,
            }
        })
        .collect()
}

fn unit(x: [f64; 2]) -> [f64; 2] {
    let n = x[0].hypot(x[1]);
    [x[0] / n, x[1] / n]
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// The range and Doppler spatial frequencies of the look of T_d centred at `t_s` along `traj`
/// at `point_m`: (B/c) g at the look's centre, and the change of the bistatic range gradient over
/// the look over λ, which is T_d d for a constant velocity (and, where the velocity changes
/// within the look, the Doppler extent the look actually sweeps), 1/m.
fn gradients(m: &Mission, traj: &Trajectory, t_s: f64, point_m: [f64; 2]) -> [[f64; 2]; 2] {
    let p = m.params();
    let g = bistatic_range_gradient(p, traj.position_at(t_s), point_m);
    let half = 0.5 * p.integration_time_s;
    let g0 = bistatic_range_gradient(p, traj.position_at(t_s - half), point_m);
    let g1 = bistatic_range_gradient(p, traj.position_at(t_s + half), point_m);
    let kb = p.bandwidth_hz / SPEED_OF_LIGHT_MPS;
    let kl = 1.0 / p.wavelength_m;
    [
        [kb * g[0], kb * g[1]],
        [kl * (g1[0] - g0[0]), kl * (g1[1] - g0[1])],
    ]
}

/// The unit major axis of the cell at `point_m` seen at time `t_s` along `traj`.
fn major_axis(m: &Mission, traj: &Trajectory, t_s: f64, point_m: [f64; 2]) -> [f64; 2] {
    let [a, b] = gradients(m, traj, t_s, point_m);
    let (na, nb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
    cell_ellipse_major_direction(unit(a), 1.0 / na, unit(b), 1.0 / nb)
}

/// The times of the looks' centres of `ap`.
fn look_times(ap: &Aperture) -> Vec<f64> {
    (0..ap.looks)
        .map(|l| ap.t_start_s + (l as f64 + 0.5) * ap.look_s)
        .collect()
}

/// The noise-free look images of aperture `ap` along `traj` of each object of the pair alone
/// (echoes only: the chain is linear), scaled so that the sum of the looks' |I|² is the
/// multi-look image normalised to the noise, with their grid.
fn look_images(
    m: &Mission,
    traj: &Trajectory,
    scene: &SceneFile,
    ap: &Aperture,
    objects: &[SceneObject],
) -> (Grid, Vec<Vec<Vec<Complex32>>>) {
    let setup = RadarSetup::new(m.params(), scene).unwrap();
    let track = PlannedTrack::new(traj.clone(), m.params().altitude_m);
    let pulses = setup.pulses(&track, ap);
    let proc = Processor::new(setup.clone()).unwrap();
    let grid = setup.grid(ap);
    let ppl = ap.pulses_per_look;
    let scale = (1.0 / (proc.look_noise_var(ppl) * ap.looks as f64)).sqrt() as f32;
    let comps = Components {
        direct: false,
        echoes: true,
        noise: false,
    };
    let looks = objects
        .iter()
        .map(|o| {
            let iq = setup
                .synthesizer(vec![*o])
                .unwrap()
                .synthesize_frame(&pulses, comps)
                .unwrap();
            let c = proc
                .compress(&grid, &pulses, &iq, ppl, None, false)
                .unwrap();
            (0..ap.looks)
                .map(|l| {
                    let mut img = proc.image_look(&grid, &c, l * ppl..(l + 1) * ppl).unwrap();
                    img.iter_mut().for_each(|x| *x *= scale);
                    img
                })
                .collect()
        })
        .collect();
    (grid, looks)
}

/// The multi-look image of the pair in quadrature and equally bright: object 2's look images
/// rotated, look by look, so that at the pixel nearest `mid_m` its phase leads object 1's by
/// π/2, and scaled so that its multi-look image at its own position equals object 1's at its
/// own (the antenna pattern and the ranges make two equal objects differ by up to 1 dB).
fn quadrature_image(
    grid: &Grid,
    looks: &[Vec<Vec<Complex32>>],
    objects: &[SceneObject],
    mid_m: [f64; 2],
) -> Vec<f32> {
    let (cx, cy) = grid.index_of(mid_m);
    let k = cy.round() as usize * grid.nx + cx.round() as usize;
    let brightness = |i: usize| {
        let img: Vec<f32> = (0..grid.pixels())
            .map(|j| looks[i].iter().map(|l| l[j].norm_sqr()).sum())
            .collect();
        sample(grid, &img, objects[i].pos_m())
    };
    let gain = (brightness(0) / brightness(1)).sqrt() as f32;
    let mut out = vec![0f32; grid.pixels()];
    for (a, b) in looks[0].iter().zip(&looks[1]) {
        let rot = Complex32::i() * (a[k] / a[k].norm()) * (b[k] / b[k].norm()).conj() * gain;
        for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
            *o += (x + rot * y).norm_sqr();
        }
    }
    out
}

/// The image sampled at `p_m` (bilinear in intensity).
fn sample(grid: &Grid, img: &[f32], p_m: [f64; 2]) -> f64 {
    let (fx, fy) = grid.index_of(p_m);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (x0, y0) = (x0 as usize, y0 as usize);
    let at = |x: usize, y: usize| f64::from(img[y * grid.nx + x]);
    (1.0 - ty) * ((1.0 - tx) * at(x0, y0) + tx * at(x0 + 1, y0))
        + ty * ((1.0 - tx) * at(x0, y0 + 1) + tx * at(x0 + 1, y0 + 1))
}

/// What a profile through the pair shows (positions u along the line, 0 at the midpoint, the
/// objects at ±s/2).
#[derive(Debug, Clone, Copy)]
struct Dip {
    /// Positions of the profile's maxima on either side of the midpoint, m.
    maxima_m: [f64; 2],
    /// 10 lg(lower of the two maxima / lowest value between them), dB: 0 for a single peak.
    between_maxima_db: f64,
    /// 10 lg(mean value at the objects / value at the midpoint), dB: > 0 where the midpoint is
    /// darker than the objects (for a quadrature pair, 2 P(s/2) < P(0) + P(s): where the
    /// spacing exceeds the response's −3 dB chord).
    objects_over_midpoint_db: f64,
}

/// The dips of the profile `f` over u ∈ [−s, s] (s/400 steps).
fn dip(f: impl Fn(f64) -> f64, s_m: f64) -> Dip {
    let step = s_m / 400.0;
    let n = (s_m / step).round() as i64;
    let us: Vec<f64> = (-n..=n).map(|i| i as f64 * step).collect();
    let v: Vec<f64> = us.iter().map(|&u| f(u)).collect();
    let argmax = |r: std::ops::Range<usize>| {
        r.max_by(|&i, &j| v[i].total_cmp(&v[j]))
            .expect("empty half")
    };
    let mid = n as usize;
    let (l, r) = (argmax(0..mid + 1), argmax(mid..v.len()));
    let lowest = v[l..=r].iter().copied().fold(f64::INFINITY, f64::min);
    Dip {
        maxima_m: [us[l], us[r]],
        between_maxima_db: 10.0 * (v[l].min(v[r]) / lowest).log10(),
        objects_over_midpoint_db: 10.0 * (0.5 * (f(-0.5 * s_m) + f(0.5 * s_m)) / f(0.0)).log10(),
    }
}

/// sinc²(x) = (sin πx / πx)².
fn sinc2(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0
    } else {
        ((PI * x).sin() / (PI * x)).powi(2)
    }
}

/// The unweighted response model's profile of the pair, equally bright and in quadrature: for
/// each object the sum over the looks of w sinc²(α u) sinc²(β u), α and β the range and
/// Doppler spatial frequencies along e at the object ([`gradients`]), w the share of
/// the look in the object's multi-look brightness (`look_weights`, measured: the antenna
/// pattern and the ranges make the looks differ by up to a factor 4).
fn model_dip(
    m: &Mission,
    traj: &Trajectory,
    ap: &Aperture,
    objects: &[SceneObject],
    look_weights: &[Vec<f64>],
    e: [f64; 2],
) -> Dip {
    let ts = look_times(ap);
    let mid_m = [
        0.5 * (objects[0].x_m + objects[1].x_m),
        0.5 * (objects[0].y_m + objects[1].y_m),
    ];
    // per object and look: [position along e, weight, α, β]
    let terms: Vec<[f64; 4]> = objects
        .iter()
        .zip(look_weights)
        .flat_map(|(o, w)| {
            let u0 = dot([o.x_m - mid_m[0], o.y_m - mid_m[1]], e);
            let total: f64 = w.iter().sum();
            ts.iter().zip(w).map(move |(&t, &wl)| {
                let [a, b] = gradients(m, traj, t, o.pos_m());
                [u0, wl / total, dot(a, e), dot(b, e)]
            })
        })
        .collect();
    let resp = |u: f64| -> f64 {
        terms
            .iter()
            .map(|[u0, w, a, b]| w * sinc2(a * (u - u0)) * sinc2(b * (u - u0)))
            .sum()
    };
    dip(resp, m.params().d_min_m)
}

/// Each object's look intensities at its own position in its look images.
fn look_weights(
    grid: &Grid,
    looks: &[Vec<Vec<Complex32>>],
    objects: &[SceneObject],
) -> Vec<Vec<f64>> {
    looks
        .iter()
        .zip(objects)
        .map(|(ls, o)| {
            ls.iter()
                .map(|l| {
                    let img: Vec<f32> = l.iter().map(|x| x.norm_sqr()).collect();
                    sample(grid, &img, o.pos_m())
                })
                .collect()
        })
        .collect()
}

#[test]
fn pair_along_the_major_axis_merges_along_the_old_best_effort_and_separates_along_todays() {
    let m = Mission::from_path(&root().join("missions/default-30m.toml")).unwrap();
    let p = m.params();
    let d_min = p.d_min_m;
    let old = Trajectory::from_csv_path(
        &root().join("radar-sim/tests/data/old-best-effort/trajectory.csv"),
        p.slot_s,
        m.slots(),
        p.start_m,
        p.altitude_m,
    )
    .unwrap();
    let old_ev = evaluate(&m, &old);
    assert!(old_ev.violations.p2_ok(1e-6), "{:?}", old_ev.violations);
    let old_cells = window_cells(&m, &old, &old_ev);
    // windows where the old metric held the cell within 0.95 d_min and today's says more
    let qualifying: Vec<&WindowCell> = old_cells
        .iter()
        .filter(|w| w.max_side_m <= OLD_SIDE_BOUND_REL * d_min && w.median_ellipse_m > d_min)
        .collect();
    println!("old best effort, windows with every side ≤ 0.95 d_min and the ellipse > d_min:");
    for w in &qualifying {
        println!(
            "  landmark {:2}: largest side {:.2} m, ellipse median {:.2} m, largest {:.2} m",
            w.landmark, w.max_side_m, w.median_ellipse_m, w.max_ellipse_m
        );
    }
    assert!(qualifying.len() >= 3, "{qualifying:?}");
    let w_old = *qualifying
        .iter()
        .max_by(|a, b| a.median_ellipse_m.total_cmp(&b.median_ellipse_m))
        .unwrap();
    assert!(w_old.median_ellipse_m > 1.04 * d_min, "{w_old:?}");

    // today's best effort (the default options: exact, general resolution, vehicle limits)
    let new = planner::plan(&m, &planner::PlanOptions::default()).unwrap();
    assert!(new.best_effort.is_some(), "not a best-effort plan");
    assert!(
        new.evaluation.is_feasible(),
        "today's best effort infeasible"
    );
    let new_cells = window_cells(&m, &new.trajectory, &new.evaluation);
    let w_new = &new_cells[w_old.landmark];
    println!("today's best effort, same window: {w_new:?}");
    assert!(
        w_new.max_ellipse_m <= OLD_SIDE_BOUND_REL * d_min,
        "{w_new:?}"
    );

    // the pair: d_min apart along the old plan's major axis at the landmark, mid-aperture
    let mut scene =
        pair::linear(SceneFile::from_path(&root().join("radar-sim/scenes/default.toml")).unwrap());
    scene.processing.range_weighting = Weighting::None;
    scene.processing.azimuth_weighting = Weighting::None;
    let aps = RadarSetup::new(p, &scene).unwrap().apertures(&m).unwrap();
    let ai = aps
        .iter()
        .position(|a| a.landmark == Some(w_old.landmark))
        .expect("no aperture of that landmark");
    let ap = &aps[ai];
    let landmark_m = m.schedule().landmarks[w_old.landmark].pos_m();
    let e = major_axis(&m, &old, 0.5 * (ap.t_start_s + ap.t_end_s), landmark_m);
    let objects = pair::pair_along(landmark_m, e, d_min);
    println!(
        "landmark {} at {landmark_m:?}, aperture {ai} ({}–{} s, {} looks), pair along {:.1}°",
        w_old.landmark,
        ap.t_start_s,
        ap.t_end_s,
        ap.looks,
        e[1].atan2(e[0]).to_degrees()
    );
    for t in look_times(ap) {
        let cell = |tr: &Trajectory| {
            ResolutionCell::new(p, tr.position_at(t), tr.velocity_at(t), landmark_m)
        };
        let (o, n) = (cell(&old), cell(&new.trajectory));
        println!(
            "  look at {t:.1} s: old ellipse {:.2} m (sides {:.2}, {:.2} m), today's {:.2} m",
            o.worst_width_m, o.cross_track_width_m, o.iso_range_width_m, n.worst_width_m
        );
    }

    let mut dips = Vec::new();
    for (name, traj) in [("old", &old), ("today's", &new.trajectory)] {
        let (grid, looks) = look_images(&m, traj, &scene, ap, &objects);
        let img = quadrature_image(&grid, &looks, &objects, landmark_m);
        let along = |u: f64| {
            let q = [landmark_m[0] + u * e[0], landmark_m[1] + u * e[1]];
            sample(&grid, &img, q)
        };
        let measured = dip(along, d_min);
        let weights = look_weights(&grid, &looks, &objects);
        let model = model_dip(&m, traj, ap, &objects, &weights, e);
        println!("{name}: measured {measured:?}\n  model {model:?}");
        assert!(
            (measured.between_maxima_db - model.between_maxima_db).abs() <= MODEL_TOLERANCE_DB,
            "{name}: measured {measured:?}, model {model:?}"
        );
        let (per_phase, random) = pair::pair_detections(&m, traj, &scene, ai, &objects);
        println!(
            "  detections near the pair, objects matched: random phases {random:?}, relative \
             phases k·π/4 {per_phase:?}"
        );
        dips.push((measured, random));
    }
    let ((old_dip, old_det), (new_dip, new_det)) = (dips[0], dips[1]);
    let x_db = rayleigh_dip_db();
    // the old plan: a dip shallower than Rayleigh's (the pair not resolved in the planner's
    // sense), and the detector reports one object
    assert!(old_dip.between_maxima_db < x_db - 0.1, "{old_dip:?}");
    assert_eq!(old_det.0, 1, "old plan, random phases: {old_det:?}");
    // today's: two maxima near the objects with more than Rayleigh's dip between them, and
    // both objects detected
    assert!(new_dip.between_maxima_db > x_db + 0.1, "{new_dip:?}");
    for (u, s) in new_dip.maxima_m.iter().zip([-0.5, 0.5]) {
        assert!((u - s * d_min).abs() < 0.1 * d_min, "{new_dip:?}");
    }
    assert_eq!(new_det, (2, 2), "today's plan, random phases: {new_det:?}");
    // by the −3 dB chord (0.886 of the ellipse, 18.6 m along the old plan here) the midpoint is
    // darker than the objects along both: the old plan's cell exceeds d_min by less than the
    // unweighted main lobe's 1/0.886
    assert!(
        old_dip.objects_over_midpoint_db > 0.0 && w_old.median_ellipse_m * 0.886 < d_min,
        "{old_dip:?}"
    );
}

#[test]
fn quadrature_sinc_pairs_show_rayleighs_dip_at_the_rayleigh_distance_and_none_closer() {
    // responses of width 1 (peak to first null): the −3 dB chord is 0.886
    let pair = |s: f64| dip(|u| sinc2(u - 0.5 * s) + sinc2(u + 0.5 * s), s);
    let at_rayleigh = pair(1.0);
    assert!(
        (at_rayleigh.between_maxima_db - rayleigh_dip_db()).abs() < 1e-3,
        "{at_rayleigh:?}"
    );
    assert!((rayleigh_dip_db() - 0.9121).abs() < 1e-4);
    assert!(
        (at_rayleigh.maxima_m[1] - 0.5).abs() < 0.01,
        "{at_rayleigh:?}"
    );
    // at the −3 dB chord the midpoint is as bright as the objects (2 P(s/2) = P(0), P(s) small)
    let at_3db = pair(0.8859);
    assert!(at_3db.objects_over_midpoint_db.abs() < 0.1, "{at_3db:?}");
    // closer: one maximum
    let close = pair(0.7);
    assert!(close.between_maxima_db < 1e-9, "{close:?}");
    // the dip grows with the spacing
    assert!(pair(1.1).between_maxima_db > at_rayleigh.between_maxima_db + 0.3);
}
