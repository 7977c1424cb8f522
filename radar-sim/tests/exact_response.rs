//! The exact point response of the look images (`cfar::ExactResponse`) against backprojected
//! images of simulated points, and the sidelobe editing against it (`cfar::cluster_edited`):
//! several objects' sidelobes adding up above the CFAR threshold are edited, a weak object in a
//! strong one's sidelobes is still detected.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use radar_sim::backproject::Grid;
use radar_sim::config::{CancellerKind, SceneFile, Weighting};
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::scene::SceneObject;
use radar_sim::synth::Components;
use radar_sim::track::{Aperture, PulseMeta};
use rustfft::num_complex::Complex32;

/// The default scene with Hann tapers, no direct path and no canceller (a linear chain), with
/// or without thermal noise.
fn scene(noise: bool) -> SceneFile {
    let mut s = SceneFile::default();
    s.radar.direct_path = false;
    s.radar.thermal_noise = noise;
    s.processing.canceller = CancellerKind::None;
    s.processing.range_weighting = Weighting::Hann;
    s.processing.azimuth_weighting = Weighting::Hann;
    s
}

/// Two looks of a straight track heading south at 20 m/s whose sensing centre passes the
/// origin mid-aperture: the setup, the processor, the aperture and its pulses.
fn geometry(scene: &SceneFile) -> (RadarSetup, Processor, Aperture, Vec<PulseMeta>) {
    geometry_heading(scene, 180.0)
}

/// [`geometry`] heading `heading_deg` (94°: within a few degrees of blind at the origin).
fn geometry_heading(
    scene: &SceneFile,
    heading_deg: f64,
) -> (RadarSetup, Processor, Aperture, Vec<PulseMeta>) {
    let params = planner::Params::default();
    let setup = RadarSetup::new(&params, scene).unwrap();
    let proc = Processor::new(setup.clone()).unwrap();
    let ap = common::aperture(&setup, [0.0, 0.0], 0.0, 2);
    let track = common::track_through(&params, [0.0, 0.0], heading_deg, 20.0, setup.look_s);
    let pulses = common::pulses(&setup, &track, &ap);
    (setup, proc, ap, pulses)
}

/// The complex look images of `objects` on `grid`.
fn look_images(
    setup: &RadarSetup,
    proc: &Processor,
    ap: &Aperture,
    pulses: &[PulseMeta],
    grid: &Grid,
    objects: Vec<SceneObject>,
) -> (Vec<Vec<Complex32>>, radar_sim::pipeline::Compressed) {
    let iq = setup
        .synthesizer(objects)
        .unwrap()
        .synthesize_frame(pulses, Components::ALL)
        .unwrap();
    let ppl = ap.pulses_per_look;
    let c = proc.compress(grid, pulses, &iq, ppl, None, false).unwrap();
    let looks = (0..ap.looks)
        .map(|l| proc.image_look(grid, &c, l * ppl..(l + 1) * ppl).unwrap())
        .collect();
    (looks, c)
}

/// The image of a point, pixel by pixel, is its value at the point times the exact response:
/// the backprojection interpolates the range profiles linearly between samples 1/U apart, an
/// error of at most `(1/U)²/8 · max|h''| ≤ (π N_sc / (N U))² / 8` of the peak per pulse
/// (0.72 % at the default 2 500 of 4 096 subcarriers, U = 8), and computes the carrier phase in
/// single precision (~1e-4 rad): the tolerance is their sum.
#[test]
fn exact_response_matches_a_backprojected_point() {
    // heading south, and within a few degrees of blind (the cell tens of metres long)
    for heading_deg in [180.0, 94.0] {
        matches_backprojection(heading_deg);
    }
}

