//! Who may send the launcher what, as far as it can tell: a service status only from an
//! instance of the role it claims, on that role's key; detections only from a processor
//! instance. An instance is known once its liveliness token (`cellsar/alive/<role>/<instance>`)
//! was seen in the run.
//!
//! Without authentication this is a consistency check, not a proof: a peer that copies a live
//! processor's instance name (liveliness tokens are public) passes it. In a deployment with
//! mutual TLS and access control (`pipeline/deploy/tls/`) the router already refuses such a
//! peer: only the processor's certificate may publish detections and processor status.

use std::collections::BTreeSet;

use crate::protocol::{keys, ApertureDetections, ServiceStatus};

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
    unrecorded: u64,
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
            Some(r) if r != s.role => Some(format!("role {:?} on the key of {r}", s.role)),
            Some(_) if !self.knows(&s.role, &s.instance) => Some(format!(
                "{} {:?} never announced itself",
                s.role, s.instance
            )),
            Some(_) => None,
        };
        let why = why.map(|w| (w, &mut self.refused_status));
        Self::refuse_if(&mut self.refused, why, key, "status")
    }

    /// Detections received on `key`: accepted when their processor instance is known.
    pub fn detections(&mut self, key: &str, d: &ApertureDetections) -> Result<(), String> {
        let why = (!self.knows("processor", &d.processor)).then(|| {
            format!(
                "aperture {} from processor {:?}, which never announced itself",
                d.aperture, d.processor
            )
        });
        let why = why.map(|w| (w, &mut self.refused_detections));
        Self::refuse_if(&mut self.refused, why, key, "detections")
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
    use bridge::MissionId;

    fn status(role: &str, instance: &str) -> ServiceStatus {
        ServiceStatus {
            role: role.into(),
            instance: instance.into(),
            mission_id: MissionId(1),
            state: "failed".into(),
            ..ServiceStatus::default()
        }
    }

    #[test]
    fn a_status_must_come_from_a_known_instance_of_its_role_on_its_key() {
        let mut s = Senders::default();
        let key = keys::status(MissionId(1), "processor").unwrap();
        // nobody announced yet
        assert!(s.status(&key, &status("processor", "p1")).is_err());
        s.saw("processor", "p1");
        s.saw("echo", "e1");
        assert!(s.status(&key, &status("processor", "p1")).is_ok());
        // another instance, another role's instance claiming the processor, the wrong key
        assert!(s.status(&key, &status("processor", "intruder")).is_err());
        assert!(s.status(&key, &status("processor", "e1")).is_err());
        let echo_key = keys::status(MissionId(1), "echo").unwrap();
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
        assert_eq!(s.refused, 2);
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
