//! `forge --forge-iq`: wrong IQ frames on a mission's echo key (`cellsar/<m>/echo`), the data
//! key that the bridge's certificate may put (it carries the echo's frames out to Zenoh), and
//! the bridge's counters key, which it may put too. Every round and for every mission it forges
//! for:
//!
//! - frames of another mission: well-formed, checksummed, one on the mission's key whose header
//!   names another mission, one on that other mission's key (nobody processes it);
//! - a frame numbered outside any mission ([`SEQ_OUTSIDE`]);
//! - frames numbered as the mission's first [`FORGED_SEQS`] with a shape and a mission time that
//!   fit no layout (1 pulse × 1 sample, at −1 s), and the first of them replayed
//!   [`REPLAYS`] times;
//! - garbage: bytes that are no frame, a frame whose checksum does not match its payload, a
//!   frame whose header announces more bytes than it carries, a frame of single bytes whose
//!   payload is not complex f32, and every [`OVERSIZE_EVERY`] rounds a frame larger
//!   than the processor's `--max-frame-bytes` default;
//! - with `--iq-flood-frames N`, `N` frames of `--iq-flood-bytes` bytes each, numbered in the
//!   mission and not fitting its layout (1 pulse, at −1 s);
//! - a garbage counters message on `cellsar/bridge/<instance>/stats`;
//! - with `--iq-plan-dir` and `--iq-scene` (the mission's plan, as a peer that knows it
//!   would have it), `--iq-fit-frames` frames every round that FIT the layout: numbered,
//!   shaped and timed as the processor expects (computed by the same library calls as the
//!   processor's context), with forged samples, every other one tagged under a key of the
//!   forger's own and the rest untagged. They go through the mission's frames in turn.
//!
//! None of them may change what the processor makes: a frame is taken only when its mission is
//! one the processor runs, its number falls in the mission, its shape and mission time are the
//! layout's for that number, and its tag verifies under the key the echo gave the processor
//! (which a peer holding only the bridge's certificate cannot learn: the key travels in the
//! echo's answers to the processor's aperture requests).

use std::path::PathBuf;
use std::sync::OnceLock;

use bridge::frame::{self, FrameKey, FrameMeta};
use bridge::zenoh::Wait;
use bridge::{MissionId, ZenohNode};
use pipeline::protocol::{keys, FrameLayout};
use serde::Serialize;

/// The number of a forged frame that no mission has.
pub(super) const SEQ_OUTSIDE: u64 = 1 << 40;

/// Frames numbered as a mission's first ones, forged every round (shape and time wrong).
pub(super) const FORGED_SEQS: u64 = 4;

/// How many times the first of them is sent again every round.
pub(super) const REPLAYS: u64 = 4;

/// Every this many rounds, a frame larger than the processor's default `--max-frame-bytes`.
pub(super) const OVERSIZE_EVERY: u64 = 25;

/// The mission time of the forged frames numbered in the mission, ns: before any pulse.
const BEFORE_THE_MISSION_NS: i64 = -1_000_000_000;

/// The flags of the IQ forgeries.
#[derive(clap::Args, Debug, Clone)]
pub(in super::super) struct IqArgs {
    /// Every round and for every mission: put wrong IQ frames on its echo key (another
    /// mission's, numbered outside it, of a shape and time that fit no layout, replayed, no
    /// frame at all, a bad checksum, truncated, not complex f32, too large) and garbage bridge
    /// counters.
    #[arg(long)]
    forge_iq: bool,
    /// With --forge-iq: also this many frames of --iq-flood-bytes every round and mission.
    #[arg(long, default_value_t = 0)]
    iq_flood_frames: u32,
    /// Payload bytes of each flooded frame (a multiple of 8).
    #[arg(long, default_value_t = 64 * 1024)]
    iq_flood_bytes: u32,
    /// With --forge-iq and --iq-scene: the plan directory (mission.toml, trajectory.csv) of
    /// the mission forged for; frames that fit its layout are forged too.
    #[arg(long, requires = "iq_scene")]
    iq_plan_dir: Option<PathBuf>,
    /// The scene file of the mission of --iq-plan-dir.
    #[arg(long, requires = "iq_plan_dir")]
    iq_scene: Option<PathBuf>,
    /// With --iq-plan-dir: layout-fitting frames forged every round.
    #[arg(long, default_value_t = 1)]
    iq_fit_frames: u32,
}

