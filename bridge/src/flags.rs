//! Checks of the numeric command-line flags of the cellsar binaries.
//!
//! Every float option is checked before anything starts: a number of seconds must be finite,
//! greater than zero and at most [`MAX_SECONDS`] (so that it converts to a
//! [`Duration`] and can be added to an [`std::time::Instant`] without overflow); a rate may
//! also be zero where zero has a meaning ("as fast as possible"). The errors name the flag
//! and the value. The `parse_*` functions are clap value parsers (`#[arg(value_parser =
//! bridge::flags::parse_seconds)]`): clap then names the flag and exits with code 2.

use std::time::Duration;

/// The largest number of seconds a flag accepts (about 31.7 years).
pub const MAX_SECONDS: f64 = 1e9;

/// A numeric flag out of its range; the message names the flag and the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{flag} {value}: {reason}")]
pub struct FlagError {
    /// The flag, e.g. `--timeout-s`.
    pub flag: String,
    /// The value as given.
    pub value: String,
    /// What the flag needs.
    pub reason: String,
}

fn seconds_reason(v: f64) -> Option<String> {
    if !(v.is_finite() && v > 0.0) {
        Some("must be a finite number of seconds > 0".to_string())
    } else if v > MAX_SECONDS {
        Some(format!("must be at most {MAX_SECONDS:e} s"))
    } else {
        None
    }
}

fn non_negative_reason(v: f64) -> Option<String> {
    (!(v.is_finite() && v >= 0.0)).then(|| "must be a finite number >= 0".to_string())
}

fn flag_error(flag: &str, v: f64, reason: String) -> FlagError {
    FlagError {
        flag: flag.to_string(),
        value: format!("{v:?}"),
        reason,
    }
}

/// `v` seconds as a [`Duration`]: finite, > 0 and at most [`MAX_SECONDS`].
pub fn seconds(flag: &str, v: f64) -> Result<Duration, FlagError> {
    if let Some(reason) = seconds_reason(v) {
        return Err(flag_error(flag, v, reason));
    }
    Duration::try_from_secs_f64(v).map_err(|e| flag_error(flag, v, e.to_string()))
}

/// `v` when it is finite and >= 0 (a rate where 0 means "unlimited", for instance).
pub fn non_negative(flag: &str, v: f64) -> Result<f64, FlagError> {
    match non_negative_reason(v) {
        Some(reason) => Err(flag_error(flag, v, reason)),
        None => Ok(v),
    }
}

fn parse_f64(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .map_err(|_| format!("{s:?} is not a number"))
}

/// clap value parser of a number of seconds (see [`seconds`]).
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    let v = parse_f64(s)?;
    match seconds_reason(v) {
        Some(reason) => Err(reason),
        None => Ok(v),
    }
}

/// clap value parser of a finite number >= 0 (see [`non_negative`]).
pub fn parse_non_negative(s: &str) -> Result<f64, String> {
    let v = parse_f64(s)?;
    match non_negative_reason(v) {
        Some(reason) => Err(reason),
        None => Ok(v),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_must_be_finite_positive_and_bounded() {
        assert_eq!(seconds("--t", 2.5).unwrap(), Duration::from_millis(2500));
        for bad in [f64::NAN, f64::INFINITY, -1.0, 0.0, -0.0, 1e10, 1e300] {
            let e = seconds("--timeout-s", bad).unwrap_err();
            assert_eq!(e.flag, "--timeout-s");
            assert!(e.to_string().starts_with("--timeout-s "), "{e}");
            assert!(e.to_string().len() < 80, "{e}");
            assert!(parse_seconds(&bad.to_string()).is_err(), "{bad}");
        }
        assert_eq!(parse_seconds("3").unwrap(), 3.0);
        assert!(parse_seconds("soon").unwrap_err().contains("soon"));
    }

    #[test]
    fn non_negative_accepts_zero() {
        assert_eq!(non_negative("--rate-hz", 0.0).unwrap(), 0.0);
        assert_eq!(parse_non_negative("0").unwrap(), 0.0);
        for bad in [f64::NAN, f64::INFINITY, -1.0] {
            assert!(non_negative("--rate-hz", bad).is_err());
            assert!(parse_non_negative(&bad.to_string()).is_err());
        }
    }
}
