//! Messages of the radar services (kinds `0x0300..=0x03ff`).

use bridge::{Message, MissionId};
use serde::{Deserialize, Serialize};

use radar_sim::run::{DetectionRow, Metrics};

/// f64 fields that may be NaN or infinite: JSON has no such numbers, so they are written as
/// `null` and read back as NaN; binary forms keep the value.
pub mod f64_or_null {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Serialises `v` (non-finite values as `null` in human-readable formats).
    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            if v.is_finite() {
                Some(*v).serialize(s)
            } else {
                None::<f64>.serialize(s)
            }
        } else {
            v.serialize(s)
        }
    }

    /// Deserialises a value written by [`serialize`] (`null` → NaN).
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        if d.is_human_readable() {
            Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
        } else {
            f64::deserialize(d)
        }
    }
}

/// Ask the echo for the frames of one aperture (or one look of it); sent as a query to
/// `cellsar/<mission>/echo/request`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ApertureRequest {
    /// Mission id.
    pub mission_id: MissionId,
    /// Aperture index.
    pub aperture: u32,
    /// Only this look (None: the whole aperture).
    pub look: Option<u32>,
    /// Pulses per frame the requester expects (must match the echo's layout).
    pub frame_pulses: u32,
    /// Digest of the requester's scene (`radar_sim::config::SceneFile::digest`): the echo
    /// refuses a request whose scene is not its own, naming both digests.
    pub scene_digest: u64,
    /// Who asks (for logs).
    pub requester: String,
}

impl Message for ApertureRequest {
    const KIND: u16 = 0x0301;
    const NAME: &'static str = "radar.aperture_request";
    /// 2: `scene_digest`.
    const SCHEMA_VERSION: u16 = 2;
}

/// The echo's answer to an [`ApertureRequest`]: which frames will be sent.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RequestAck {
    /// Mission id.
    pub mission_id: MissionId,
    /// Aperture.
    pub aperture: u32,
    /// Look (None: all).
    pub look: Option<u32>,
    /// Sequence numbers of the frames that will be sent.
    pub seqs: Vec<u64>,
    /// Jobs queued before this one at the echo.
    pub queued_before: u32,
    /// False when an identical request was already queued (nothing added).
    pub queued: bool,
    /// The mission's frame key: the echo tags every IQ frame of the mission with it
    /// ([`bridge::frame::FrameKey::tag`]), and a processor given it takes only frames whose
    /// tag verifies. It goes only to whoever asked (a query reply); `None`: frames untagged.
    pub frame_key: Option<bridge::frame::FrameKey>,
}

impl Message for RequestAck {
    const KIND: u16 = 0x0302;
    const NAME: &'static str = "radar.request_ack";
    /// 2: `frame_key`.
    const SCHEMA_VERSION: u16 = 2;
}

/// Metadata of one IQ frame (`cellsar/<mission>/frames`), published next to the frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameInfo {
    /// Mission id.
    pub mission_id: MissionId,
    /// Sequence number of the frame (as in its header).
    pub seq: u64,
    /// Aperture.
    pub aperture: u32,
    /// Look within the aperture.
    pub look: u32,
    /// Global index of the frame's first pulse.
    pub first_pulse: u64,
    /// Pulses (rows).
    pub pulses: u32,
    /// Complex samples per pulse (columns).
    pub samples_per_pulse: u32,
    /// Mission time of the first pulse, s.
    pub t_first_s: f64,
    /// CRC-32 of the samples.
    pub checksum: u32,
    /// iceoryx2 subscribers it reached.
    pub delivered: u32,
    /// iceoryx2 subscribers skipped because their buffer was full.
    pub skipped_full: u32,
}

impl Message for FrameInfo {
    const KIND: u16 = 0x0303;
    const NAME: &'static str = "radar.frame_info";
    const SCHEMA_VERSION: u16 = 1;
}

/// One detection (as a row of `detections.csv`), JSON-safe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Aperture.
    pub aperture: usize,
    /// x, m.
    #[serde(with = "f64_or_null")]
    pub x_m: f64,
    /// y, m.
    #[serde(with = "f64_or_null")]
    pub y_m: f64,
    /// SNR over the local noise, dB.
    #[serde(with = "f64_or_null")]
    pub snr_db: f64,
    /// Pixels in the cluster.
    pub pixels: usize,
    /// Matched truth id.
    pub truth_id: Option<usize>,
    /// Distance to the matched truth, m.
    pub error_m: Option<f64>,
}

impl From<&DetectionRow> for Detection {
    fn from(d: &DetectionRow) -> Self {
        Detection {
            aperture: d.aperture,
            x_m: d.x_m,
            y_m: d.y_m,
            snr_db: d.snr_db,
            pixels: d.pixels,
            truth_id: d.truth_id,
            error_m: d.error_m.filter(|e| e.is_finite()),
        }
    }
}

