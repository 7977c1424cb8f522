//! Zenoh key expressions used by cellsar.
//!
//! ```text
//! cellsar/alive/<role>/<instance>          liveliness token of every process
//! cellsar/<mission>/plan, .../detections   mission-scoped messages (mission = 16 hex digits)
//! cellsar/bridge/<instance>/stats          counters of a bridge (JSON)
//! cellsar/bridged/<instance>/<data key>    liveliness token per bridged service
//! ```

use crate::envelope::MissionId;

/// First chunk of every cellsar key.
pub const ROOT: &str = "cellsar";
/// Selector matching every liveliness token of cellsar processes.
pub const ALIVE_ALL: &str = "cellsar/alive/**";

/// A key or key chunk that Zenoh would not accept.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
#[error("invalid key {what} {value:?}: {reason}")]
pub struct KeyError {
    /// Which part (role, instance, key, ...).
    pub what: &'static str,
    /// The rejected value.
    pub value: String,
    /// Why.
    pub reason: &'static str,
}

/// Checks that `value` is one literal key chunk: non-empty, no `/`, no wildcard or reserved
/// characters (`* $ ? # @`), no spaces.
pub fn chunk<'a>(what: &'static str, value: &'a str) -> Result<&'a str, KeyError> {
    let err = |reason| KeyError {
        what,
        value: value.to_string(),
        reason,
    };
    if value.is_empty() {
        return Err(err("must not be empty"));
    }
    if value
        .chars()
        .any(|c| matches!(c, '/' | '*' | '$' | '?' | '#' | '@') || c.is_whitespace())
    {
        return Err(err(
            "must not contain '/', '*', '$', '?', '#', '@' or whitespace",
        ));
    }
    Ok(value)
}

/// Checks that `value` is a literal key (chunks as in [`chunk`], separated by `/`).
pub fn literal_key<'a>(what: &'static str, value: &'a str) -> Result<&'a str, KeyError> {
    if value.starts_with('/') || value.ends_with('/') {
        return Err(KeyError {
            what,
            value: value.to_string(),
            reason: "must not start or end with '/'",
        });
    }
    for c in value.split('/') {
        chunk(what, c).map_err(|e| KeyError {
            value: value.to_string(),
            ..e
        })?;
    }
    Ok(value)
}

/// `cellsar/alive/<role>/<instance>`.
pub fn alive(role: &str, instance: &str) -> Result<String, KeyError> {
    Ok(format!(
        "{ROOT}/alive/{}/{}",
        chunk("role", role)?,
        chunk("instance", instance)?
    ))
}

/// Splits a liveliness key `cellsar/alive/<role>/<instance>` into role and instance.
pub fn parse_alive(key: &str) -> Option<(&str, &str)> {
    let rest = key.strip_prefix("cellsar/alive/")?;
    let (role, instance) = rest.split_once('/')?;
    if role.is_empty() || instance.is_empty() || instance.contains('/') {
        return None;
    }
    Some((role, instance))
}

/// `cellsar/<mission>/<suffix>` (suffix checked as a literal key).
pub fn mission(id: MissionId, suffix: &str) -> Result<String, KeyError> {
    Ok(format!("{ROOT}/{id}/{}", literal_key("suffix", suffix)?))
}

/// `cellsar/bridge/<instance>/stats`.
pub fn bridge_stats(instance: &str) -> Result<String, KeyError> {
    Ok(format!(
        "{ROOT}/bridge/{}/stats",
        chunk("instance", instance)?
    ))
}

/// `cellsar/bridged/<instance>/<data key>`: liveliness of one bridged service.
pub fn bridged(instance: &str, data_key: &str) -> Result<String, KeyError> {
    Ok(format!(
        "{ROOT}/bridged/{}/{}",
        chunk("instance", instance)?,
        literal_key("data key", data_key)?
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_and_parses() {
        let k = alive("planner", "p1").unwrap();
        assert_eq!(k, "cellsar/alive/planner/p1");
        assert_eq!(parse_alive(&k), Some(("planner", "p1")));
        assert_eq!(parse_alive("cellsar/alive/x"), None);
        assert_eq!(
            mission(MissionId(255), "image/3").unwrap(),
            "cellsar/00000000000000ff/image/3"
        );
        assert_eq!(
            bridged("b1", "cellsar/m/echo").unwrap(),
            "cellsar/bridged/b1/cellsar/m/echo"
        );
    }

    #[test]
    fn rejects_wildcards() {
        assert!(alive("a/b", "x").is_err());
        assert!(alive("a", "*").is_err());
        assert!(alive("", "x").is_err());
        assert!(literal_key("k", "a//b").is_err());
        assert!(literal_key("k", "/a").is_err());
        assert!(literal_key("k", "a/**").is_err());
        let e = chunk("role", "a b").unwrap_err();
        assert!(e.to_string().contains("role"));
    }
}
