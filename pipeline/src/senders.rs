//! Who may send the launcher what, as far as it can tell: a service status only from an
//! instance of the role it claims, on that role's key; detections, images and metrics only
//! from a processor instance, on the key of the mission (and aperture) they claim. An instance is known once its liveliness token (`cellsar/alive/<role>/<instance>`)
//! was seen in the run.
//!
//! Without authentication this is a consistency check, not a proof: a peer that copies a live
//! processor's instance name (liveliness tokens are public) passes it. In a deployment with
//! mutual TLS and access control (`pipeline/deploy/tls/`) the router already refuses such a
//! peer: only the processor's certificate may publish detections, images, metrics and
//! processor status.

use std::collections::BTreeSet;

use crate::protocol::{keys, ApertureDetections, ApertureImage, MissionMetrics, ServiceStatus};

/// Messages of one kind refused before the log turns quiet about that kind (the rest are
/// counted and logged at debug level).
const LOUD_REFUSALS: u64 = 10;

/// Most instances the launcher knows at once: peers decide how many liveliness tokens appear,
/// so past this bound the instances whose tokens are gone are forgotten first, and a new
/// instance is not recorded while every known one is still alive.
pub const MAX_KNOWN_SENDERS: usize = 1024;

/// The instances of each role seen alive in a run, and what was refused.
#[derive(Debug, Default)]
pub struct Senders {
    seen: BTreeSet<(String, String)>,
    /// Messages refused as foreign (wrong key, unknown sender).
    pub refused: u64,
    refused_status: u64,
    refused_detections: u64,
    refused_images: u64,
    refused_metrics: u64,
    unrecorded: u64,
}

/// Messages refused as foreign, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Refused {
    /// Service statuses.
    pub status: u64,
    /// Aperture detections.
    pub detections: u64,
    /// Aperture images.
    pub images: u64,
    /// Mission metrics.
    pub metrics: u64,
}

impl Senders {
    /// Records that `instance` of `role` announced itself (its liveliness token was seen),
    /// within [`MAX_KNOWN_SENDERS`] (every known instance counted as still alive; see
    /// [`Senders::saw_within`]).
    pub fn saw(&mut self, role: &str, instance: &str) -> bool {
        self.saw_within(role, instance, |_, _| true)
    }

    /// Records that `instance` of `role` announced itself; at [`MAX_KNOWN_SENDERS`] the known
    /// instances that are no longer alive (`still_alive` tells) are forgotten first, and when
    /// none is, the new one is not recorded (counted in [`Senders::unrecorded`], logged).
    /// Returns whether it is known now.
    pub fn saw_within(
        &mut self,
        role: &str,
        instance: &str,
        still_alive: impl Fn(&str, &str) -> bool,
    ) -> bool {
        if self.knows(role, instance) {
            return true;
        }
        if self.seen.len() >= MAX_KNOWN_SENDERS {
            self.seen.retain(|(r, i)| still_alive(r, i));
        }
        if self.seen.len() >= MAX_KNOWN_SENDERS {
            self.unrecorded += 1;
            if self.unrecorded <= LOUD_REFUSALS {
                tracing::warn!(
                    role,
                    instance,
                    max = MAX_KNOWN_SENDERS,
                    "instance not recorded: as many known instances as the bound are alive"
                );
            }
            return false;
        }
        self.seen.insert((role.to_string(), instance.to_string()));
        true
    }

    /// Instances not recorded because [`MAX_KNOWN_SENDERS`] known ones were alive.
    pub fn unrecorded(&self) -> u64 {
        self.unrecorded
    }

    /// Whether `instance` of `role` announced itself in this run.
    pub fn knows(&self, role: &str, instance: &str) -> bool {
        self.seen
            .iter()
            .any(|(r, i)| r.as_str() == role && i.as_str() == instance)
    }

    /// A status received on `key`: accepted when the key names the role the status claims and
    /// that role's instance is known; otherwise refused (counted, logged), with the reason.
    pub fn status(&mut self, key: &str, s: &ServiceStatus) -> Result<(), String> {
        let why = match keys::status_role(key) {
            None => Some(format!("{key} is no status key")),
            Some(r) if r != s.role.as_str() => Some(format!("role {} on the key of {r}", s.role)),
            Some(_) if !self.knows(s.role.as_str(), &s.instance) => Some(format!(
                "{} {:?} never announced itself",
                s.role, s.instance
            )),
            Some(_) => None,
        };
        let why = why.map(|w| (w, &mut self.refused_status));
        Self::refuse_if(&mut self.refused, why, key, "status")
    }

