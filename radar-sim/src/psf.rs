//! The resolution report's measurements: the measured −3 dB region of a point target's response
//! and its principal widths beside the predicted parallelogram cell (errata 11 and 12
//! (docs/paper-notes.md)), for several bistatic geometries (one within a few degrees of blind)
//! and bandwidths. Each case is one noise-free look of a single object at the sensing centre of
//! a straight track, imaged exactly (sinc-interpolated, f64) and traced in 40 directions
//! ([`crate::resolution::PsfRegion`]). The report itself (table, JSON, drawings) is written by
//! the pipeline crate (`pipeline::report::resolution`).

use serde::{Deserialize, Serialize};

use crate::config::{CancellerKind, SceneFile};
use crate::error::Result;
use crate::pipeline::{Processor, RadarSetup};
use crate::resolution::CellReport;
use crate::scene::SceneObject;
use crate::synth::Components;
use crate::track::{plan_apertures, plan_pulses, LinearTrack};

/// One geometry: a straight track at `speed_mps` heading `heading_deg` whose sensing centre
/// passes the target at the middle of the look.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PsfCase {
    /// Short name.
    pub label: String,
    /// Target (x, y), m.
    pub target_m: [f64; 2],
    /// Heading, deg from +x counter-clockwise.
    pub heading_deg: f64,
    /// Speed, m/s.
    pub speed_mps: f64,
    /// Within a few degrees of the blind geometry.
    pub near_blind: bool,
}

/// The report's geometries (default BS): three well-conditioned bistatic angles and, at the
/// origin with the UAV heading 4° off north, a slot within a few degrees of blind.
pub fn default_cases() -> Vec<PsfCase> {
    let c = |label: &str, t: [f64; 2], h: f64, nb: bool| PsfCase {
        label: label.into(),
        target_m: t,
        heading_deg: h,
        speed_mps: 20.0,
        near_blind: nb,
    };
    vec![
        c("origin, heading south", [0.0, 0.0], 180.0, false),
        c("(300, 500), heading west", [300.0, 500.0], 270.0, false),
        c(
            "(−400, 200), heading south-west",
            [-400.0, 200.0],
            225.0,
            false,
        ),
        c(
            "origin, heading 4° off north (near blind)",
            [0.0, 0.0],
            94.0,
            true,
        ),
    ]
}

/// Measures `case` for mission parameters `params` (its B, λ, T_d, geometry) with the default
/// radar and unweighted processing (main-lobe factor 0.886).
pub fn measure_case(params: &planner::Params, case: &PsfCase) -> Result<CellReport> {
    let mut scene = SceneFile::default();
    scene.radar.thermal_noise = false;
    scene.radar.direct_path = false;
    scene.processing.canceller = CancellerKind::None;
    let setup = RadarSetup::new(params, &scene)?;
    let proc = Processor::new(setup.clone())?;
    let t_mid = 0.5 * setup.look_s;
    let track = LinearTrack::through(
        params,
        case.target_m,
        case.heading_deg,
        case.speed_mps,
        t_mid,
    );
    let ap = plan_apertures(
        &[(case.target_m, Some(0), 0.0, setup.look_s)],
        setup.look_s,
        setup.scene.radar.prf_hz,
    )?
    .remove(0);
    let pulses = plan_pulses(
        &track,
        &setup.num,
        setup.bs_m,
        &ap,
        setup.scene.radar.prf_hz,
    );
    let object = SceneObject {
        id: 0,
        x_m: case.target_m[0],
        y_m: case.target_m[1],
        rcs_m2: 10.0,
        phase_rad: 0.0,
        landmark: None,
    };
    let iq = setup
        .synthesizer(vec![object])?
        .synthesize_frame(&pulses, Components::ALL)?;
    let grid = setup.grid(&ap);
    let c = proc.compress(&grid, &pulses, &iq, ap.pulses_per_look, None, true)?;
    proc.measure_cell(&c, &pulses, 0..pulses.len(), case.target_m)
}

/// One row of the resolution report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReportRow {
    /// The geometry.
    pub case: PsfCase,
    /// Its measurement.
    pub cell: CellReport,
}

/// Mission parameters of the report at bandwidth `bandwidth_hz`: the defaults otherwise.
pub fn params_at(bandwidth_hz: f64) -> planner::Params {
    planner::Params {
        bandwidth_hz,
        ..Default::default()
    }
}