fn matches_backprojection(heading_deg: f64) {
    let sc = scene(false);
    let (setup, proc, ap, pulses) = geometry_heading(&sc, heading_deg);
    let grid = Grid::square([0.0, 0.0], 30.0, 0.4);
    let q = [0.0, 0.0];
    let (looks, c) = look_images(
        &setup,
        &proc,
        &ap,
        &pulses,
        &grid,
        vec![common::object(0, q, 10.0)],
    );
    let exact = proc.exact_response(&c, &ap);
    let gains = proc.pulse_gains(&pulses, q);
    let num = &setup.num;
    let u = sc.processing.upsample as f64;
    let interp =
        (std::f64::consts::PI * num.subcarriers as f64 / (num.fft_size as f64 * u)).powi(2) / 8.0;
    let tol = interp + 1e-3;
    let centre = (grid.ny / 2) * grid.nx + grid.nx / 2;
    let mut worst: f64 = 0.0;
    let mut far: f64 = 0.0;
    for (l, img) in looks.iter().enumerate() {
        let a = img[centre];
        let a = rustfft::num_complex::Complex64::new(a.re.into(), a.im.into());
        assert!(a.norm() > 0.0);
        for iy in (0..grid.ny).step_by(3) {
            for ix in (0..grid.nx).step_by(3) {
                let p = [grid.x(ix), grid.y(iy)];
                let v = img[iy * grid.nx + ix];
                let v = rustfft::num_complex::Complex64::new(v.re.into(), v.im.into());
                let pred = a * exact.response(l, p, q, &gains);
                let err = (v - pred).norm() / a.norm();
                worst = worst.max(err);
                if p[0].hypot(p[1]) > 15.0 {
                    far = far.max(v.norm() / a.norm());
                }
            }
        }
    }
    println!(
        "heading {heading_deg}°: exact response against the backprojected image: worst error \
         {worst:.2e} of the peak (tolerance {tol:.2e}); the response beyond 15 m reaches \
         {far:.2e}"
    );
    assert!(worst <= tol, "{worst} > {tol}");
    // the test compares sidelobes, not only the main lobe
    assert!(far > 2.0 * tol, "{far}");
}

/// Look images of point objects (`(position, multilook SNR, phase)`) made from the exact
/// response itself plus complex Gaussian noise of unit multilook mean, on the aperture's grid:
/// (the complex looks, the multilook image, the scale multilook / Σ|I|²).
fn model_images(
    proc: &Processor,
    exact: &radar_sim::cfar::ExactResponse,
    pulses: &[PulseMeta],
    grid: &Grid,
    objects: &[([f64; 2], f64, f64)],
    seed: u64,
) -> (Vec<Vec<Complex32>>, Vec<f32>, f64) {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use rustfft::num_complex::Complex64;
    let looks = exact.looks();
    // unit noise variance per look: the multilook image is Σ_l |I_l|² / looks
    let scale = 1.0 / looks as f64;
    let gains: Vec<Vec<f64>> = objects
        .iter()
        .map(|(q, _, _)| proc.pulse_gains(pulses, *q))
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, std::f64::consts::FRAC_1_SQRT_2).unwrap();
    let mut images = vec![vec![Complex32::new(0.0, 0.0); grid.pixels()]; looks];
    for (l, img) in images.iter_mut().enumerate() {
        for (i, v) in img.iter_mut().enumerate() {
            let p = [grid.x(i % grid.nx), grid.y(i / grid.nx)];
            let mut acc = Complex64::new(normal.sample(&mut rng), normal.sample(&mut rng));
            for ((q, snr, phase), g) in objects.iter().zip(&gains) {
                acc += Complex64::from_polar(snr.sqrt(), *phase) * exact.response(l, p, *q, g);
            }
            *v = Complex32::new(acc.re as f32, acc.im as f32);
        }
    }
    let multilook = (0..grid.pixels())
        .map(|i| (images.iter().map(|im| im[i].norm_sqr() as f64).sum::<f64>() * scale) as f32)
        .collect();
    (images, multilook, scale)
}

/// Detections of the model images of `objects` with the exact sidelobe editing, and the
/// exceedance peaks without any editing (the CFAR's local maxima, non-maximum suppression
/// only).
fn detections(
    objects: &[([f64; 2], f64, f64)],
) -> (
    Vec<radar_sim::cfar::Detection>,
    Vec<radar_sim::cfar::Detection>,
) {
    let sc = scene(true);
    let (setup, proc, ap, pulses) = geometry(&sc);
    let grid = setup.grid(&ap);
    let iq = setup
        .synthesizer(Vec::new())
        .unwrap()
        .synthesize_frame(
            &pulses,
            Components {
                direct: false,
                echoes: false,
                noise: false,
            },
        )
        .unwrap();
    let c = proc
        .compress(&grid, &pulses, &iq, ap.pulses_per_look, None, false)
        .unwrap();
    let exact = proc.exact_response(&c, &ap);
    let (looks, multilook, scale) = model_images(&proc, &exact, &pulses, &grid, objects, 3);
    let gains = |q: [f64; 2]| proc.pulse_gains(&pulses, q);
    let det = proc
        .detect_edited(
            &ap,
            &pulses,
            &multilook,
            None,
            Some(radar_sim::cfar::LookImages {
                response: &exact,
                grid: &looks,
                band_grid: None,
                band: &[],
                scale,
                gains: &gains,
                ghosts: None,
            }),
        )
        .unwrap();
    let radius = planner::Params::default().d_min_m / 2.0;
    let plain = radar_sim::cfar::cluster(&multilook, &det.map, &grid, radius, 0, None);
    (det.detections, plain)
}

