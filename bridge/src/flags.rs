//! Checks of the numeric command-line flags of the cellsar binaries.
//!
//! Every float option is checked once, when clap parses it: a number of seconds must be
//! finite, greater than zero and at most [`MAX_SECONDS`] (so that it converts to a
//! [`Duration`] and can be added to an [`std::time::Instant`] without overflow) and becomes a
//! [`Seconds`], which holds the [`Duration`] and the number as given, so that nothing checks
//! or converts it again; a rate may also be zero where zero has a meaning ("as fast as
//! possible"). The errors name the flag and the value. The `parse_*` functions are clap value
//! parsers (`#[arg(value_parser = bridge::flags::parse_seconds)]`): clap then names the flag
//! and exits with code 2.

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

/// A checked number of seconds: finite, > 0 and at most [`MAX_SECONDS`]. It holds both the
/// [`Duration`] and the number as given (shown by `Display`, e.g. to pass the flag on to a
/// child process or to name it in a message), so a flag parsed into a `Seconds` is checked
/// and converted exactly once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seconds {
    secs: f64,
    duration: Duration,
}

impl Seconds {
    /// `v` seconds; the error names `flag` and the value.
    pub fn new(flag: &str, v: f64) -> Result<Self, FlagError> {
        Self::checked(v).map_err(|reason| flag_error(flag, v, reason))
    }

    fn checked(v: f64) -> Result<Self, String> {
        if let Some(reason) = seconds_reason(v) {
            return Err(reason);
        }
        let duration = Duration::try_from_secs_f64(v).map_err(|e| e.to_string())?;
        Ok(Seconds { secs: v, duration })
    }

    /// The time span.
    pub fn duration(self) -> Duration {
        self.duration
    }

    /// The number of seconds as given.
    pub fn as_secs_f64(self) -> f64 {
        self.secs
    }
}

impl std::fmt::Display for Seconds {
    /// The number as given (`2.5`, `900`): parsing it again gives the same value.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(&self.secs, f)
    }
}

impl std::str::FromStr for Seconds {
    type Err = String;

    /// As [`parse_seconds`].
    fn from_str(s: &str) -> Result<Self, String> {
        parse_seconds(s)
    }
}

impl From<Seconds> for Duration {
    fn from(s: Seconds) -> Duration {
        s.duration
    }
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

/// clap value parser of a number of seconds (see [`Seconds`]); clap names the flag in the
/// error.
pub fn parse_seconds(s: &str) -> Result<Seconds, String> {
    Seconds::checked(parse_f64(s)?)
}

/// clap value parser of a finite number >= 0 (see [`non_negative`]).
pub fn parse_non_negative(s: &str) -> Result<f64, String> {
    non_negative("", parse_f64(s)?).map_err(|e| e.reason)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_must_be_finite_positive_and_bounded() {
        assert_eq!(
            Seconds::new("--t", 2.5).unwrap().duration(),
            Duration::from_millis(2500)
        );
        for bad in [f64::NAN, f64::INFINITY, -1.0, 0.0, -0.0, 1e10, 1e300] {
            let e = Seconds::new("--timeout-s", bad).unwrap_err();
            assert_eq!(e.flag, "--timeout-s");
            assert!(e.to_string().starts_with("--timeout-s "), "{e}");
            assert!(e.to_string().len() < 80, "{e}");
            assert!(parse_seconds(&bad.to_string()).is_err(), "{bad}");
        }
        assert_eq!(parse_seconds("3").unwrap().as_secs_f64(), 3.0);
        assert!(parse_seconds("soon").unwrap_err().contains("soon"));
    }

    /// A parsed flag carries its Duration and the number as given: nothing after clap checks
    /// or converts it again, and passing it on to a child gives the same value back.
    #[test]
    fn seconds_are_parsed_once_into_a_duration() {
        let s: Seconds = "2.5".parse().unwrap();
        assert_eq!(s.duration(), Duration::from_millis(2500));
        assert_eq!(Duration::from(s), Duration::from_millis(2500));
        assert_eq!(s.as_secs_f64(), 2.5);
        assert_eq!(s.to_string(), "2.5");
        assert_eq!(parse_seconds("900").unwrap().to_string(), "900");
        for v in ["0.1", "1e-9", "1e9", "12.345678901234567"] {
            let s = parse_seconds(v).unwrap();
            assert_eq!(parse_seconds(&s.to_string()).unwrap(), s, "{v}");
        }
        let e = Seconds::new("--plan-timeout-s", f64::NAN).unwrap_err();
        assert!(e.to_string().starts_with("--plan-timeout-s NaN"), "{e}");
        assert!("1e300".parse::<Seconds>().is_err());
        assert!("-0".parse::<Seconds>().is_err());
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
