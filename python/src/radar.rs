//! `cellsar.radar`: `simulate` a plan's recording (IQ per aperture, complex64 arrays) and
//! `process` it into images, detections and metrics, in memory, with the `radar-sim` library's
//! streaming API (the same steps as `cellsar-radar-sim simulate` and `process`, without files).

use numpy::ndarray::Array2;
use numpy::{Complex32, IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use radar_sim::clutter::GroundClutter;
use radar_sim::config::SceneFile;
use radar_sim::limits::{IqBudget, IqLimits};
use radar_sim::pipeline::{synthesize_frames, Processor, RadarSetup};
use radar_sim::run::{planned_track, Metrics};
use radar_sim::scene::SceneObject;
use radar_sim::synth::Components;
use radar_sim::tally::{self, ApertureTally};
use radar_sim::track::{Aperture, PulseMeta};

use crate::errors::{panic_error, RadarError};
use crate::json;
use crate::mission::PyMission;
use crate::plan::PyPlan;

/// Pulses per synthesised frame (the frames are concatenated into one array per aperture).
const FRAME_PULSES: usize = 64;

fn radar_err(e: &radar_sim::RadarError) -> PyErr {
    RadarError::new_err(cellsar_error::error_chain(e))
}

/// A scene: `None` (the defaults), a path to a scene file (TOML), or a dict with its structure.
fn scene_from(scene: Option<&Bound<'_, PyAny>>) -> PyResult<SceneFile> {
    let Some(scene) = scene.filter(|s| !s.is_none()) else {
        return Ok(SceneFile::default());
    };
    if scene.is_instance_of::<PyDict>() {
        let text =
            json::dumps(scene).map_err(|e| RadarError::new_err(format!("scene dict: {e}")))?;
        let file: SceneFile =
            json::from_text(&text).map_err(|e| RadarError::new_err(format!("scene dict: {e}")))?;
        file.validate().map_err(|e| radar_err(&e))?;
        return Ok(file);
    }
    let path: std::path::PathBuf = scene
        .extract()
        .map_err(|_| RadarError::new_err("scene: expected None, a scene file path or a dict"))?;
    SceneFile::from_path(&path).map_err(|e| radar_err(&e))
}

/// What `simulate` computes, before it becomes Python objects.
struct Simulated {
    setup: RadarSetup,
    apertures: Vec<Aperture>,
    pulses: Vec<Vec<PulseMeta>>,
    iq: Vec<Vec<Complex32>>,
    objects: Vec<SceneObject>,
    samples_per_pulse: usize,
    noise_power_w: f64,
}

fn simulate_in_memory(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    altitudes_m: Option<&[f64]>,
    scene: &SceneFile,
) -> radar_sim::Result<Simulated> {
    let setup = RadarSetup::new(mission.params(), scene)?;
    let apertures = setup.apertures(mission)?;
    IqBudget::new(&setup, &apertures).check(&setup, &IqLimits::default())?;
    let objects = setup.objects(mission)?;
    // a free mission's plan is flown at its altitude per slot, a fixed one at `altitude_m`
    let track = planned_track(mission, traj, altitudes_m)?;
    let synth = setup.synthesizer(objects.clone())?;
    // ground clutter (`[clutter]`): synthesised with the objects, as `cellsar-radar-sim simulate`
    let clutter = GroundClutter::for_run(&setup, &track, &apertures)?;
    let spp = synth.samples_per_pulse();
    let mut pulses = Vec::with_capacity(apertures.len());
    let mut iq = Vec::with_capacity(apertures.len());
    for ap in &apertures {
        let ps = setup.pulses(&track, ap);
        let cluttered = match &clutter {
            Some(c) => Some(c.synthesizer(&setup, &objects, ap, &ps)?),
            None => None,
        };
        let mut samples = Vec::with_capacity(ps.len() * spp);
        synthesize_frames(
            cluttered.as_ref().unwrap_or(&synth),
            &ps,
            FRAME_PULSES,
            Components::ALL,
            &mut |_, frame| {
                samples.extend_from_slice(frame);
                Ok(())
            },
        )?;
        pulses.push(ps);
        iq.push(samples);
    }
    Ok(Simulated {
        noise_power_w: synth.noise_power_w(),
        setup,
        apertures,
        pulses,
        iq,
        objects,
        samples_per_pulse: spp,
    })
}

/// A simulated recording: per aperture its IQ (`pulses × samples` complex64, the layout of the
/// CLI's `iq/aperture_NNN.npy`), its pulses and the scene's objects.
#[pyclass(frozen, name = "Recording", module = "cellsar.radar")]
pub struct PyRecording {
    mission: PyMission,
    setup: RadarSetup,
    apertures: Vec<Aperture>,
    pulses: Vec<Vec<PulseMeta>>,
    iq: Vec<Py<PyArray2<Complex32>>>,
    objects: Vec<SceneObject>,
    samples_per_pulse: usize,
    noise_power_w: f64,
}

/// `numpy.rec.fromarrays(columns, names=...)`: a structured array.
fn structured<'py>(
    py: Python<'py>,
    names: &[&str],
    columns: Vec<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let kwargs = PyDict::new(py);
    kwargs.set_item("names", names.join(","))?;
    py.import("numpy")?.getattr("rec")?.call_method(
        "fromarrays",
        (PyList::new(py, columns)?,),
        Some(&kwargs),
    )
}

