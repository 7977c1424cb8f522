//! What the processor publishes: each aperture's detections and image, each mission's metrics
//! (again on request), the status of every mission and, at the end, its counters.

use std::collections::HashMap;

use bridge::envelope::Meta;
use bridge::net::{PublishOptions, TypedPublisher};
use bridge::MissionId;

use super::context::detections_message;
use super::proc::Proc;
use crate::protocol::keys as pkeys;
use crate::protocol::{
    ApertureDetections, ApertureImage, MissionMetrics, ResultAck, ResultRequest, ServiceState,
};
use crate::services::admission::requested_apertures;
use crate::services::radar::ServiceError;

/// The processor's result publishers, made on first use.
#[derive(Default)]
pub(super) struct Publishers {
    /// Detections, per mission.
    pub(super) detections: HashMap<MissionId, TypedPublisher<ApertureDetections>>,
    /// Images, per mission and aperture.
    pub(super) images: HashMap<(MissionId, usize), TypedPublisher<ApertureImage>>,
    /// Metrics, per mission.
    pub(super) metrics: HashMap<MissionId, TypedPublisher<MissionMetrics>>,
}

/// At most this many apertures are named missing in the answer to a request for a mission the
/// processor does not hold.
const MAX_UNKNOWN_MISSING: usize = 4096;

impl Proc<'_> {
    /// Publishes aperture `k` of mission `i`: its detections and its image.
    pub(super) fn publish_outcome(&mut self, i: usize, k: usize) {
        // the image names this instance (one restored from the state directory may have been
        // made by an instance before a restart)
        if let Some(o) = self.runs[i].outcomes.get_mut(&k) {
            if o.image.processor != self.args.instance {
                o.image.processor.clone_from(&self.args.instance);
            }
        }
        let run = &self.runs[i];
        let id = run.ctx.base.mission_id;
        let Some(o) = run.outcomes.get(&k) else {
            return;
        };
        let n = run.ctx.base.apertures.len();
        let msg = detections_message(id, o, n, &self.args.instance);
        let meta = Meta {
            mission_id: id,
            seq: k as u64,
            time_unix_ns: 0,
        };
        if !self.publishers.detections.contains_key(&id) {
            let made = pkeys::detections(id)
                .map_err(ServiceError::from)
                .and_then(|key| {
                    Ok(self.node.publisher::<ApertureDetections>(
                        &key,
                        PublishOptions {
                            mission_id: id,
                            ..PublishOptions::json()
                        },
                    )?)
                });
            match made {
                Ok(p) => {
                    self.publishers.detections.insert(id, p);
                }
                Err(e) => tracing::warn!(error = %e, "detections publisher"),
            }
        }
        if let Some(p) = self.publishers.detections.get(&id) {
            if let Err(e) = p.put_with(&msg, meta) {
                tracing::warn!(error = %e, "detections not published");
            }
        }
        if !self.publishers.images.contains_key(&(id, k)) {
            let made = pkeys::image(id, k)
                .map_err(ServiceError::from)
                .and_then(|key| {
                    Ok(self.node.publisher::<ApertureImage>(
                        &key,
                        PublishOptions {
                            mission_id: id,
                            ..PublishOptions::default()
                        },
                    )?)
                });
            match made {
                Ok(p) => {
                    self.publishers.images.insert((id, k), p);
                }
                Err(e) => tracing::warn!(error = %e, "image publisher"),
            }
        }
        if let Some(p) = self.publishers.images.get(&(id, k)) {
            if let Err(e) = p.put_with(&o.image, meta) {
                tracing::warn!(error = %e, "image not published");
            }
        }
    }

    /// Publishes the metrics of mission `i`, once done.
    pub(super) fn publish_metrics(&mut self, i: usize) {
        if let Some(m) = self.runs[i].metrics.as_mut() {
            if m.processor != self.args.instance {
                m.processor.clone_from(&self.args.instance);
            }
        }
        let run = &self.runs[i];
        let id = run.ctx.base.mission_id;
        let Some(m) = &run.metrics else { return };
        if !self.publishers.metrics.contains_key(&id) {
            let made = pkeys::metrics(id)
                .map_err(ServiceError::from)
                .and_then(|key| {
                    Ok(self.node.publisher::<MissionMetrics>(
                        &key,
                        PublishOptions {
                            mission_id: id,
                            ..PublishOptions::default()
                        },
                    )?)
                });
            match made {
                Ok(p) => {
                    self.publishers.metrics.insert(id, p);
                }
                Err(e) => tracing::warn!(error = %e, "metrics publisher"),
            }
        }
        if let Some(p) = self.publishers.metrics.get(&id) {
            if let Err(e) = p.put_with(
                m,
                Meta {
                    mission_id: id,
                    ..Meta::default()
                },
            ) {
                tracing::warn!(error = %e, "metrics not published");
            }
        }
    }

    /// Publishes again the results a [`ResultRequest`] asks for; the answer says which were
    /// and which are not held.
    pub(super) fn republish(&mut self, req: &ResultRequest) -> ResultAck {
        let mut ack = ResultAck {
            republished: Vec::new(),
            missing: Vec::new(),
            metrics: false,
        };
        let Some(i) = self.run_index(req.mission_id) else {
            // bounded: a request cannot make the answer larger than the mission could be
            ack.missing = req
                .apertures
                .iter()
                .copied()
                .take(MAX_UNKNOWN_MISSING)
                .collect();
            return ack;
        };
        let n = self.runs[i].ctx.base.apertures.len();
        if req.apertures.len() > n {
            tracing::warn!(mission = %req.mission_id, asked = req.apertures.len(), apertures = n,
                "result request names more apertures than the mission has");
        }
        for k in requested_apertures(&req.apertures, n) {
            if self.runs[i].outcomes.contains_key(&(k as usize)) {
                self.publish_outcome(i, k as usize);
                self.report.republished += 1;
                ack.republished.push(k);
            } else {
                ack.missing.push(k);
            }
        }
        if req.metrics && self.runs[i].metrics.is_some() {
            self.publish_metrics(i);
            ack.metrics = true;
        }
        ack
    }

    /// Publishes the status of every mission.
    pub(super) fn publish_status(&self) {
        for run in &self.runs {
            let id = run.ctx.base.mission_id;
            let state = if run.metrics.is_some() {
                ServiceState::Done
            } else if run.failed.is_some() {
                ServiceState::Failed
            } else {
                ServiceState::Running
            };
            let mut s = self.board.status(id, state);
            s.total = run.ctx.base.apertures.len() as u64;
            s.done = run.outcomes.len() as u64;
            s.done_items = run.outcomes.keys().map(|k| *k as u64).collect();
            let r = &self.report;
            for (k, v) in status_counters(r, self.malformed) {
                s.counters.insert(k.to_string(), v);
            }
            s.counters
                .insert("metrics".to_string(), u64::from(run.metrics.is_some()));
            if let Some(f) = &run.failed {
                s.message = format!("failed: {f}");
                self.board.publish(self.node, &s);
                continue;
            }
            s.message = format!(
                "{}/{} apertures, assembling {:?}, {} frames ({} duplicates, {} lost in transport)",
                s.done,
                s.total,
                run.assembling.keys().collect::<Vec<_>>(),
                r.frames,
                r.duplicates,
                r.transport_lost
            );
            self.board.publish(self.node, &s);
        }
    }

    /// Logs the final counters (with the malformed plans and result requests counted by their
    /// subscribers) as the processor stops.
    pub(super) fn log_final_counters(&self, plans_malformed: u64, result_requests_malformed: u64) {
        let r = &self.report;
        tracing::info!(
            final_counters = true,
            apertures = r.apertures,
            restored = r.restored,
            missions = r.missions,
            frames = r.frames,
            used = r.used,
            duplicates = r.duplicates,
            unsolicited = r.unsolicited,
            bad = r.bad,
            forged = r.forged,
            dropped = r.dropped,
            transport_lost = r.transport_lost,
            frames_malformed = r.frames_malformed,
            requests = r.requests,
            resends = r.resends,
            request_errors = r.request_errors,
            republished = r.republished,
            plans_refused = r.plans_refused,
            plans_inconsistent = r.plans_inconsistent,
            evicted = r.evicted,
            state_errors = r.state_errors,
            plans_malformed,
            result_requests_malformed,
            lookups_malformed = self.cache.malformed(),
            "processor stopping"
        );
    }
}

