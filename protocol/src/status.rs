//! The status every service publishes per mission (kind `0x0110`).

use std::collections::BTreeMap;

use bridge::{Message, MissionId};
use serde::{Deserialize, Serialize};

use super::Role;

/// The state of a service for one mission, as every service publishes it (lowercase on the
/// wire: `"planning"`, `"planned"`, `"running"`, `"done"`, `"failed"`, `"stopping"`); a status
/// with any other state does not decode.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ServiceState {
    /// The planner is planning the mission.
    Planning,
    /// The planner published the mission's plan.
    Planned,
    /// The echo or the processor works on the mission.
    #[default]
    Running,
    /// The processor finished the mission (its metrics are out).
    Done,
    /// The processor gave the mission up.
    Failed,
    /// The service is stopping.
    Stopping,
}

impl ServiceState {
    /// The state as on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            ServiceState::Planning => "planning",
            ServiceState::Planned => "planned",
            ServiceState::Running => "running",
            ServiceState::Done => "done",
            ServiceState::Failed => "failed",
            ServiceState::Stopping => "stopping",
        }
    }
}

impl std::fmt::Display for ServiceState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Progress and counters of one service for one mission (`cellsar/<mission>/status/<role>`,
/// JSON). Shared by every cellsar service.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ServiceStatus {
    /// Role of the service.
    pub role: Role,
    /// Instance name.
    pub instance: String,
    /// Mission id.
    pub mission_id: MissionId,
    /// State.
    pub state: ServiceState,
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

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Every state is its lowercase name on the wire, and reads back; another name does not
    /// decode.
    #[test]
    fn states_are_their_lowercase_names_on_the_wire() {
        use ServiceState::*;
        for s in [Planning, Planned, Running, Done, Failed, Stopping] {
            let json = serde_json::to_string(&s).unwrap();
            assert_eq!(json, format!("\"{}\"", s.as_str()));
            assert_eq!(s.to_string(), s.as_str());
            assert_eq!(serde_json::from_str::<ServiceState>(&json).unwrap(), s);
        }
        assert!(serde_json::from_str::<ServiceState>("\"exploded\"").is_err());
        assert!(serde_json::from_str::<ServiceState>("\"Failed\"").is_err());
    }
}