fn f64_col<'py, T>(py: Python<'py>, rows: &[T], f: impl Fn(&T) -> f64) -> Bound<'py, PyAny> {
    PyArray1::from_vec(py, rows.iter().map(f).collect()).into_any()
}

fn i64_col<'py, T>(py: Python<'py>, rows: &[T], f: impl Fn(&T) -> i64) -> Bound<'py, PyAny> {
    PyArray1::from_vec(py, rows.iter().map(f).collect()).into_any()
}

fn index(i: usize) -> i64 {
    i64::try_from(i).unwrap_or(i64::MAX)
}

#[pymethods]
impl PyRecording {
    /// The mission flown.
    #[getter]
    fn mission(&self) -> PyMission {
        self.mission.clone()
    }

    /// IQ per aperture: a list of `pulses × samples` complex64 arrays (owned by the recording,
    /// not copies).
    #[getter]
    fn iq<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.iq.iter().map(|a| a.bind(py)))
    }

    /// The apertures: a list of dicts (index, landmark, centre_m, t_start_s, t_end_s, looks, ...).
    #[getter]
    fn apertures<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_py(py, &self.apertures)
    }

    /// The scene's objects (the truth): a structured array (id, x_m, y_m, rcs_m2, landmark;
    /// landmark -1 for none).
    #[getter]
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let o = &self.objects;
        structured(
            py,
            &["id", "x_m", "y_m", "rcs_m2", "landmark"],
            vec![
                i64_col(py, o, |o| index(o.id)),
                f64_col(py, o, |o| o.x_m),
                f64_col(py, o, |o| o.y_m),
                f64_col(py, o, |o| o.rcs_m2),
                i64_col(py, o, |o| o.landmark.map_or(-1, index)),
            ],
        )
    }

    /// Every pulse of every aperture, in recording order (the CLI's `pulses.csv`): a structured
    /// array (aperture, look, t_s, x_m, y_m, z_m, vx_mps, vy_mps, vz_mps, window_delay_samples)
    /// of the UAV's navigated position and velocity at each pulse.
    #[getter]
    fn pulses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p: Vec<&PulseMeta> = self.pulses.iter().flatten().collect();
        structured(
            py,
            &[
                "aperture",
                "look",
                "t_s",
                "x_m",
                "y_m",
                "z_m",
                "vx_mps",
                "vy_mps",
                "vz_mps",
                "window_delay_samples",
            ],
            vec![
                i64_col(py, &p, |p| index(p.aperture)),
                i64_col(py, &p, |p| index(p.look)),
                f64_col(py, &p, |p| p.t_s),
                f64_col(py, &p, |p| p.pos_m[0]),
                f64_col(py, &p, |p| p.pos_m[1]),
                f64_col(py, &p, |p| p.pos_m[2]),
                f64_col(py, &p, |p| p.vel_mps[0]),
                f64_col(py, &p, |p| p.vel_mps[1]),
                f64_col(py, &p, |p| p.vel_mps[2]),
                i64_col(py, &p, |p| p.window_delay_samples),
            ],
        )
    }

    /// Samples per pulse.
    #[getter]
    fn samples_per_pulse(&self) -> usize {
        self.samples_per_pulse
    }

    /// Thermal noise power per sample, W.
    #[getter]
    fn noise_power_w(&self) -> f64 {
        self.noise_power_w
    }

    fn __repr__(&self) -> String {
        format!(
            "Recording(mission={:?}, apertures={}, samples_per_pulse={})",
            self.mission.inner.name(),
            self.apertures.len(),
            self.samples_per_pulse
        )
    }
}