impl From<&Detection> for DetectionRow {
    fn from(d: &Detection) -> Self {
        DetectionRow {
            aperture: d.aperture,
            x_m: d.x_m,
            y_m: d.y_m,
            snr_db: d.snr_db,
            pixels: d.pixels,
            truth_id: d.truth_id,
            error_m: d.error_m,
        }
    }
}

/// The detections of one aperture (`cellsar/<mission>/detections`, JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ApertureDetections {
    /// Mission id.
    pub mission_id: MissionId,
    /// Aperture index.
    pub aperture: u32,
    /// Apertures in the mission.
    pub apertures: u32,
    /// Landmark of the aperture.
    pub landmark: Option<usize>,
    /// Whether the landmark was detected.
    pub landmark_detected: Option<bool>,
    /// Expected per-look SNR of the landmark, dB.
    pub landmark_snr_db: Option<f64>,
    /// The detections.
    pub detections: Vec<Detection>,
    /// Unmatched detections.
    pub false_alarms: usize,
    /// Seconds the processor spent on the aperture.
    #[serde(with = "f64_or_null")]
    pub process_s: f64,
    /// Processor instance.
    pub processor: String,
}

impl Message for ApertureDetections {
    const KIND: u16 = 0x0304;
    const NAME: &'static str = "radar.aperture_detections";
    const SCHEMA_VERSION: u16 = 1;
}

/// The multilook image of one aperture (`cellsar/<mission>/image/<n>`, bincode): power over the
/// per-look noise, `ny × nx` row-major, north up as in the PNG, with the detection markers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ApertureImage {
    /// Mission id.
    pub mission_id: MissionId,
    /// Aperture index.
    pub aperture: u32,
    /// Columns.
    pub nx: u32,
    /// Rows.
    pub ny: u32,
    /// Grid centre, m.
    pub centre_m: [f64; 2],
    /// Pixel spacing, m.
    pub spacing_m: f64,
    /// `ny × nx` multilook power over the noise (f32).
    pub multilook: Vec<f32>,
    /// Detection markers (column, row).
    pub markers: Vec<(u32, u32)>,
    /// Processor instance that made the image (its liveliness token
    /// `cellsar/alive/processor/<instance>`): the launcher takes images only from a processor
    /// instance it saw alive, as it takes detections.
    pub processor: String,
}

impl Message for ApertureImage {
    const KIND: u16 = 0x0305;
    const NAME: &'static str = "radar.aperture_image";
    /// 2: the image names the processor instance that made it (`processor`).
    const SCHEMA_VERSION: u16 = 2;
}

/// The mission's processing metrics (`cellsar/<mission>/metrics`), as `metrics.json` of
/// `cellsar-radar-sim process`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MissionMetrics {
    /// Mission id.
    pub mission_id: MissionId,
    /// Apertures processed.
    pub apertures: u32,
    /// The metrics.
    pub metrics: Metrics,
    /// Processor instance that publishes them (its liveliness token
    /// `cellsar/alive/processor/<instance>`): the launcher takes metrics only from a processor
    /// instance it saw alive, as it takes detections.
    pub processor: String,
}

impl Message for MissionMetrics {
    const KIND: u16 = 0x0306;
    const NAME: &'static str = "radar.mission_metrics";
    /// 2: the metrics of the physics review (direct-path suppression and the residual over the
    /// predicted floor instead of `dpi_reduction_db`, per-object Pd, pixel-level and
    /// Euler-characteristic false-alarm designs, resolution pairs with one definition).
    /// 3: the metrics name the processor instance that publishes them (`processor`).
    const SCHEMA_VERSION: u16 = 3;
}

/// Ask the processor to publish the results of some apertures again (and the metrics); sent as
/// a query to `cellsar/<mission>/results`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ResultRequest {
    /// Mission id.
    pub mission_id: MissionId,
    /// Apertures whose detections and image to publish again.
    pub apertures: Vec<u32>,
    /// Publish the metrics again (if known).
    pub metrics: bool,
}

impl Message for ResultRequest {
    const KIND: u16 = 0x0307;
    const NAME: &'static str = "radar.result_request";
    const SCHEMA_VERSION: u16 = 1;
}

/// The processor's answer to a [`ResultRequest`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ResultAck {
    /// Apertures published again.
    pub republished: Vec<u32>,
    /// Apertures it does not have (yet).
    pub missing: Vec<u32>,
    /// Whether the metrics were published again.
    pub metrics: bool,
}

impl Message for ResultAck {
    const KIND: u16 = 0x0308;
    const NAME: &'static str = "radar.result_ack";
    const SCHEMA_VERSION: u16 = 1;
}
