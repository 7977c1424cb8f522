//! What the processor derives from a plan and a scene: the mission context every radar
//! service shares, the processor's own view of it, one aperture's outcome, the pulses and
//! truth as recorded, and the messages made from outcomes.

use std::sync::Arc;
use std::time::Instant;

use bridge::{Complex32, Message, MissionId};
use serde::{Deserialize, Serialize};

use radar_sim::config::SceneFile;
use radar_sim::limits::{IqBudget, IqLimits};
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::run::{MeasuredResolution, Metrics};
use radar_sim::scene::SceneObject;
use radar_sim::tally::{self, ApertureTally};
use radar_sim::track::{Aperture, PlannedTrack, PulseMeta};

use crate::protocol::{ApertureDetections, ApertureImage, Detection, FrameLayout, Plan};
use crate::services::radar::{ServiceError, ServiceResult};

/// What every radar service derives from a plan and a scene.
#[derive(Debug)]
pub struct MissionContext {
    /// Mission id.
    pub mission_id: MissionId,
    /// The plan.
    pub plan: Arc<Plan>,
    /// The validated mission.
    pub mission: planner::Mission,
    /// Radar setup (mission parameters + scene).
    pub setup: RadarSetup,
    /// One aperture per landmark window.
    pub apertures: Vec<Aperture>,
    /// Which frame carries which pulses.
    pub layout: FrameLayout,
    /// The planned track, at the plan's altitudes (a free mission) or the mission's altitude.
    pub track: PlannedTrack,
    /// The scene's digest ([`SceneFile::digest`]): in every aperture request and IQ frame of
    /// the mission, and compared with the other side's.
    pub scene_digest: u64,
}

impl MissionContext {
    /// Resolves a plan against a scene under the default [`IqLimits`]; errors name the
    /// mission.
    pub fn new(plan: &Arc<Plan>, scene: &SceneFile, max_frame_bytes: usize) -> ServiceResult<Self> {
        Self::with_limits(plan, scene, max_frame_bytes, &IqLimits::default())
    }

    /// Resolves a plan against a scene; a mission whose IQ or largest aperture exceeds
    /// `limits` is refused ([`radar_sim::limits::IqBudget`]); errors name the mission.
    pub fn with_limits(
        plan: &Arc<Plan>,
        scene: &SceneFile,
        max_frame_bytes: usize,
        limits: &IqLimits,
    ) -> ServiceResult<Self> {
        let mission = plan.mission().map_err(|e| ServiceError::Mission {
            mission: plan.mission_id,
            reason: e.to_string(),
        })?;
        let setup = RadarSetup::new(mission.params(), scene)?;
        let apertures = setup.apertures(&mission)?;
        IqBudget::new(&setup, &apertures).check(&setup, limits)?;
        let spp = setup.scene.radar.samples_per_pulse();
        let layout = FrameLayout::new(&apertures, spp, max_frame_bytes)?;
        // a free mission is flown at the plan's altitude per slot, a fixed one at `altitude_m`
        let track = radar_sim::run::planned_track(
            &mission,
            &plan.result.trajectory,
            plan.result.altitudes_m.as_deref(),
        )?;
        Ok(MissionContext {
            mission_id: plan.mission_id,
            plan: plan.clone(),
            mission,
            setup,
            apertures,
            layout,
            track,
            scene_digest: scene.digest(),
        })
    }
}

/// One processed aperture: everything `cellsar-radar-sim process` derives from it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ApertureOutcome {
    /// Its detections and what it adds to the mission's metrics.
    pub tally: ApertureTally,
    /// The image.
    pub image: ApertureImage,
    /// Processing time, s.
    pub process_s: f64,
}

impl ApertureOutcome {
    /// Aperture index.
    pub fn aperture(&self) -> usize {
        self.tally.summary.aperture
    }
}

/// A per-aperture outcome as the processor stores it in `--state-dir`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StoredOutcome {
    /// The outcome.
    pub outcome: ApertureOutcome,
}

impl Message for StoredOutcome {
    const KIND: u16 = 0x0309;
    const NAME: &'static str = "radar.stored_outcome";
    /// 2: the outcome nests its tally and no longer repeats the aperture index (a version-1
    /// file in a state directory is ignored, and that aperture processed again). 3: the tally
    /// carries the physics review's metrics (an older file is ignored the same way). 4: the
    /// image names its processor instance (`radar.aperture_image` 2).
    const SCHEMA_VERSION: u16 = 4;
}

/// The pulse as `cellsar-radar-sim simulate` writes it to `pulses.csv` and `process` reads it
/// back (same number formats), so that both processors see identical inputs.
pub fn pulse_as_recorded(p: &PulseMeta) -> PulseMeta {
    let r = |s: String| s.parse::<f64>().unwrap_or(f64::NAN);
    PulseMeta {
        index: p.index,
        aperture: p.aperture,
        look: p.look,
        t_s: r(format!("{:.9}", p.t_s)),
        symbol: p.symbol,
        pos_m: [
            r(format!("{:.6}", p.pos_m[0])),
            r(format!("{:.6}", p.pos_m[1])),
            r(format!("{:.6}", p.pos_m[2])),
        ],
        vel_mps: [
            r(format!("{:.6}", p.vel_mps[0])),
            r(format!("{:.6}", p.vel_mps[1])),
            r(format!("{:.6}", p.vel_mps[2])),
        ],
        heading: [
            r(format!("{:.12}", p.heading[0])),
            r(format!("{:.12}", p.heading[1])),
        ],
        window_delay_samples: p.window_delay_samples,
    }
}