/// Simulates what the UAV records flying `plan` over `scene` (None: the default scene; a
/// scene file path; or a dict with its structure). Runs with the GIL released.
#[pyfunction]
#[pyo3(signature = (mission, plan, scene = None))]
pub fn simulate(
    py: Python<'_>,
    mission: PyRef<'_, PyMission>,
    plan: PyRef<'_, PyPlan>,
    scene: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyRecording> {
    let scene = scene_from(scene)?;
    let m = mission.clone();
    let result = plan.result.clone();
    if *plan.mission.inner != *m.inner {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "simulate: the plan was made for another mission",
        ));
    }
    let sim = py
        .detach(|| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                simulate_in_memory(
                    &m.inner,
                    &result.trajectory,
                    result.altitudes_m.as_deref(),
                    &scene,
                )
            }))
        })
        .map_err(|p| panic_error("the radar simulator", p.as_ref()))?
        .map_err(|e| radar_err(&e))?;
    let mut iq = Vec::with_capacity(sim.iq.len());
    for (samples, ps) in sim.iq.into_iter().zip(&sim.pulses) {
        let array = Array2::from_shape_vec((ps.len(), sim.samples_per_pulse), samples)
            .map_err(|e| RadarError::new_err(format!("IQ shape: {e}")))?;
        iq.push(array.into_pyarray(py).unbind());
    }
    Ok(PyRecording {
        mission: m,
        setup: sim.setup,
        apertures: sim.apertures,
        pulses: sim.pulses,
        iq,
        objects: sim.objects,
        samples_per_pulse: sim.samples_per_pulse,
        noise_power_w: sim.noise_power_w,
    })
}

/// One processed aperture's image and its grid.
struct Image {
    grid: radar_sim::backproject::Grid,
    multilook: Vec<f32>,
}

fn process_in_memory(
    rec: &PyRecording,
    setup: RadarSetup,
    iq: &[&[Complex32]],
) -> radar_sim::Result<(Vec<Image>, Vec<ApertureTally>, Metrics)> {
    let proc = Processor::new(setup)?;
    let mut images = Vec::with_capacity(rec.apertures.len());
    let mut tallies = Vec::with_capacity(rec.apertures.len());
    for ((ap, pulses), samples) in rec.apertures.iter().zip(&rec.pulses).zip(iq) {
        let r = proc.process_aperture(ap, pulses, samples, &rec.objects)?;
        tallies.push(ApertureTally::new(ap, &r, rec.noise_power_w));
        images.push(Image {
            grid: r.grid,
            multilook: r.multilook,
        });
    }
    let (mut metrics, best) = tally::fold(&tallies, rec.noise_power_w);
    // resolution measured on the strongest landmark's look, as the CLI's `process` does
    let best = best.and_then(|(ai, look)| {
        let k = rec.apertures.iter().position(|a| a.index == ai)?;
        Some((k, look))
    });
    if let Some((k, look)) = best {
        let ap = &rec.apertures[k];
        let pulses: Vec<PulseMeta> = rec.pulses[k]
            .iter()
            .filter(|p| p.look == look)
            .copied()
            .collect();
        let first = look * ap.pulses_per_look * rec.samples_per_pulse;
        let samples = iq[k]
            .get(first..first + pulses.len() * rec.samples_per_pulse)
            .unwrap_or_default();
        if let Some((rr, ra)) = tally::measure_look(&proc, ap, &pulses, samples)? {
            metrics.range_resolution_m = Some(rr);
            metrics.azimuth_resolution_m = Some(ra);
            metrics.resolution_from = Some((ap.index, look));
        }
    }
    Ok((images, tallies, metrics))
}

/// Images, detections and metrics of a processed recording.
#[pyclass(frozen, name = "Result", module = "cellsar.radar")]
pub struct PyRadarResult {
    images: Vec<Py<PyArray2<f32>>>,
    x_m: Vec<Py<PyArray1<f64>>>,
    y_m: Vec<Py<PyArray1<f64>>>,
    detections: Py<PyAny>,
    metrics: Py<PyAny>,
}

