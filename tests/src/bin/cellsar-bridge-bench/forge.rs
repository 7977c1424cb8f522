//! `forge`: a hostile peer of the pipeline. It learns the mission ids from the keys it may
//! see (plans, statuses) and, for each, keeps publishing a forged processor status
//! `{role: "processor", state: "failed"}` and forged detections of every aperture (one
//! detection far off the scene at `FORGED_X_M`), under an instance name of its own; with
//! `--malformed-images`, also an image of aperture 0 (which every mission has) whose pixel
//! count is not `nx × ny`; with `--forge-plans`, it answers every plan request at once with
//! a plan of another mission (planned when it starts), and publishes that plan under a mission
//! id its content does not give (`FORGED_PLAN_ID`).

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::Result;
use bridge::net::{PublishOptions, TypedPublisher};
use bridge::zenoh::sample::Sample;
use bridge::zenoh::Wait;
use bridge::{MissionId, ZenohArgs};
use pipeline::protocol::{
    keys, ApertureDetections, ApertureImage, Detection, Plan, PlanRequest, ServiceStatus,
};
use serde::Serialize;

use super::{ready, report, tools::z_node};

/// The mission id the published forged plan claims (its content gives another).
pub(super) const FORGED_PLAN_ID: MissionId = MissionId(0x5eed_5eed_5eed_5eed);

/// x of the forged detection, m: far from any scene's landmarks.
pub(super) const FORGED_X_M: f64 = 987_654.0;

/// The flags of `forge`.
#[derive(clap::Args, Debug, Clone)]
pub(super) struct ForgeArgs {
    /// The instance name the forged messages claim.
    #[arg(long, default_value = "intruder")]
    instance: String,
    /// Apertures to forge detections for (0..N).
    #[arg(long, default_value_t = 16)]
    apertures: u32,
    /// Keep forging for this many seconds.
    #[arg(long, default_value = "30", value_parser = bridge::flags::parse_seconds)]
    duration_s: bridge::flags::Seconds,
    /// Pause between two rounds, ms.
    #[arg(long, default_value_t = 200)]
    interval_ms: u64,
    /// Also publish an image of aperture 0 whose pixel count differs from nx × ny.
    #[arg(long)]
    malformed_images: bool,
    /// Also answer every plan request (cellsar/plan) at once with a plan of another mission.
    #[arg(long)]
    forge_plans: bool,
    #[command(flatten)]
    zenoh: ZenohArgs,
}

#[derive(Debug, Default, Serialize)]
struct ForgeReport {
    missions: usize,
    statuses: u64,
    detections: u64,
    images: u64,
    plans: u64,
    errors: u64,
}

/// A plan of a mission of its own ("forged"), for answering plan requests.
fn forged_plan() -> Result<Plan> {
    let mission = planner::MissionFile::from_toml_str(
        "name = \"forged\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{ x_m = 0.0, \
         y_m = 0.0, from_s = 0.0, to_s = 10.0 }, { x_m = 0.0, y_m = 30.0, from_s = 10.0, to_s = \
         20.0 }]\n",
    )
    .map_err(|e| anyhow::anyhow!("the forged mission: {e}"))?;
    let req = PlanRequest {
        mission,
        options: Default::default(),
    };
    Ok(pipeline::services::plan::plan_request(
        &req,
        "intruder",
        &mut planner::NoObserver,
    )?)
}

fn mission_of(key: &str) -> Option<MissionId> {
    let m = key.split('/').nth(1)?;
    (m.len() == 16)
        .then(|| u64::from_str_radix(m, 16).ok())
        .flatten()
        .map(MissionId)
}

struct Forger {
    status: TypedPublisher<ServiceStatus>,
    detections: TypedPublisher<ApertureDetections>,
    images: Vec<TypedPublisher<ApertureImage>>,
}

