//! The planner's messages (kinds `0x0100..=0x01ff`): plan requests and their options, plans,
//! plan lookups and plan summaries, and the mission id every process derives from a mission.

use bridge::keys::KeyError;
use bridge::{Message, MissionId};
use planner::evaluate::{Dynamics, ResolutionMode};
use planner::summary::Summary;
use planner::{Mission, MissionFile, PlanOptions, PlanResult, Scheme};
use serde::{Deserialize, Serialize};

use super::keys;

/// Largest plan message accepted (a plan of a long mission with its iteration records).
pub const MAX_PLAN_BYTES: usize = 64 << 20;

/// A plan request whose options are invalid; the message names the field
/// (`options.tolerance`, ...).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct BadRequest(pub String);

/// Options of a plan request; every field optional (defaults: [`PlanOptions::for_scheme`] of the
/// scheme, so the same defaults as `cellsar-planner plan`, the Python package and the library).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanRequestOptions {
    /// `exact` (default), `paper`, `baseline` or `baseline-exact`.
    #[serde(default)]
    pub scheme: Option<Scheme>,
    /// Largest number of SCA/BCD iterations (≥ 1).
    #[serde(default)]
    pub max_iterations: Option<usize>,
    /// Relative objective change that stops the iterations (finite, > 0).
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// `general` (the default for `exact`, [`planner::DEFAULT_RESOLUTION`]: the general cell as
    /// a best effort) or `paper` (the least-energy plan; the default of the comparison schemes).
    #[serde(default)]
    pub resolution: Option<ResolutionMode>,
    /// Under `general` with `exact`: refuse instead of the best effort (default false); refused
    /// with `paper` or a comparison scheme, which would ignore it.
    #[serde(default)]
    pub strict_resolution: Option<bool>,
    /// Best effort: at most this many percent more energy than the least-energy plan (≥ 0);
    /// refused where `strict_resolution` is.
    #[serde(default)]
    pub max_extra_energy_pct: Option<f64>,
    /// `vehicle` (the acceleration limit of the mission's `max_accel_mps2` between slots, from
    /// its start velocity, and its `max_jerk_mps3` when it sets one, each less the mission's
    /// margin) or `paper` (the velocity may jump); default: the scheme's
    /// ([`Scheme::default_dynamics`]); `vehicle` is refused with `paper` and `baseline`.
    #[serde(default)]
    pub dynamics: Option<Dynamics>,
}

impl PlanRequestOptions {
    /// The planner options, checked; errors name the field (`options.tolerance`, ...).
    pub fn to_plan_options(&self) -> Result<PlanOptions, BadRequest> {
        let mut o = PlanOptions::for_scheme(self.scheme.unwrap_or(PlanOptions::default().scheme));
        if let Some(n) = self.max_iterations {
            if n == 0 {
                return Err(BadRequest(
                    "options.max_iterations: must be at least 1".into(),
                ));
            }
            o.max_iterations = n;
        }
        if let Some(t) = self.tolerance {
            if !(t.is_finite() && t > 0.0) {
                return Err(BadRequest(format!(
                    "options.tolerance: {t} must be a finite number > 0"
                )));
            }
            o.tolerance = t;
        }
        if let Some(r) = self.resolution {
            o.resolution = r;
        }
        if let Some(strict) = self.strict_resolution {
            o.strict_resolution = strict;
        }
        if let Some(pct) = self.max_extra_energy_pct {
            if !(pct.is_finite() && pct >= 0.0) {
                return Err(BadRequest(format!(
                    "options.max_extra_energy_pct: {pct} must be a finite percentage >= 0"
                )));
            }
            o.max_extra_energy_pct = Some(pct);
        }
        if let Some(d) = self.dynamics {
            if !o.scheme.supports(d) {
                return Err(BadRequest(format!(
                    "options.dynamics: {d} applies to the exact-geometry schemes (exact, \
                     baseline-exact) only, not to {}",
                    o.scheme
                )));
            }
            o.dynamics = d;
        }
        o.check_best_effort()
            .map_err(|e| BadRequest(format!("options.{e}")))?;
        // the pipeline flies a free mission's altitude per slot (its track is the plan's
        // `altitudes_m`), so `exact` plans one; the other schemes still refuse the mission
        o.altitude_profile = true;
        Ok(o)
    }
}

