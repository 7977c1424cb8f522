//! The status every service publishes per mission (kind `0x0110`).

use std::collections::BTreeMap;

use bridge::{Message, MissionId};
use serde::{Deserialize, Serialize};

/// Progress and counters of one service for one mission (`cellsar/<mission>/status/<role>`,
/// JSON). Shared by every cellsar service.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ServiceStatus {
    /// Role (planner, echo, processor, ...).
    pub role: String,
    /// Instance name.
    pub instance: String,
    /// Mission id.
    pub mission_id: MissionId,
    /// State (`planning`, `planned`, `running`, `done`, `failed`, `stopping`).
    pub state: String,
    /// Units done (apertures, frames, iterations).
    pub done: u64,
    /// Units in total (0 if unknown).
    pub total: u64,
    /// The items done (e.g. aperture indices), when the role has them.
    pub done_items: Vec<u64>,
    /// Named counters (frames sent, dropped, duplicates, malformed, ...).
    pub counters: BTreeMap<String, u64>,
    /// A line for people.
    pub message: String,
    /// Seconds since the process started.
    pub uptime_s: f64,
}

impl Message for ServiceStatus {
    const KIND: u16 = 0x0110;
    const NAME: &'static str = "cellsar.service_status";
    const SCHEMA_VERSION: u16 = 1;
}