    /// Detections received on `key`: accepted when they are on the key of the mission they
    /// claim and their processor instance is known.
    pub fn detections(&mut self, key: &str, d: &ApertureDetections) -> Result<(), String> {
        let why = match keys::detections(d.mission_id) {
            Ok(k) if k != key => Some(format!("detections of mission {} on {key}", d.mission_id)),
            Err(e) => Some(e.to_string()),
            Ok(_) => self.unknown_processor(&d.processor, || format!("aperture {}", d.aperture)),
        };
        let why = why.map(|w| (w, &mut self.refused_detections));
        Self::refuse_if(&mut self.refused, why, key, "detections")
    }

    /// An image received on `key`: accepted when it is on the key of the mission and aperture
    /// it claims and its processor instance is known.
    pub fn image(&mut self, key: &str, img: &ApertureImage) -> Result<(), String> {
        let why = match keys::image(img.mission_id, img.aperture as usize) {
            Ok(k) if k != key => Some(format!(
                "aperture {} of mission {} on {key}",
                img.aperture, img.mission_id
            )),
            Err(e) => Some(e.to_string()),
            Ok(_) => {
                self.unknown_processor(&img.processor, || format!("aperture {}", img.aperture))
            }
        };
        let why = why.map(|w| (w, &mut self.refused_images));
        Self::refuse_if(&mut self.refused, why, key, "image")
    }

    /// Metrics received on `key`: accepted when they are on the key of the mission they claim
    /// and their processor instance is known.
    pub fn metrics(&mut self, key: &str, m: &MissionMetrics) -> Result<(), String> {
        let why = match keys::metrics(m.mission_id) {
            Ok(k) if k != key => Some(format!("metrics of mission {} on {key}", m.mission_id)),
            Err(e) => Some(e.to_string()),
            Ok(_) => self.unknown_processor(&m.processor, || "metrics".to_string()),
        };
        let why = why.map(|w| (w, &mut self.refused_metrics));
        Self::refuse_if(&mut self.refused, why, key, "metrics")
    }

    /// Why a result of `what` claiming processor `instance` is refused: it never announced
    /// itself as a processor (`None`: it did).
    fn unknown_processor(&self, instance: &str, what: impl Fn() -> String) -> Option<String> {
        (!self.knows("processor", instance)).then(|| {
            format!(
                "{} from processor {instance:?}, which never announced itself",
                what()
            )
        })
    }

    /// Messages refused as foreign so far, by kind.
    pub fn refused_by_kind(&self) -> Refused {
        Refused {
            status: self.refused_status,
            detections: self.refused_detections,
            images: self.refused_images,
            metrics: self.refused_metrics,
        }
    }