/// A request to plan a mission (`cellsar/plan`). As JSON:
/// `{"mission": {"name": ..., "params": {...}, "landmarks": {...}}, "options": {...}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanRequest {
    /// The mission, as in a mission file.
    pub mission: MissionFile,
    /// Planner options.
    #[serde(default)]
    pub options: PlanRequestOptions,
}

impl Message for PlanRequest {
    const KIND: u16 = 0x0101;
    const NAME: &'static str = "planner.plan_request";
    /// 2: the mission's `[params]` gain `max_jerk_mps3`, `resolution_margin_pct`,
    /// `accel_margin_pct` and `jerk_margin_pct` (the binary layout of [`MissionFile`]; a JSON
    /// request may leave them out).
    const SCHEMA_VERSION: u16 = 2;
}

/// Fields whose types need a self-describing format (the planner's adjacently tagged enums, NaN
/// values): CBOR bytes inside bincode; the value itself in JSON.
mod self_describing {
    use serde::de::{DeserializeOwned, Error as _, Visitor};
    use serde::ser::Error as _;
    use serde::{Deserializer, Serialize, Serializer};

    pub fn serialize<T: Serialize, S: Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            v.serialize(s)
        } else {
            let mut buf = Vec::new();
            ciborium::into_writer(v, &mut buf).map_err(S::Error::custom)?;
            s.serialize_bytes(&buf)
        }
    }

    struct Bytes;

    impl<'de> Visitor<'de> for Bytes {
        type Value = Vec<u8>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("CBOR bytes")
        }
        fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Vec<u8>, E> {
            Ok(v.to_vec())
        }
        fn visit_byte_buf<E: serde::de::Error>(self, v: Vec<u8>) -> Result<Vec<u8>, E> {
            Ok(v)
        }
    }

    pub fn deserialize<'de, T: DeserializeOwned, D: Deserializer<'de>>(
        d: D,
    ) -> Result<T, D::Error> {
        if d.is_human_readable() {
            T::deserialize(d)
        } else {
            let buf = d.deserialize_byte_buf(Bytes)?;
            ciborium::from_reader(buf.as_slice()).map_err(D::Error::custom)
        }
    }
}

/// A plan: the resolved mission, the planner's full result and its summary. In the binary form
/// `result` and `summary` travel as CBOR (their enums and NaN values need a self-describing
/// format); in JSON they are plain values (NaN as `null`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The mission id ([`mission_id`] of `mission`).
    pub mission_id: MissionId,
    /// The resolved mission (explicit landmark windows): `Mission::from_file_struct` gives it back.
    pub mission: MissionFile,
    /// The options it was planned with.
    pub options: PlanRequestOptions,
    /// The planner's result (trajectory, exact evaluation, histories).
    #[serde(with = "self_describing")]
    pub result: PlanResult,
    /// The summary (as in `summary.json`).
    #[serde(with = "self_describing")]
    pub summary: Summary,
    /// Instance of the planner that made it.
    pub planner: String,
}

impl Message for Plan {
    const KIND: u16 = 0x0102;
    const NAME: &'static str = "planner.plan";
    /// 2: its mission's `[params]` gain `max_jerk_mps3` and the margins, as
    /// [`PlanRequest`]'s (plans stored by a planner before are not read back).
    const SCHEMA_VERSION: u16 = 2;
}

impl Plan {
    /// The validated mission.
    pub fn mission(&self) -> Result<Mission, planner::MissionError> {
        Mission::from_file_struct(&self.mission)
    }

