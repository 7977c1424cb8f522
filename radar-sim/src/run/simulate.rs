//! `simulate`: a planned trajectory and a scene → a recording directory (`iq/aperture_NNN.npy`,
//! `pulses.csv`, `truth.csv`, `meta.json`).

use std::path::Path;

use super::recording::{write_pulses, write_truth};
use super::{iq_path, mkdir, ApertureTruth, Progress, RecordingMeta, FORMAT, FRAME_LAYOUT};
use crate::config::SceneFile;
use crate::error::{RadarError, Result};
use crate::io::{write_json, NpyType, NpyWriter};
use crate::limits::{IqBudget, IqLimits};
use crate::pipeline::RadarSetup;
use crate::scene::SceneObject;
use crate::synth::{Components, Synthesizer};
use crate::track::{Aperture, PlannedTrack, PulseMeta};
use rustfft::num_complex::Complex32;

/// Frames of `run::simulate` hold at most this many bytes of IQ (and 100 pulses).
pub const SIMULATE_FRAME_BYTES: usize = 64 << 20;

/// Simulates the recording of `mission` flown along `traj` over the scene into `out`, refusing
/// a run above the default [`IqLimits`] (see [`simulate_limited`]).
pub fn simulate(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    scene: &SceneFile,
    out: &Path,
    progress: Progress<'_>,
) -> Result<RecordingMeta> {
    simulate_limited(mission, traj, scene, out, &IqLimits::default(), progress)
}

/// Simulates the recording of `mission` flown along `traj` over the scene into `out`. Before
/// anything is synthesised or written, the run's IQ and the memory of its largest aperture are
/// checked against `limits` ([`crate::limits::IqBudget`]). A mission with `altitude = "free"`
/// is refused here: flying it needs its plan's altitudes ([`simulate_profile_limited`]).
pub fn simulate_limited(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    scene: &SceneFile,
    out: &Path,
    limits: &IqLimits,
    progress: Progress<'_>,
) -> Result<RecordingMeta> {
    simulate_profile_limited(mission, traj, None, scene, out, limits, progress)
}

/// Allowance on the altitude bounds of a free mission, m (the planner's solver meets them to
/// within its tolerance).
const ALTITUDE_BOUND_SLACK_M: f64 = 1e-3;

/// The track that flies `traj` for `mission`: at its fixed altitude, or through
/// `altitudes_m` (one per slot, within the mission's bounds) for a mission with
/// `altitude = "free"`. A free mission without a profile, or a fixed one with a profile, is
/// refused ([`RadarError::Config`] naming `altitude` / `altitudes_m`).
pub fn planned_track(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    altitudes_m: Option<&[f64]>,
) -> Result<PlannedTrack> {
    let p = mission.params();
    match (p.altitude, altitudes_m) {
        (planner::AltitudeMode::Fixed, None) => Ok(PlannedTrack::new(traj.clone(), p.altitude_m)),
        (planner::AltitudeMode::Fixed, Some(_)) => Err(RadarError::config(
            "altitudes_m",
            format!(
                "mission {} flies at one altitude ({} m, altitude = \"fixed\"): an altitude per slot is not flown",
                mission.name(),
                p.altitude_m
            ),
        )),
        (planner::AltitudeMode::Free, None) => Err(RadarError::config(
            "altitude",
            format!(
                "mission {} has altitude = \"free\": flying it needs its plan's altitude per slot (the z_m column of the plan's trajectory.csv, planned with the altitude profile on)",
                mission.name()
            ),
        )),
        (planner::AltitudeMode::Free, Some(h)) => {
            let (lo, hi) = planner::altitude::bounds_m(p);
            if let Some((i, z)) = h.iter().enumerate().find(|(_, z)| {
                !(**z >= lo - ALTITUDE_BOUND_SLACK_M && **z <= hi + ALTITUDE_BOUND_SLACK_M)
            }) {
                return Err(RadarError::config(
                    "altitudes_m",
                    format!(
                        "slot {}: altitude {z} m is outside the mission's bounds [{lo}, {hi}] m",
                        i + 1
                    ),
                ));
            }
            PlannedTrack::with_altitudes(traj.clone(), p.altitude_m, h.to_vec())
        }
    }
}