#[pymethods]
impl PyRadarResult {
    /// Per aperture its multilook power image, `ny × nx` float32 (row iy at `y_m[iy]`, column
    /// ix at `x_m[ix]`).
    #[getter]
    fn images<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.images.iter().map(|a| a.bind(py)))
    }

    /// Per aperture the ground x of each image column, m.
    #[getter]
    fn x_m<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.x_m.iter().map(|a| a.bind(py)))
    }

    /// Per aperture the ground y of each image row, m.
    #[getter]
    fn y_m<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.y_m.iter().map(|a| a.bind(py)))
    }

    /// The detections (the rows of the CLI's `detections.csv`): a structured array with
    /// aperture, x_m, y_m, snr_db, pixels, truth_id (-1: unmatched), error_m (nan: unmatched).
    #[getter]
    fn detections<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        self.detections.bind(py).clone()
    }

    /// `metrics.json` as a dict.
    #[getter]
    fn metrics<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        self.metrics.bind(py).clone()
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let n = self.detections.bind(py).len().unwrap_or(0);
        format!("Result(apertures={}, detections={n})", self.images.len())
    }
}

/// Processes a recording into images, detections and metrics; `scene` (None: the recording's)
/// may change the `[processing]` table. Runs with the GIL released.
#[pyfunction]
#[pyo3(signature = (recording, scene = None))]
pub fn process(
    py: Python<'_>,
    recording: PyRef<'_, PyRecording>,
    scene: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyRadarResult> {
    let rec = &*recording;
    let setup = match scene.filter(|s| !s.is_none()) {
        None => rec.setup.clone(),
        Some(s) => {
            let file = scene_from(Some(s))?;
            let setup =
                RadarSetup::new(rec.mission.inner.params(), &file).map_err(|e| radar_err(&e))?;
            if setup.num != rec.setup.num {
                return Err(RadarError::new_err(
                    "scene: its [radar] table differs from the recording's (only [processing] may change)",
                ));
            }
            setup
        }
    };
    let borrows: Vec<PyReadonlyArray2<'_, Complex32>> =
        rec.iq.iter().map(|a| a.bind(py).readonly()).collect();
    let slices: Vec<&[Complex32]> = borrows
        .iter()
        .map(|b| b.as_slice())
        .collect::<Result<_, _>>()
        .map_err(|e| RadarError::new_err(format!("IQ array: {e}")))?;
    let (images, tallies, metrics) = py
        .detach(|| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                process_in_memory(rec, setup, &slices)
            }))
        })
        .map_err(|p| panic_error("the radar processor", p.as_ref()))?
        .map_err(|e| radar_err(&e))?;
    let rows: Vec<_> = tallies
        .iter()
        .flat_map(|t| t.rows.iter().cloned())
        .collect();
    let detections = structured(
        py,
        &[
            "aperture", "x_m", "y_m", "snr_db", "pixels", "truth_id", "error_m",
        ],
        vec![
            i64_col(py, &rows, |r| index(r.aperture)),
            f64_col(py, &rows, |r| r.x_m),
            f64_col(py, &rows, |r| r.y_m),
            f64_col(py, &rows, |r| r.snr_db),
            i64_col(py, &rows, |r| index(r.pixels)),
            i64_col(py, &rows, |r| r.truth_id.map_or(-1, index)),
            f64_col(py, &rows, |r| r.error_m.unwrap_or(f64::NAN)),
        ],
    )?;
    let mut out = PyRadarResult {
        images: Vec::with_capacity(images.len()),
        x_m: Vec::with_capacity(images.len()),
        y_m: Vec::with_capacity(images.len()),
        detections: detections.unbind(),
        metrics: json::to_py(py, &metrics)?.unbind(),
    };
    for img in images {
        let g = img.grid;
        let array = Array2::from_shape_vec((g.ny, g.nx), img.multilook)
            .map_err(|e| RadarError::new_err(format!("image shape: {e}")))?;
        out.images.push(array.into_pyarray(py).unbind());
        out.x_m
            .push(PyArray1::from_vec(py, (0..g.nx).map(|i| g.x(i)).collect()).unbind());
        out.y_m
            .push(PyArray1::from_vec(py, (0..g.ny).map(|i| g.y(i)).collect()).unbind());
    }
    Ok(out)
}

/// Checks a scene (None, a scene file path or a dict with its structure) as `simulate` reads
/// it, without simulating: raises `RadarError` naming the table and key of a bad one.
#[pyfunction]
#[pyo3(signature = (scene = None))]
pub fn check_scene(scene: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
    scene_from(scene).map(drop)
}

/// Registers `cellsar._cellsar.radar`'s classes and functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRecording>()?;
    m.add_class::<PyRadarResult>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(process, m)?)?;
    m.add_function(wrap_pyfunction!(check_scene, m)?)?;
    Ok(())
}