/// What the IQ forgeries put (and how many puts failed).
#[derive(Debug, Default, Serialize)]
pub(super) struct IqForged {
    /// Well-formed frames of another mission (on the mission's key or the other's).
    pub other_mission: u64,
    /// Well-formed frames numbered outside any mission.
    pub seq_outside: u64,
    /// Well-formed frames numbered in the mission, of a shape and time that fit no layout.
    pub misfit: u64,
    /// Replays of the first of them.
    pub replays: u64,
    /// Puts that are no valid frame (no frame, bad checksum, truncated, not complex f32, too
    /// large).
    pub garbage: u64,
    /// Flooded frames.
    pub flooded: u64,
    /// Garbage bridge counters.
    pub stats: u64,
    /// Frames that fit the mission's layout, with forged samples (tagged under the forger's
    /// own key, or untagged).
    pub fitting: u64,
    /// Why no layout-fitting frame could be made (the plan or scene did not load), if so.
    pub fit_error: Option<String>,
    /// Puts that failed.
    pub errors: u64,
    /// Rounds done.
    pub rounds: u64,
}

/// A well-formed, checksummed IQ frame (wire form) of `rows` × `cols` samples, every sample
/// `value`.
fn iq_frame(id: MissionId, seq: u64, time_ns: i64, rows: u32, cols: u32, value: f32) -> Vec<u8> {
    let n = rows as usize * cols as usize;
    let samples = vec![bridge::Complex32::new(value, -value); n];
    let payload = frame::samples_as_bytes(&samples);
    FrameMeta::iq(id, seq, time_ns, rows, cols)
        .header(Some(frame::checksum(payload)))
        .and_then(|h| frame::encode_wire(&h, payload))
        .unwrap_or_default()
}

/// What the processor expects of each frame of a mission: (rows, cols, mission time ns) by
/// frame number, and the mission's frame count.
pub(super) struct Fit {
    /// The mission's frame layout, as the processor and the echo hold it.
    pub layout: FrameLayout,
    /// Mission time of every aperture's pulses, as the processor holds them, ns.
    pulse_times_ns: Vec<Vec<i64>>,
    /// The scene's digest, as the echo's frames and requests carry it.
    pub scene_digest: u64,
}

/// The layout of the mission of `plan_dir` and `scene`, by the library calls the processor's
/// context makes (`MissionContext::with_limits`, `ProcContext::new`).
fn fit_of(plan_dir: &std::path::Path, scene: &std::path::Path) -> Result<Fit, String> {
    let (mission, traj) = pipeline::report::read_plan_dir(plan_dir)
        .map_err(|e| format!("{}: {e}", plan_dir.display()))?;
    let scene = radar_sim::config::SceneFile::from_path(scene)
        .map_err(|e| format!("{}: {e}", scene.display()))?;
    let setup = radar_sim::pipeline::RadarSetup::new(mission.params(), &scene)
        .map_err(|e| e.to_string())?;
    let apertures = setup.apertures(&mission).map_err(|e| e.to_string())?;
    let spp = setup.scene.radar.samples_per_pulse();
    let layout = FrameLayout::new(&apertures, spp, frame::SERVICE_MAX_FRAME_BYTES)
        .map_err(|e| e.to_string())?;
    let track = radar_sim::track::PlannedTrack::new(traj, mission.params().altitude_m);
    let pulse_times_ns = apertures
        .iter()
        .map(|ap| {
            setup
                .pulses(&track, ap)
                .iter()
                .map(|p| {
                    (pipeline::services::process::pulse_as_recorded(p).t_s * 1e9).round() as i64
                })
                .collect()
        })
        .collect();
    Ok(Fit {
        layout,
        pulse_times_ns,
        scene_digest: scene.digest(),
    })
}

/// The layout of the mission of `--iq-plan-dir` and `--iq-scene` (loaded once), or why it
/// could not be made; `None` without those flags.
pub(super) fn fit(a: &IqArgs) -> Option<&'static Result<Fit, String>> {
    static FIT: OnceLock<Result<Fit, String>> = OnceLock::new();
    let (Some(plan_dir), Some(scene)) = (&a.iq_plan_dir, &a.iq_scene) else {
        return None;
    };
    Some(FIT.get_or_init(|| fit_of(plan_dir, scene)))
}

/// The forger's own frame key (the echo's is never given to it).
pub(super) fn own_key() -> Option<&'static FrameKey> {
    static KEY: OnceLock<Option<FrameKey>> = OnceLock::new();
    KEY.get_or_init(|| FrameKey::random().ok()).as_ref()
}

/// `a.iq_fit_frames` frames of mission `id` that fit its layout, the `k`-th of the mission
/// `start + k` (modulo its frame count), with forged samples; odd frame numbers tagged under
/// the forger's own key, even ones untagged.
fn fitting_frames(id: MissionId, fit: &Fit, start: u64, count: u32) -> Vec<Vec<u8>> {
    let total = fit.layout.total_frames();
    if total == 0 {
        return Vec::new();
    }
    (0..u64::from(count))
        .filter_map(|k| {
            let seq = (start + k) % total;
            let slot = fit.layout.locate(seq)?;
            let t_ns = *fit
                .pulse_times_ns
                .get(slot.aperture)?
                .get(slot.first_pulse)?;
            let (rows, cols) = (slot.pulses as u32, fit.layout.samples_per_pulse() as u32);
            let samples = vec![
                bridge::Complex32::new(1e3, -1e3);
                slot.pulses * fit.layout.samples_per_pulse()
            ];
            let payload = frame::samples_as_bytes(&samples);
            let mut meta = FrameMeta::iq(id, seq, t_ns, rows, cols).with_scene(fit.scene_digest);
            if seq % 2 == 1 {
                meta = meta.tagged(own_key()?, payload);
            }
            meta.header(Some(frame::checksum(payload)))
                .and_then(|h| frame::encode_wire(&h, payload))
                .ok()
        })
        .collect()
}