/// The processor's counters in a mission's status. `malformed` counts the messages that arrived
/// and failed to decode or validate: the frames (`report.frames_malformed`) and the plans,
/// result requests and plan lookups (`other_malformed`); `transport_lost` counts only the frames
/// the transport lost (sequence gaps, a full subscriber queue). Neither includes the other.
pub(super) fn status_counters(
    report: &super::ProcessReport,
    other_malformed: u64,
) -> [(&'static str, u64); 16] {
    let r = report;
    [
        ("apertures", r.apertures),
        ("restored", r.restored),
        ("frames", r.frames),
        ("used", r.used),
        ("duplicates", r.duplicates),
        ("unsolicited", r.unsolicited),
        ("bad", r.bad),
        ("forged", r.forged),
        ("dropped", r.dropped),
        ("transport_lost", r.transport_lost),
        ("frames_malformed", r.frames_malformed),
        ("requests", r.requests),
        ("resends", r.resends),
        ("request_errors", r.request_errors),
        ("republished", r.republished),
        (
            "malformed",
            other_malformed.saturating_add(r.frames_malformed),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::status_counters;
    use crate::services::process::ProcessReport;

    /// Frames lost in transport are not malformed messages, and malformed frames are not lost
    /// ones: each count shows under its own name only.
    #[test]
    fn lost_and_malformed_frames_are_counted_apart_in_the_status() {
        let report = ProcessReport {
            transport_lost: 3,
            frames_malformed: 5,
            dropped: 7,
            ..ProcessReport::default()
        };
        let c: std::collections::HashMap<_, _> = status_counters(&report, 11).into_iter().collect();
        assert_eq!(c["transport_lost"], 3);
        assert_eq!(c["frames_malformed"], 5);
        assert_eq!(c["malformed"], 5 + 11);
        assert_eq!(c["dropped"], 7);
        // nothing lost, nothing malformed: a healthy run on a loaded machine still shows 0
        let lossy = ProcessReport {
            transport_lost: 9,
            ..ProcessReport::default()
        };
        let c: std::collections::HashMap<_, _> = status_counters(&lossy, 0).into_iter().collect();
        assert_eq!((c["malformed"], c["transport_lost"]), (0, 9));
    }
}
