//! The status board: each service's [`ServiceStatus`] per mission.

use std::sync::Mutex;
use std::time::Instant;

use bridge::net::PublishOptions;
use bridge::zenoh::qos::CongestionControl;
use bridge::{MissionId, ZenohNode};

use super::bounded::{Lru, MAX_MISSION_PUBLISHERS};
use crate::protocol::keys as pkeys;
use crate::protocol::{Role, ServiceState, ServiceStatus};

/// Publishes [`ServiceStatus`] per mission (JSON, congestion control `Drop`: a frozen reader
/// never stalls a service). At most [`MAX_MISSION_PUBLISHERS`] publishers are kept, the least
/// recently used undeclared first.
pub struct StatusBoard {
    role: Role,
    instance: String,
    started: Instant,
    pubs: Mutex<Lru<bridge::net::TypedPublisher<ServiceStatus>>>,
}

impl StatusBoard {
    /// A board for `role`/`instance`.
    pub fn new(role: Role, instance: &str) -> Self {
        StatusBoard {
            role,
            instance: instance.to_string(),
            started: Instant::now(),
            pubs: Mutex::new(Lru::with_count(MAX_MISSION_PUBLISHERS)),
        }
    }

    /// A status with role, instance, mission and uptime filled in.
    pub fn status(&self, mission_id: MissionId, state: ServiceState) -> ServiceStatus {
        ServiceStatus {
            role: self.role,
            instance: self.instance.clone(),
            mission_id,
            state,
            uptime_s: self.uptime_s(),
            ..Default::default()
        }
    }

    /// How many per-mission publishers are held.
    #[cfg(test)]
    pub(super) fn publishers(&self) -> usize {
        self.pubs.lock().map(|p| p.len()).unwrap_or_default()
    }

    /// Whether mission `id`'s publisher is held (its use not noted).
    #[cfg(test)]
    pub(super) fn has_publisher(&self, id: MissionId) -> bool {
        self.pubs
            .lock()
            .map(|p| p.peek(id).is_some())
            .unwrap_or_default()
    }

    /// Seconds since the board was made (the service's uptime).
    pub(super) fn uptime_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// Publishes `status` on `cellsar/<mission>/status/<role>`; failures are logged, not fatal.
    pub fn publish(&self, node: &ZenohNode, status: &ServiceStatus) {
        let Ok(mut pubs) = self.pubs.lock() else {
            return;
        };
        if pubs.get(status.mission_id).is_none() {
            let made = pkeys::status(status.mission_id, self.role)
                .map_err(bridge::NetError::from)
                .and_then(|key| {
                    node.publisher::<ServiceStatus>(
                        &key,
                        PublishOptions {
                            mission_id: status.mission_id,
                            congestion_control: CongestionControl::Drop,
                            ..PublishOptions::json()
                        },
                    )
                });
            match made {
                Ok(p) => {
                    pubs.insert(status.mission_id, p, 0);
                }
                Err(e) => {
                    tracing::warn!(error = %e, "status publisher");
                    return;
                }
            }
        }
        let Some(p) = pubs.get(status.mission_id) else {
            return;
        };
        if let Err(e) = p.put(status) {
            tracing::debug!(error = %e, "status not published");
        }
    }
}