    /// The key the plan is published on: `cellsar/<mission>/plan`.
    pub fn key(&self) -> Result<String, KeyError> {
        keys::plan(self.mission_id)
    }

    /// Why the plan's mission id is not the one its mission and options give ([`mission_id`],
    /// recomputed), which every process keys the mission by; `None` when it is.
    pub fn id_problem(&self) -> Option<String> {
        let id = mission_id(&self.mission, &self.options);
        (self.mission_id != id).then(|| {
            format!(
                "mission id {} where its mission and options give {id}",
                self.mission_id
            )
        })
    }
}

/// A request for known plans (sent to `cellsar/<mission>/plan` or [`keys::ALL_PLANS`]).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlanLookup {}

impl Message for PlanLookup {
    const KIND: u16 = 0x0103;
    const NAME: &'static str = "planner.plan_lookup";
    const SCHEMA_VERSION: u16 = 1;
}

/// The summary of a published plan (`cellsar/<mission>/plan/summary`, JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanSummary {
    /// Mission id.
    pub mission_id: MissionId,
    /// Mission name.
    pub mission: String,
    /// Number of landmark windows.
    pub windows: usize,
    /// The summary.
    #[serde(with = "self_describing")]
    pub summary: Summary,
}

impl Message for PlanSummary {
    const KIND: u16 = 0x0104;
    const NAME: &'static str = "planner.plan_summary";
    const SCHEMA_VERSION: u16 = 1;
}

/// The mission id of a plan of a (resolved) mission file with request `options`: FNV-1a of the
/// file's JSON form, followed by the options' JSON form unless they are the defaults. Equal
/// requests get equal ids in every process; a changed mission, or the same mission planned with
/// other options (another resolution, say), gets a new one, so that two plans of one mission do
/// not replace each other in the caches and processors. Default options keep the mission's own
/// id (and the ids of plans kept in a state directory).
pub fn mission_id(file: &MissionFile, options: &PlanRequestOptions) -> MissionId {
    let mut text =
        serde_json::to_string(file).unwrap_or_else(|_| file.name.clone().unwrap_or_default());
    if *options != PlanRequestOptions::default() {
        text.push_str(&serde_json::to_string(options).unwrap_or_default());
    }
    MissionId::from_name(&text)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// A request that names no resolution gets the library's default for its scheme, as
    /// `cellsar-planner plan` and the Python package do; best-effort options that the plan
    /// would ignore are refused with the library's message, the field named.
    #[test]
    fn request_defaults_and_refusals_are_the_librarys() {
        let none = PlanRequestOptions::default();
        // ... and plans a free mission's altitudes, as they do
        assert_eq!(
            none.to_plan_options().unwrap(),
            PlanOptions {
                altitude_profile: true,
                ..PlanOptions::default()
            }
        );
        assert_eq!(
            none.to_plan_options().unwrap().resolution,
            planner::DEFAULT_RESOLUTION
        );
        for scheme in Scheme::ALL {
            let o = PlanRequestOptions {
                scheme: Some(scheme),
                ..Default::default()
            };
            assert_eq!(
                o.to_plan_options().unwrap(),
                PlanOptions {
                    altitude_profile: true,
                    ..PlanOptions::for_scheme(scheme)
                }
            );
        }
        let paper_strict = PlanRequestOptions {
            resolution: Some(ResolutionMode::Paper),
            strict_resolution: Some(true),
            ..Default::default()
        };
        let e = paper_strict.to_plan_options().unwrap_err();
        assert_eq!(
            e.to_string(),
            "options.strict_resolution applies to resolution general only, not to paper"
        );
        let baseline_cap = PlanRequestOptions {
            scheme: Some(Scheme::Baseline),
            max_extra_energy_pct: Some(5.0),
            ..Default::default()
        };
        assert!(baseline_cap
            .to_plan_options()
            .unwrap_err()
            .to_string()
            .starts_with("options.max_extra_energy_pct applies to resolution general only"));
    }
}
