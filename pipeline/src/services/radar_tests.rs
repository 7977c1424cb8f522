//! The service's per-aperture processing against the file-based `simulate` + `process` on the
//! same plan: identical pulses, truth, detections and metrics.

use std::path::Path;
use std::sync::Arc;

use super::echo::*;
use super::plan::plan_request;
use super::process::*;
use crate::protocol::*;
use planner::NoObserver;

use super::process::{fold_metrics, ProcContext};
use radar_sim::config::SceneFile;
use radar_sim::io::NpyReader;
use radar_sim::run;

/// A small, fast scene (1024-point FFT, 50 MHz, 40 m grid at 0.5 m).
pub(crate) const SMALL_SCENE: &str = r#"
[objects]
count = 8
radius_m = 120.0
seed = 3
rcs_m2 = 5.0
include_landmarks = true
landmark_rcs_m2 = 10.0

[radar]
fft_size = 1024
cp_samples = 256
bandwidth_hz = 50e6

[processing]
grid_half_m = 20.0
pixel_m = 0.5
range_weighting = "hann"
azimuth_weighting = "hann"
"#;

fn small_scene() -> SceneFile {
    SceneFile::from_toml_str(SMALL_SCENE, "small scene").unwrap()
}

fn plan(horizon_s: f64) -> Arc<crate::protocol::Plan> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let m = planner::Mission::from_path(&root.join("../missions/default-30m.toml")).unwrap();
    let m = run::shorten(&m, horizon_s).unwrap();
    let req = PlanRequest {
        mission: m.to_file_struct(),
        options: crate::protocol::PlanRequestOptions {
            resolution: Some(planner::evaluate::ResolutionMode::Paper),
            ..Default::default()
        },
    };
    Arc::new(plan_request(&req, "test", &mut NoObserver).unwrap())
}

