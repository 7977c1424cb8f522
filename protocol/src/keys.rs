//! Every key expression of the pipeline, defined once. Services, the launcher and the tests
//! build their keys here; the transport's own keys (liveliness `cellsar/alive/<role>/<instance>`,
//! bridge counters) are in [`bridge::keys`].
//!
//! ```text
//! cellsar/plan                      queryable of the planner: PlanRequest -> Plan | Refusal
//! cellsar/<m>/plan                  each plan (bincode); also answered to PlanLookup queries
//! cellsar/<m>/plan/summary          the plan's summary (JSON)
//! cellsar/<m>/status/<role>         ServiceStatus of each service (JSON)
//! cellsar/<m>/echo                  IQ frames: iceoryx2 service, and the same key on Zenoh
//!                                   when the bridge carries them
//! cellsar/<m>/echo/request          queryable of the echo: ApertureRequest -> RequestAck
//! cellsar/<m>/frames                FrameInfo per frame sent (droppable)
//! cellsar/<m>/detections            ApertureDetections per aperture (JSON), naming the processor
//! cellsar/<m>/image/<n>             ApertureImage of aperture n, naming the processor
//! cellsar/<m>/metrics               MissionMetrics when every aperture is done, naming the
//!                                   processor
//! cellsar/<m>/results               queryable of the processor: ResultRequest -> ResultAck
//! ```
//! `<m>` is the mission id, 16 hex digits ([`super::plan::mission_id`]).

use bridge::keys::{mission, KeyError};
use bridge::MissionId;

use super::Role;

/// Key of the plan queryable.
pub const PLAN: &str = "cellsar/plan";
/// Selector of every mission's plan (plan lookups by late joiners).
pub const ALL_PLANS: &str = "cellsar/*/plan";
/// Selector of every mission's echo request queryable.
pub const ALL_ECHO_REQUESTS: &str = "cellsar/*/echo/request";
/// Selector of every mission's IQ frames on Zenoh.
pub const ALL_ECHO: &str = "cellsar/*/echo";
/// Selector of every mission's result queryable.
pub const ALL_RESULTS: &str = "cellsar/*/results";
/// Selector of every mission's detections.
pub const ALL_DETECTIONS: &str = "cellsar/*/detections";
/// Selector of every mission's images.
pub const ALL_IMAGES: &str = "cellsar/*/image/*";
/// Selector of every mission's metrics.
pub const ALL_METRICS: &str = "cellsar/*/metrics";
/// Selector of every mission's service status.
pub const ALL_STATUS: &str = "cellsar/*/status/*";

/// `cellsar/<m>/plan`.
pub fn plan(id: MissionId) -> Result<String, KeyError> {
    mission(id, "plan")
}
/// `cellsar/<m>/plan/summary`.
pub fn plan_summary(id: MissionId) -> Result<String, KeyError> {
    mission(id, "plan/summary")
}
/// `cellsar/<m>/status/<role>`.
pub fn status(id: MissionId, role: Role) -> Result<String, KeyError> {
    mission(id, &format!("status/{role}"))
}
/// `cellsar/<m>/echo`: the IQ frame service (iceoryx2) and its Zenoh key.
pub fn echo(id: MissionId) -> Result<String, KeyError> {
    mission(id, "echo")
}
/// `cellsar/<m>/echo/request`.
pub fn echo_request(id: MissionId) -> Result<String, KeyError> {
    mission(id, "echo/request")
}
/// `cellsar/<m>/frames`.
pub fn frames(id: MissionId) -> Result<String, KeyError> {
    mission(id, "frames")
}
/// `cellsar/<m>/detections`.
pub fn detections(id: MissionId) -> Result<String, KeyError> {
    mission(id, "detections")
}
/// `cellsar/<m>/image/<n>`.
pub fn image(id: MissionId, aperture: usize) -> Result<String, KeyError> {
    mission(id, &format!("image/{aperture}"))
}
/// `cellsar/<m>/metrics`.
pub fn metrics(id: MissionId) -> Result<String, KeyError> {
    mission(id, "metrics")
}
/// `cellsar/<m>/results`.
pub fn results(id: MissionId) -> Result<String, KeyError> {
    mission(id, "results")
}
/// The role of a status key `cellsar/<m>/status/<role>`; `None` for any other key.
pub fn status_role(key: &str) -> Option<&str> {
    match key.split('/').collect::<Vec<_>>().as_slice() {
        ["cellsar", m, "status", role] if !m.is_empty() && !role.is_empty() => Some(*role),
        _ => None,
    }
}
/// The bridge route that carries the echo frames of mission `id` out to Zenoh
/// (`cellsar/<m>/echo@out`).
pub fn echo_route_out(id: MissionId) -> Result<String, KeyError> {
    Ok(format!("{}@out", echo(id)?))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Every selector matches the key its builder makes.
    #[test]
    fn selectors_match_their_keys() {
        use bridge::zenoh::key_expr::KeyExpr;
        let id = MissionId(0xff);
        let m = |sel: &str, key: String| {
            let s = KeyExpr::try_from(sel.to_string()).unwrap();
            let k = KeyExpr::try_from(key.clone()).unwrap();
            assert!(s.intersects(&k), "{sel} does not match {key}");
        };
        m(ALL_PLANS, plan(id).unwrap());
        m(ALL_ECHO_REQUESTS, echo_request(id).unwrap());
        m(ALL_ECHO, echo(id).unwrap());
        m(ALL_RESULTS, results(id).unwrap());
        m(ALL_DETECTIONS, detections(id).unwrap());
        m(ALL_IMAGES, image(id, 3).unwrap());
        m(ALL_METRICS, metrics(id).unwrap());
        m(ALL_STATUS, status(id, Role::Echo).unwrap());
        assert_eq!(image(id, 3).unwrap(), "cellsar/00000000000000ff/image/3");
        assert_eq!(
            echo_route_out(id).unwrap(),
            "cellsar/00000000000000ff/echo@out"
        );
        assert_eq!(status_role(&status(id, Role::Echo).unwrap()), Some("echo"));
        for bad in [
            "cellsar/1/status",
            "cellsar/1/status/a/b",
            "x/1/status/a",
            "cellsar//status/a",
        ] {
            assert_eq!(status_role(bad), None, "{bad}");
        }
    }
}