/// As [`simulate_limited`], flying `traj` at the altitudes `altitudes_m` (one per slot) for a
/// mission with `altitude = "free"` ([`planned_track`]): every pulse's position, the antenna's
/// footprint, the echo and direct-path delays and powers follow H_t.
pub fn simulate_profile_limited(
    mission: &planner::Mission,
    traj: &planner::Trajectory,
    altitudes_m: Option<&[f64]>,
    scene: &SceneFile,
    out: &Path,
    limits: &IqLimits,
    progress: Progress<'_>,
) -> Result<RecordingMeta> {
    let track = planned_track(mission, traj, altitudes_m)?;
    let setup = RadarSetup::new(mission.params(), scene)?;
    let aps = setup.apertures(mission)?;
    IqBudget::new(&setup, &aps).check(&setup, limits)?;
    let objects = setup.objects(mission)?;
    let synth = setup.synthesizer(objects.clone())?;
    // ground clutter (`[clutter]`): synthesised with the objects, not part of the truth
    let clutter = crate::clutter::GroundClutter::for_run(&setup, &track, &aps)?;
    mkdir(&out.join("iq"))?;
    let spp = synth.samples_per_pulse();
    let sample_bytes = crate::limits::IQ_SAMPLE_BYTES as usize;
    let frame_pulses = (SIMULATE_FRAME_BYTES / (spp * sample_bytes).max(1)).clamp(1, 100);
    let total: u64 = aps.iter().map(|a| a.pulses() as u64).sum();
    let mut done = 0u64;
    let mut all_pulses = Vec::new();
    let mut truths = Vec::new();
    let mut warnings = Vec::new();
    for ap in &aps {
        let pulses = setup.pulses(&track, ap);
        let (truth, warning) = aperture_truth(&setup, &synth, &objects, ap, &pulses);
        truths.push(truth);
        warnings.extend(warning);
        let cluttered = match &clutter {
            Some(c) => Some(c.synthesizer(&setup, &objects, ap, &pulses)?),
            None => None,
        };
        let w = NpyWriter::create(&iq_path(out, ap.index), NpyType::C8, &[pulses.len(), spp])?;
        write_overlapped(
            w,
            cluttered.as_ref().unwrap_or(&synth),
            &pulses,
            frame_pulses,
            &mut |n| {
                done += n as u64;
                progress(done, total);
            },
        )?;
        all_pulses.extend(pulses);
    }
    if !truths.is_empty()
        && truths
            .iter()
            .all(|t| t.landmark_gain_db.is_some_and(|g| g < -10.0))
    {
        return Err(RadarError::Mismatch(format!(
            "no landmark is in the receive beam in any aperture (best {:.1} dB off the peak): the plan does not look at the scene",
            truths.iter().filter_map(|t| t.landmark_gain_db).fold(f64::NEG_INFINITY, f64::max)
        )));
    }
    write_pulses(&out.join("pulses.csv"), &all_pulses)?;
    write_truth(&out.join("truth.csv"), &objects)?;
    let meta = RecordingMeta {
        format: FORMAT.into(),
        frame_layout: FRAME_LAYOUT.into(),
        mission: mission.name().to_string(),
        params: mission.params().clone(),
        scene: scene.clone(),
        numerology: setup.num.clone(),
        noise_power_w: synth.noise_power_w(),
        samples_per_pulse: spp,
        apertures: truths,
        warnings,
    };
    write_json(&out.join("meta.json"), &meta)?;
    Ok(meta)
}

/// Synthesises `pulses` in frames of `frame_pulses` into `w` and finishes it; a writer thread
/// writes each frame while the next is synthesised (the recording's bytes, gigabytes under NR,
/// then cost no synthesis time). `done(pulses)` is called as each frame is handed over.
fn write_overlapped(
    mut w: NpyWriter,
    synth: &Synthesizer,
    pulses: &[PulseMeta],
    frame_pulses: usize,
    done: &mut dyn FnMut(usize),
) -> Result<()> {
    std::thread::scope(|scope| {
        // one frame in the channel, one being written: at most three frames in memory
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Complex32>>(1);
        let writer = scope.spawn(move || -> Result<NpyWriter> {
            for iq in rx {
                w.write_c8(&iq)?;
            }
            Ok(w)
        });
        let mut made = Ok(());
        for chunk in pulses.chunks(frame_pulses.max(1)) {
            match synth.synthesize_frame(chunk, Components::ALL) {
                // a closed channel: the writer failed, its error is reported below
                Ok(iq) => {
                    if tx.send(iq).is_err() {
                        break;
                    }
                }
                Err(e) => {
                    made = Err(e);
                    break;
                }
            }
            done(chunk.len());
        }
        drop(tx);
        let written = writer
            .join()
            .map_err(|_| RadarError::Mismatch("the IQ writer thread panicked".into()))?;
        made?;
        written?.finish()
    })
}

/// The truth-side facts of one aperture at its middle pulse, and a warning when its landmark
/// lies more than 10 dB off the beam peak.
fn aperture_truth(
    setup: &RadarSetup,
    synth: &Synthesizer,
    objects: &[SceneObject],
    ap: &Aperture,
    pulses: &[PulseMeta],
) -> (ApertureTruth, Option<String>) {
    let mid = &pulses[pulses.len() / 2];
    let landmark_gain_db = ap.landmark.map(|_| {
        let g = setup.antenna.gain_towards(
            mid.pos_m,
            mid.heading,
            [ap.centre_m[0], ap.centre_m[1], 0.0],
        );
        10.0 * (g / setup.antenna.peak_gain).log10()
    });
    let warning = landmark_gain_db.filter(|&g| g < -10.0).map(|g| {
        format!(
            "aperture {} (t = {:.1}..{:.1} s): landmark {:?} is {:.1} dB off the beam peak at mid-aperture",
            ap.index, ap.t_start_s, ap.t_end_s, ap.landmark, g
        )
    });
    let pd = synth.direct_power_w(mid.pos_m, mid.heading);
    let pe: f64 = objects
        .iter()
        .map(|o| synth.echo_power_w(o, mid.pos_m, mid.heading))
        .sum();
    let truth = ApertureTruth {
        aperture: ap.clone(),
        landmark_gain_db,
        direct_to_echo_db: 10.0 * (pd / pe.max(1e-300)).log10(),
        direct_to_noise_db: 10.0 * (pd / synth.noise_power_w()).log10(),
    };
    (truth, warning)
}