/// The frames that are no valid frame: not a frame, a bad checksum, truncated, bytes that are
/// not complex f32 and, with `oversize`, one larger than the processor takes.
fn garbage(id: MissionId, oversize: bool) -> Vec<Vec<u8>> {
    let noise: Vec<u8> = (0..100u32)
        .map(|i| (i.wrapping_mul(151) ^ 0x5a) as u8)
        .collect();
    let mut bad_crc = iq_frame(id, 0, BEFORE_THE_MISSION_NS, 1, 4, 1.0);
    if let Some(last) = bad_crc.last_mut() {
        *last ^= 0xff;
    }
    let mut truncated = iq_frame(id, 0, BEFORE_THE_MISSION_NS, 1, 4, 1.0);
    truncated.truncate(truncated.len().saturating_sub(8));
    let bytes = FrameMeta::bytes(frame::IQ_FRAME_KIND, id, 0, 7)
        .and_then(|m| m.header(None))
        .and_then(|h| frame::encode_wire(&h, &[7; 7]))
        .unwrap_or_default();
    let mut out = vec![noise, bad_crc, truncated, bytes];
    if oversize {
        let cols = (frame::SERVICE_MAX_FRAME_BYTES / 8 + 1) as u32;
        out.push(iq_frame(id, 0, BEFORE_THE_MISSION_NS, 1, cols, 0.0));
    }
    out
}

/// One round of IQ forgeries for mission `id` (with `a.forge_iq`), from instance `instance`.
pub(super) fn forge_round(
    node: &ZenohNode,
    id: MissionId,
    instance: &str,
    a: &IqArgs,
    r: &mut IqForged,
) {
    if !a.forge_iq {
        return;
    }
    let (Ok(key), Ok(other_key)) = (keys::echo(id), keys::echo(MissionId(id.0 ^ 0xff00_ff00)))
    else {
        r.errors += 1;
        return;
    };
    let other = MissionId(id.0 ^ 0xff00_ff00);
    let mut put =
        |k: &str, bytes: Vec<u8>, count: &mut u64| match node.session().put(k, bytes).wait() {
            Ok(()) => *count += 1,
            Err(_) => r.errors += 1,
        };
    let mut n = 0;
    put(&key, iq_frame(other, 0, 0, 1, 4, 1.0), &mut n);
    put(&other_key, iq_frame(other, 0, 0, 1, 4, 1.0), &mut n);
    r.other_mission += n;
    let mut n = 0;
    put(&key, iq_frame(id, SEQ_OUTSIDE, 0, 1, 4, 1.0), &mut n);
    r.seq_outside += n;
    let mut n = 0;
    for seq in 0..FORGED_SEQS {
        put(
            &key,
            iq_frame(id, seq, BEFORE_THE_MISSION_NS, 1, 1, 1e6),
            &mut n,
        );
    }
    r.misfit += n;
    let mut n = 0;
    let first = iq_frame(id, 0, BEFORE_THE_MISSION_NS, 1, 1, 1e6);
    for _ in 0..REPLAYS {
        put(&key, first.clone(), &mut n);
    }
    r.replays += n;
    let mut n = 0;
    for g in garbage(id, r.rounds.is_multiple_of(OVERSIZE_EVERY)) {
        put(&key, g, &mut n);
    }
    r.garbage += n;
    let mut n = 0;
    let cols = (a.iq_flood_bytes / 8).max(1);
    for k in 0..u64::from(a.iq_flood_frames) {
        let seq = k % FORGED_SEQS;
        put(
            &key,
            iq_frame(id, seq, BEFORE_THE_MISSION_NS, 1, cols, 1e3),
            &mut n,
        );
    }
    r.flooded += n;
    let mut n = 0;
    if let Ok(stats) = bridge::keys::chunk("instance", instance)
        .map(|_| format!("cellsar/bridge/{instance}/stats"))
    {
        put(&stats, b"{\"forged\": true}".to_vec(), &mut n);
    }
    r.stats += n;
    if let Some(fit) = fit(a) {
        match fit {
            Ok(fit) => {
                let mut n = 0;
                let start = r.rounds.saturating_mul(u64::from(a.iq_fit_frames));
                for f in fitting_frames(id, fit, start, a.iq_fit_frames) {
                    put(&key, f, &mut n);
                }
                r.fitting += n;
            }
            Err(e) => r.fit_error = Some(e.clone()),
        }
    }
    r.rounds += 1;
}