#[test]
fn aperture_processing_matches_the_file_pipeline() {
    let scene = small_scene();
    let plan = plan(10.0);
    let base = Arc::new(MissionContext::new(&plan, &scene, 1 << 20).unwrap());
    let ctx = ProcContext::new(base.clone()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let meta = run::simulate(
        &base.mission,
        &plan.result.trajectory,
        &scene,
        &rec,
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(meta.apertures.len(), 1);
    // inputs as the file-based processor sees them
    let pulses = run::read_pulses(&rec.join("pulses.csv")).unwrap();
    assert_eq!(pulses, ctx.pulses[0]);
    let truth = run::read_truth(&rec.join("truth.csv")).unwrap();
    assert_eq!(truth, ctx.truth);
    assert_eq!(meta.noise_power_w.to_bits(), ctx.noise_power_w.to_bits());
    // the same numbers out
    let out = dir.path().join("out");
    let metrics = run::process(
        &rec,
        &out,
        &mut |_, _| {},
        &mut crate::report::image_svg::write_aperture_view,
    )
    .unwrap();
    let mut rd = NpyReader::open(&rec.join("iq/aperture_000.npy")).unwrap();
    let n = rd.shape[0] * rd.shape[1];
    let iq = rd.read_c8(0, n).unwrap();
    let o = ctx.process(0, &iq).unwrap();
    let rows: Vec<run::DetectionRow> =
        serde_json::from_str(&std::fs::read_to_string(out.join("detections.json")).unwrap())
            .unwrap();
    assert!(!rows.is_empty(), "the landmark should be detected");
    assert_eq!(
        serde_json::to_string(&rows).unwrap(),
        serde_json::to_string(&o.tally.rows).unwrap()
    );
    let (mut m2, best) = fold_metrics(&[&o], ctx.noise_power_w);
    let (k, look) = best.unwrap();
    assert_eq!(Some((k, look)), metrics.resolution_from);
    let spp = base.layout.samples_per_pulse();
    let ppl = base.apertures[k].pulses_per_look;
    let look_iq = &iq[look * ppl * spp..(look + 1) * ppl * spp];
    let (rr, ra) = ctx.resolution(k, look, look_iq).unwrap().unwrap();
    m2.range_resolution_m = Some(rr);
    m2.azimuth_resolution_m = Some(ra);
    m2.resolution_from = Some((k, look));
    assert_eq!(
        serde_json::to_string(&metrics).unwrap(),
        serde_json::to_string(&m2).unwrap()
    );
    // the image is the multilook written by `process`
    let mut img = NpyReader::open(&out.join("images/aperture_000.npy")).unwrap();
    assert_eq!(img.shape, [o.image.ny as usize, o.image.nx as usize]);
    let pix = img.read_f4(0, img.shape[0] * img.shape[1]).unwrap();
    assert_eq!(pix, o.image.multilook);
}

#[test]
fn layout_of_a_mission_fits_the_frames() {
    let scene = small_scene();
    let plan = plan(20.0);
    let base = MissionContext::new(&plan, &scene, 1024 * 8 * 30).unwrap();
    assert_eq!(base.apertures.len(), 2);
    assert_eq!(base.layout.frame_pulses(), 30);
    // 10 looks of 100 pulses in 4 frames each, per aperture
    assert_eq!(base.layout.total_frames(), 80);
    let e = MissionContext::new(&plan, &scene, 100).unwrap_err();
    assert!(e.to_string().contains("--max-frame-bytes"), "{e}");
}

/// Two scenes of the same layout (the cyclic prefix 128 samples instead of 256) give the same
/// frames, so only the scene's digest, which every aperture request and frame carries, tells
/// them apart; the refusal names both digests.
#[test]
fn scenes_of_the_same_layout_differ_in_their_digest() {
    let plan = plan(20.0);
    let ours = MissionContext::new(&plan, &small_scene(), 1024 * 8 * 30).unwrap();
    let other = SceneFile::from_toml_str(
        &SMALL_SCENE.replace("cp_samples = 256", "cp_samples = 128"),
        "other scene",
    )
    .unwrap();
    let theirs = MissionContext::new(&plan, &other, 1024 * 8 * 30).unwrap();
    assert_eq!(ours.layout, theirs.layout);
    assert_eq!(ours.scene_digest, small_scene().digest());
    assert_ne!(ours.scene_digest, theirs.scene_digest);
    // a frame the other scene's echo makes is refused by the processor's check, naming both
    let frame = bridge::frame::FrameMeta::iq(ours.mission_id, 0, 0, 1, 1)
        .with_scene(theirs.scene_digest)
        .header(None)
        .unwrap();
    frame.check_scene(theirs.scene_digest).unwrap();
    let msg = frame
        .check_scene(ours.scene_digest)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains(&format!("{:016x}", theirs.scene_digest))
            && msg.contains(&format!("{:016x}", ours.scene_digest))
            && msg.contains("--scene"),
        "{msg}"
    );
}

#[test]
fn detections_survive_json_with_nan() {
    let d = ApertureDetections {
        mission_id: bridge::MissionId(7),
        aperture: 1,
        apertures: 2,
        landmark: Some(1),
        landmark_detected: Some(true),
        landmark_snr_db: Some(20.0),
        detections: vec![Detection {
            aperture: 1,
            x_m: 1.5,
            y_m: f64::NAN,
            snr_db: 13.25,
            pixels: 4,
            truth_id: None,
            error_m: None,
        }],
        false_alarms: 1,
        process_s: f64::INFINITY,
        processor: "p".into(),
    };
    let json = bridge::envelope::encode_json(&d, bridge::Meta::default()).unwrap();
    let text = String::from_utf8(json.clone()).unwrap();
    assert!(text.contains("\"y_m\":null"), "{text}");
    let back: ApertureDetections =
        bridge::envelope::decode_json(&json, &bridge::DecodeLimits::default())
            .unwrap()
            .message;
    assert!(back.detections[0].y_m.is_nan() && back.process_s.is_nan());
    assert_eq!(back.detections[0].x_m, 1.5);
    let bin = bridge::envelope::encode(&d, bridge::Meta::default()).unwrap();
    let back: ApertureDetections = bridge::envelope::decode(&bin, &bridge::DecodeLimits::default())
        .unwrap()
        .message;
    assert!(back.process_s.is_infinite());
}

/// A Zenoh client configuration file in `dir` whose router (an unused loopback port) never
/// comes, waiting for it as `pipeline/deploy/client.json5` does (`connect.timeout_ms: -1`).
fn client_without_router(dir: &Path) -> String {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .unwrap()
        .port();
    let file = dir.join("client.json5");
    std::fs::write(
        &file,
        bridge::zconfig::waiting_client_json5(&format!("tcp/127.0.0.1:{port}")),
    )
    .unwrap();
    file.display().to_string()
}

/// The echo and the processor started before their router stop within a moment of their stop
/// flag (what SIGINT/SIGTERM set), with an empty report, instead of waiting for the router
/// forever.
#[test]
fn services_stop_while_waiting_for_the_router() {
    use clap::Parser;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::Duration;

    #[derive(clap::Parser)]
    struct EchoCli {
        #[command(flatten)]
        args: EchoArgs,
    }
    #[derive(clap::Parser)]
    struct ProcessCli {
        #[command(flatten)]
        args: ProcessArgs,
    }

    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SMALL_SCENE).unwrap();
    let common = |role: &str| -> Vec<String> {
        vec![
            role.to_string(),
            "--scene".into(),
            scene.display().to_string(),
            "-c".into(),
            client_without_router(dir.path()),
            "--iox-root".into(),
            dir.path().join("iox").display().to_string(),
            "--iox-prefix".into(),
            format!("rsw{}_", std::process::id()),
        ]
    };
    let echo = EchoCli::try_parse_from(common("echo")).unwrap().args;
    let process = ProcessCli::try_parse_from(common("process")).unwrap().args;
    type Run = Box<dyn FnOnce(&AtomicBool) -> Result<String, String> + Send>;
    // each returns its report (Debug): the empty one
    let runs: Vec<(&str, String, Run)> = vec![
        (
            "echo",
            format!("{:?}", EchoReport::default()),
            Box::new(move |stop| {
                run_echo(&echo, stop)
                    .map(|r| format!("{r:?}"))
                    .map_err(|e| e.to_string())
            }),
        ),
        (
            "processor",
            format!("{:?}", ProcessReport::default()),
            Box::new(move |stop| {
                run_processor(&process, stop)
                    .map(|r| format!("{r:?}"))
                    .map_err(|e| e.to_string())
            }),
        ),
    ];
    for (role, empty, run) in runs {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let s = stop.clone();
        std::thread::spawn(move || {
            let _ = tx.send(run(&s));
        });
        std::thread::sleep(Duration::from_millis(700));
        assert!(rx.try_recv().is_err(), "{role} returned without a router");
        stop.store(true, Ordering::Relaxed);
        let r = rx
            .recv_timeout(Duration::from_secs(2))
            .unwrap_or_else(|_| panic!("{role} did not stop within 2 s of the stop flag"));
        assert_eq!(r, Ok(empty), "{role}");
    }
}
