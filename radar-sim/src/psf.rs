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
use crate::nr::Reference;
use crate::pipeline::{Compressed, Processor, RadarSetup};
use crate::resolution::CellReport;
use crate::scene::SceneObject;
use crate::synth::Components;
use crate::track::PulseMeta;
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
    Ok(measure_case_in(params, case, &scene)?.0)
}

/// Measures `case` under `scene` (its noise and direct path as set there): the cell, and the
/// compressed spectra and pulses of the look (for [`range_profile_levels`]).
pub fn measure_case_in(
    params: &planner::Params,
    case: &PsfCase,
    scene: &SceneFile,
) -> Result<(CellReport, Compressed, Processor, Vec<PulseMeta>)> {
    let setup = RadarSetup::new(params, scene)?;
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
    let cell = proc.measure_cell(&c, &pulses, 0..pulses.len(), case.target_m)?;
    Ok((cell, c, proc, pulses))
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

/// The range profile of a point target around its delay, from one pulse's compressed spectrum:
/// the peak, the highest sidelobe (beyond the main lobe's first nulls) and the level at the
/// comb alias `delay + alias_samples`, in dB relative to the peak.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProfileLevels {
    /// Peak sidelobe over the whole profile (N samples around the peak), dB.
    pub peak_sidelobe_db: f64,
    /// The profile at the alias delay, dB.
    pub alias_db: f64,
}

/// [`ProfileLevels`] of the middle pulse of `c` (spectra kept) for a target at `target_m`, with
/// the alias at `alias_samples` from the peak, scanning the N-sample period at a quarter
/// sample.
pub fn range_profile_levels(
    proc: &Processor,
    c: &Compressed,
    pulses: &[PulseMeta],
    target_m: [f64; 2],
    alias_samples: f64,
) -> Option<ProfileLevels> {
    let k = pulses.len() / 2;
    let z = c.spectra.as_ref()?.get(k)?;
    let p = &pulses[k];
    let setup = proc.setup();
    let delay = setup
        .geometry()
        .delay_samples(target_m, p.pos_m, p.window_delay_samples);
    let comp = proc.compressor();
    let n = setup.num.fft_size as f64;
    // the main lobe's first null: N/N_sc unweighted, twice that with a Hann or Hamming taper
    let nulls = match setup.scene.processing.range_weighting {
        crate::config::Weighting::None => 1.0,
        _ => 2.0,
    };
    let lobe = nulls * n / setup.num.subcarriers as f64;
    let peak = comp.evaluate(z, delay).norm();
    if peak <= 0.0 {
        return None;
    }
    let steps = (4.0 * n) as usize;
    let side = (0..steps)
        .map(|j| j as f64 / 4.0 - n / 2.0)
        .filter(|x| x.abs() > lobe)
        .map(|x| comp.evaluate(z, delay + x).norm())
        .fold(0.0, f64::max);
    let alias = comp.evaluate(z, delay + alias_samples).norm();
    let db = |v: f64| 20.0 * (v.max(1e-300) / peak).log10();
    Some(ProfileLevels {
        peak_sidelobe_db: db(side),
        alias_db: db(alias),
    })
}

/// One reference's measured response.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReferenceResponse {
    /// The reference.
    pub reference: Reference,
    /// Symbols per pulse.
    pub pulse_symbols: usize,
    /// The −3 dB cell against its prediction.
    pub cell: CellReport,
    /// Range-profile levels of the middle pulse.
    pub levels: ProfileLevels,
}

/// The peak sidelobe of the unweighted range response (a sinc over evenly covered
/// subcarriers), dB.
pub const SINC_PEAK_SIDELOBE_DB: f64 = -13.26;

impl ReferenceResponse {
    /// The predicted level at the comb alias N / `prs_comb`, dB: `None` (no alias) where the
    /// reference covers every occupied subcarrier over the pulse (`ideal`, `reconstructed`, and
    /// `pilots` once the PRS's staggering cycle of `prs_comb` symbols is complete); 0 dB for a
    /// `pilots` pulse shorter than the cycle (a comb repeats its response every N / comb).
    pub fn predicted_alias_db(&self, prs_comb: usize) -> Option<f64> {
        (self.reference == Reference::Pilots && self.pulse_symbols < prs_comb).then_some(0.0)
    }
}

/// The response of each reference under the NR cell `nr` (default canceller, no noise, the
/// direct path on, so that `reconstructed` decides on it) for `case`: the comb alias at
/// N / prs_comb samples.
pub fn reference_responses(
    params: &planner::Params,
    case: &PsfCase,
    nr: &crate::config::NrConfig,
) -> Result<Vec<ReferenceResponse>> {
    let mut out = Vec::new();
    for reference in [
        Reference::Ideal,
        Reference::Pilots,
        Reference::Reconstructed,
    ] {
        let mut scene = SceneFile::default();
        scene.radar.thermal_noise = false;
        scene.radar.reference = reference;
        scene.radar.nr = Some(nr.clone());
        let (cell, c, proc, pulses) = measure_case_in(params, case, &scene)?;
        let alias = proc.setup().num.fft_size as f64 / nr.prs_comb as f64;
        let levels =
            range_profile_levels(&proc, &c, &pulses, case.target_m, alias).ok_or_else(|| {
                crate::RadarError::Mismatch("no response at the target: nothing to measure".into())
            })?;
        out.push(ReferenceResponse {
            reference,
            pulse_symbols: nr.pulse_symbols,
            cell,
            levels,
        });
    }
    Ok(out)
}