    /// Counts a refusal (in `total` and in the kind's own counter) and logs it.
    fn refuse_if(
        total: &mut u64,
        why: Option<(String, &mut u64)>,
        key: &str,
        what: &str,
    ) -> Result<(), String> {
        let Some((why, of_kind)) = why else {
            return Ok(());
        };
        *total += 1;
        *of_kind += 1;
        if *of_kind <= LOUD_REFUSALS {
            tracing::warn!(key, reason = %why, "foreign {what} skipped");
        } else {
            tracing::debug!(key, reason = %why, "foreign {what} skipped");
        }
        Err(why)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::Role;
    use bridge::MissionId;

    fn status(role: &str, instance: &str) -> ServiceStatus {
        ServiceStatus {
            role: role.parse().unwrap(),
            instance: instance.into(),
            mission_id: MissionId(1),
            state: crate::protocol::ServiceState::Failed,
            ..ServiceStatus::default()
        }
    }

    #[test]
    fn a_status_must_come_from_a_known_instance_of_its_role_on_its_key() {
        let mut s = Senders::default();
        let key = keys::status(MissionId(1), Role::Processor).unwrap();
        // nobody announced yet
        assert!(s.status(&key, &status("processor", "p1")).is_err());
        s.saw("processor", "p1");
        s.saw("echo", "e1");
        assert!(s.status(&key, &status("processor", "p1")).is_ok());
        // another instance, another role's instance claiming the processor, the wrong key
        assert!(s.status(&key, &status("processor", "intruder")).is_err());
        assert!(s.status(&key, &status("processor", "e1")).is_err());
        let echo_key = keys::status(MissionId(1), Role::Echo).unwrap();
        assert!(s.status(&echo_key, &status("processor", "p1")).is_err());
        assert!(s.status(&echo_key, &status("echo", "e1")).is_ok());
        assert!(s.status("cellsar/x", &status("echo", "e1")).is_err());
        assert_eq!(s.refused, 5);
    }

    #[test]
    fn detections_must_come_from_a_known_processor() {
        let mut s = Senders::default();
        s.saw("processor", "p1");
        s.saw("echo", "e1");
        let key = keys::detections(MissionId(1)).unwrap();
        let d = |p: &str| ApertureDetections {
            mission_id: MissionId(1),
            aperture: 0,
            apertures: 1,
            landmark: None,
            landmark_detected: None,
            landmark_snr_db: None,
            detections: Vec::new(),
            false_alarms: 0,
            process_s: 0.0,
            processor: p.into(),
        };
        assert!(s.detections(&key, &d("p1")).is_ok());
        let e = s.detections(&key, &d("e1")).unwrap_err();
        assert!(e.contains("\"e1\""), "{e}");
        assert!(s.detections(&key, &d("intruder")).is_err());
        // a known processor's detections of another mission on this mission's key
        let other = ApertureDetections {
            mission_id: MissionId(2),
            ..d("p1")
        };
        assert!(s.detections(&key, &other).is_err());
        assert_eq!(s.refused, 3);
        assert_eq!(s.refused_by_kind().detections, 3);
    }

    /// An image or metrics must come from a known processor instance (not another role's,
    /// not one that never announced itself) and on the key of the mission and aperture they
    /// claim; each refusal is counted by kind.
    #[test]
    fn images_and_metrics_must_come_from_a_known_processor_on_their_key() {
        let mut s = Senders::default();
        s.saw("processor", "p1");
        s.saw("echo", "e1");
        let m = MissionId(1);
        let img = |p: &str, aperture: u32| ApertureImage {
            mission_id: m,
            aperture,
            nx: 1,
            ny: 1,
            centre_m: [0.0; 2],
            spacing_m: 1.0,
            multilook: vec![1.0],
            markers: Vec::new(),
            processor: p.into(),
        };
        let key0 = keys::image(m, 0).unwrap();
        assert!(s.image(&key0, &img("p1", 0)).is_ok());
        let e = s.image(&key0, &img("e1", 0)).unwrap_err();
        assert!(e.contains("processor \"e1\", which never announced"), "{e}");
        assert!(s.image(&key0, &img("intruder", 0)).is_err());
        // aperture 1's image on aperture 0's key, another mission's on this one's
        let e = s.image(&key0, &img("p1", 1)).unwrap_err();
        assert!(e.contains("aperture 1 of mission"), "{e}");
        let other = ApertureImage {
            mission_id: MissionId(2),
            ..img("p1", 0)
        };
        assert!(s.image(&key0, &other).is_err());
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../docs/example/main-job/metrics.json");
        let metrics: radar_sim::run::Metrics =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        let mm = |p: &str, mission_id: MissionId| MissionMetrics {
            mission_id,
            apertures: 1,
            metrics: metrics.clone(),
            processor: p.into(),
        };
        let mkey = keys::metrics(m).unwrap();
        assert!(s.metrics(&mkey, &mm("p1", m)).is_ok());
        assert!(s.metrics(&mkey, &mm("e1", m)).is_err());
        assert!(s.metrics(&mkey, &mm("intruder", m)).is_err());
        assert!(s.metrics(&mkey, &mm("p1", MissionId(2))).is_err());
        assert!(s.metrics(&key0, &mm("p1", m)).is_err());
        assert_eq!(
            s.refused_by_kind(),
            Refused {
                status: 0,
                detections: 0,
                images: 4,
                metrics: 4
            }
        );
        assert_eq!(s.refused, 8);
    }

    /// A flood of announced instances keeps the known set within its bound: those whose
    /// tokens are gone make room; with every known one alive, new ones are not recorded.
    #[test]
    fn known_instances_are_bounded_the_gone_forgotten_first() {
        let mut s = Senders::default();
        assert!(s.saw("processor", "p1"));
        for n in 0..MAX_KNOWN_SENDERS * 3 {
            s.saw("echo", &format!("e{n}"));
            assert!(s.seen.len() <= MAX_KNOWN_SENDERS);
        }
        assert_eq!(s.unrecorded(), (MAX_KNOWN_SENDERS * 2 + 1) as u64);
        assert!(s.knows("processor", "p1"));
        // the flood's tokens gone: a new instance makes room, the live processor stays
        let alive = |r: &str, i: &str| r == "processor" && i == "p1";
        assert!(s.saw_within("processor", "p2", alive));
        assert!(s.knows("processor", "p1") && s.knows("processor", "p2"));
        assert_eq!(s.seen.len(), 2);
    }
}