pub(super) fn forge(a: &ForgeArgs) -> Result<()> {
    let node = z_node(&a.zenoh, "forge")?;
    let seen: Arc<Mutex<BTreeSet<MissionId>>> = Arc::default();
    // whatever the router lets through: plans (the echo's certificate may read them) or
    // statuses (anyone on a plain mesh)
    let mut subs = Vec::new();
    for sel in [keys::ALL_PLANS, keys::ALL_STATUS] {
        let s = seen.clone();
        subs.push(
            node.session()
                .declare_subscriber(sel)
                .callback(move |sample: Sample| {
                    // not the mission of its own forged plan
                    let id =
                        mission_of(sample.key_expr().as_str()).filter(|id| *id != FORGED_PLAN_ID);
                    if let (Some(id), Ok(mut s)) = (id, s.lock()) {
                        s.insert(id);
                    }
                })
                .wait()
                .map_err(|e| anyhow::anyhow!("subscribing to {sel}: {e}"))?,
        );
    }
    let plans = if a.forge_plans {
        let q =
            node.queryable::<PlanRequest>(keys::PLAN, bridge::net::SubscribeOptions::default())?;
        let plan = forged_plan()?;
        let wrong_id = Plan {
            mission_id: FORGED_PLAN_ID,
            ..plan.clone()
        };
        let publisher = node.publisher::<Plan>(
            &keys::plan(FORGED_PLAN_ID)?,
            PublishOptions {
                mission_id: FORGED_PLAN_ID,
                ..PublishOptions::default()
            },
        )?;
        Some((q, plan, publisher, wrong_id))
    } else {
        None
    };
    ready();
    let mut forgers: Vec<(MissionId, Forger)> = Vec::new();
    let mut r = ForgeReport::default();
    let end = Instant::now() + a.duration_s.duration();
    while Instant::now() < end {
        if let Some((q, plan, publisher, wrong_id)) = &plans {
            match publisher.put(wrong_id) {
                Ok(_) => r.plans += 1,
                Err(_) => r.errors += 1,
            }
            while let Some(request) = q.recv_timeout(Duration::ZERO) {
                match request.reply(plan, bridge::Meta::default()) {
                    Ok(()) => {
                        r.plans += 1;
                        eprintln!("answered a plan request with a forged plan");
                    }
                    Err(_) => r.errors += 1,
                }
            }
        }
        let ids: Vec<MissionId> = seen
            .lock()
            .map(|s| s.iter().copied().collect())
            .unwrap_or_default();
        for id in ids {
            if !forgers.iter().any(|(i, _)| *i == id) {
                eprintln!("forging for mission {id}");
                let opts = PublishOptions {
                    mission_id: id,
                    ..PublishOptions::json()
                };
                let mut images = Vec::new();
                if a.malformed_images {
                    let o = PublishOptions {
                        mission_id: id,
                        ..PublishOptions::default()
                    };
                    images.push(node.publisher(&keys::image(id, 0)?, o)?);
                }
                forgers.push((
                    id,
                    Forger {
                        status: node.publisher(&keys::status(id, "processor")?, opts)?,
                        detections: node.publisher(&keys::detections(id)?, opts)?,
                        images,
                    },
                ));
            }
        }
        for (id, f) in &forgers {
            let status = ServiceStatus {
                role: "processor".into(),
                instance: a.instance.clone(),
                mission_id: *id,
                state: "failed".into(),
                message: "forged".into(),
                ..ServiceStatus::default()
            };
            match f.status.put(&status) {
                Ok(_) => r.statuses += 1,
                Err(_) => r.errors += 1,
            }
            for k in 0..a.apertures {
                let d = ApertureDetections {
                    mission_id: *id,
                    aperture: k,
                    apertures: a.apertures,
                    landmark: None,
                    landmark_detected: Some(true),
                    landmark_snr_db: None,
                    detections: vec![Detection {
                        aperture: k as usize,
                        x_m: FORGED_X_M,
                        y_m: 0.0,
                        snr_db: 99.0,
                        pixels: 1,
                        truth_id: None,
                        error_m: None,
                    }],
                    false_alarms: 0,
                    process_s: 0.0,
                    processor: a.instance.clone(),
                };
                match f.detections.put(&d) {
                    Ok(_) => r.detections += 1,
                    Err(_) => r.errors += 1,
                }
            }
            for (k, p) in f.images.iter().enumerate() {
                // 8 × 8 pixels announced, 63 sent
                let img = ApertureImage {
                    mission_id: *id,
                    aperture: k as u32,
                    nx: 8,
                    ny: 8,
                    centre_m: [0.0, 0.0],
                    spacing_m: 1.0,
                    multilook: vec![1.0; 63],
                    markers: Vec::new(),
                };
                match p.put(&img) {
                    Ok(_) => r.images += 1,
                    Err(_) => r.errors += 1,
                }
            }
        }
        std::thread::sleep(Duration::from_millis(a.interval_ms));
    }
    r.missions = forgers.len();
    drop(subs);
    report(&r)?;
    node.close()?;
    Ok(())
}