fn near(d: &[radar_sim::cfar::Detection], p: [f64; 2]) -> bool {
    d.iter().any(|x| (x.x_m - p[0]).hypot(x.y_m - p[1]) < 1.0)
}

/// Two 60 dB objects 13 m apart: their sidelobes, adding up, exceed the CFAR threshold far from
/// both (peaks without editing), yet the detections are exactly the two objects.
#[test]
fn two_objects_summed_sidelobes_give_two_detections() {
    let (a, b) = ([0.0, 0.0], [12.0, 5.0]);
    let (edited, plain) = detections(&[(a, 1e6, 0.0), (b, 1e6, 1.3)]);
    println!(
        "two objects: {} detections edited, {} peaks unedited",
        edited.len(),
        plain.len()
    );
    assert!(plain.len() > 2, "no sidelobe peaks to edit: {plain:?}");
    assert!(near(&edited, a) && near(&edited, b), "{edited:?}");
    assert_eq!(edited.len(), 2, "{edited:?}");
}

/// A weak object at the strongest sidelobe peak of the two 60 dB objects (without editing a
/// detection), 10 dB above their summed response there: its residual is its own response, so
/// it is detected beside them.
#[test]
fn a_weak_object_in_strong_sidelobes_is_detected() {
    let (a, b) = ([0.0, 0.0], [12.0, 5.0]);
    let (_, plain) = detections(&[(a, 1e6, 0.0), (b, 1e6, 1.3)]);
    let far = |p: [f64; 2]| {
        (p[0] - a[0]).hypot(p[1] - a[1]) > 5.0 && (p[0] - b[0]).hypot(p[1] - b[1]) > 5.0
    };
    let side = plain
        .iter()
        .filter(|d| far([d.x_m, d.y_m]))
        .max_by(|x, y| x.snr_db.total_cmp(&y.snr_db))
        .expect("a sidelobe peak");
    let w = [side.x_m, side.y_m];
    let sc = scene(false);
    let (setup, proc, ap, pulses) = geometry(&sc);
    let grid = setup.grid(&ap);
    let iq = setup
        .synthesizer(Vec::new())
        .unwrap()
        .synthesize_frame(
            &pulses,
            Components {
                direct: false,
                echoes: false,
                noise: false,
            },
        )
        .unwrap();
    let c = proc
        .compress(&grid, &pulses, &iq, ap.pulses_per_look, None, false)
        .unwrap();
    let exact = proc.exact_response(&c, &ap);
    // the strong pair's summed response at the weak object, multilook units
    let (ga, gb) = (proc.pulse_gains(&pulses, a), proc.pulse_gains(&pulses, b));
    let summed: f64 = (0..exact.looks())
        .map(|l| {
            (exact.response(l, w, a, &ga) * 1e3
                + exact.response(l, w, b, &gb)
                    * rustfft::num_complex::Complex64::from_polar(1e3, 1.3))
            .norm_sqr()
        })
        .sum::<f64>()
        / exact.looks() as f64;
    let weak = 10.0 * summed;
    println!(
        "weak object at ({:.1}, {:.1}): {:.1} dB, the pair's summed response {:.1} dB there",
        w[0],
        w[1],
        10.0 * weak.log10(),
        10.0 * summed.log10()
    );
    assert!(summed > 10.0, "not in the pair's sidelobes: {summed}");
    let (edited, _) = detections(&[(a, 1e6, 0.0), (b, 1e6, 1.3), (w, weak, 0.4)]);
    assert!(near(&edited, w), "the weak object was edited: {edited:?}");
    assert_eq!(edited.len(), 3, "{edited:?}");
}