/// The object as written to `truth.csv` and read back (same number formats).
pub fn object_as_recorded(o: &SceneObject) -> SceneObject {
    let r = |s: String| s.parse::<f64>().unwrap_or(f64::NAN);
    SceneObject {
        id: o.id,
        x_m: r(format!("{:.6}", o.x_m)),
        y_m: r(format!("{:.6}", o.y_m)),
        rcs_m2: r(format!("{:.6e}", o.rcs_m2)),
        phase_rad: r(format!("{:.9}", o.phase_rad)),
        landmark: o.landmark,
    }
}

/// The processor's view of a mission: the shared context, the processor, the pulses and the
/// truth as recorded.
pub struct ProcContext {
    /// The shared context.
    pub base: Arc<MissionContext>,
    /// The processor.
    pub proc: Processor,
    /// Pulses per aperture.
    pub pulses: Vec<Vec<PulseMeta>>,
    /// Truth objects (for scoring).
    pub truth: Vec<SceneObject>,
    /// Noise power per complex sample, W.
    pub noise_power_w: f64,
}

impl ProcContext {
    /// Builds the processor's context of a mission.
    pub fn new(base: Arc<MissionContext>) -> ServiceResult<Self> {
        let setup = &base.setup;
        let proc = Processor::new(setup.clone())?;
        let pulses = base
            .apertures
            .iter()
            .map(|ap| {
                setup
                    .pulses(&base.track, ap)
                    .iter()
                    .map(pulse_as_recorded)
                    .collect()
            })
            .collect();
        let truth = setup
            .objects(&base.mission)?
            .iter()
            .map(object_as_recorded)
            .collect();
        let noise_power_w = setup.synthesizer(Vec::new())?.noise_power_w();
        Ok(ProcContext {
            base,
            proc,
            pulses,
            truth,
            noise_power_w,
        })
    }

    /// Processes aperture `k` from its IQ (`pulses × samples`).
    pub fn process(&self, k: usize, iq: &[Complex32]) -> ServiceResult<ApertureOutcome> {
        let t0 = Instant::now();
        let ap =
            self.base.apertures.get(k).ok_or_else(|| {
                ServiceError::Internal(format!("aperture {k} is not in the mission"))
            })?;
        let pulses = &self.pulses[k];
        let r = self.proc.process_aperture(ap, pulses, iq, &self.truth)?;
        let markers = tally::detection_pixels(&r)
            .into_iter()
            .map(|(x, y)| (x as u32, y as u32))
            .collect();
        Ok(ApertureOutcome {
            tally: ApertureTally::new(ap, &r, self.noise_power_w),
            image: ApertureImage {
                mission_id: self.base.mission_id,
                aperture: ap.index as u32,
                nx: r.grid.nx as u32,
                ny: r.grid.ny as u32,
                centre_m: r.grid.centre_m,
                spacing_m: r.grid.spacing_m,
                multilook: r.multilook,
                markers,
                // named when published (an outcome restored after a restart is published
                // under the processor's instance of now)
                processor: String::new(),
            },
            process_s: t0.elapsed().as_secs_f64(),
        })
    }

    /// Measures the resolution on one look of aperture `k` (as `process` does on the
    /// strongest landmark); None when the measurement fails, as there.
    pub fn resolution(
        &self,
        k: usize,
        look: usize,
        iq: &[Complex32],
    ) -> ServiceResult<Option<(MeasuredResolution, MeasuredResolution)>> {
        let ap =
            self.base.apertures.get(k).ok_or_else(|| {
                ServiceError::Internal(format!("aperture {k} is not in the mission"))
            })?;
        let pulses: Vec<PulseMeta> = self.pulses[k]
            .iter()
            .filter(|p| p.look == look)
            .copied()
            .collect();
        Ok(tally::measure_look(&self.proc, ap, &pulses, iq)?)
    }
}

/// Folds per-aperture outcomes (in aperture order) into the mission's metrics, as `process`
/// does; returns them with the (aperture, look) of the resolution measurement, if any.
pub fn fold_metrics(
    outcomes: &[&ApertureOutcome],
    noise_power_w: f64,
) -> (Metrics, Option<(usize, usize)>) {
    tally::fold(outcomes.iter().map(|o| &o.tally), noise_power_w)
}

/// The detections message of an outcome.
pub fn detections_message(
    id: MissionId,
    o: &ApertureOutcome,
    apertures: usize,
    processor: &str,
) -> ApertureDetections {
    ApertureDetections {
        mission_id: id,
        aperture: o.aperture() as u32,
        apertures: apertures as u32,
        landmark: o.tally.summary.landmark,
        landmark_detected: o.tally.summary.landmark_detected,
        landmark_snr_db: o.tally.summary.landmark_snr_db.filter(|v| v.is_finite()),
        detections: o.tally.rows.iter().map(Detection::from).collect(),
        false_alarms: o.tally.false_alarms,
        process_s: o.process_s,
        processor: processor.to_string(),
    }
}
