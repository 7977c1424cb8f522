//! Altitude as a mission setting: `fixed` (the paper's model, one altitude H for the whole
//! mission) or `free` (an altitude H_t per slot within bounds and climb and descent rates, the
//! three-dimensional extension the paper sketches after its problem (P6)).
//!
//! ```toml
//! [params]
//! altitude = "free"        # default "fixed"
//! altitude_m = 1000        # the start altitude H_0 (and the altitude of a fixed plan)
//! min_altitude_m = 600     # required with "free"
//! max_altitude_m = 1200    # required with "free"
//! max_climb_mps = 3        # default: PX4 MPC_Z_VEL_MAX_UP
//! max_descent_mps = 1      # default: PX4 MPC_Z_VEL_MAX_DN
//! ```
//!
//! The power of climbing and descending flight is [`crate::PowerModel::power_3d_w`].

use serde::{Deserialize, Serialize};

use crate::params::{ParamError, Params};

/// Default largest climb rate, m/s: PX4's multicopter position controller limit
/// `MPC_Z_VEL_MAX_UP` (default 3 m/s).
pub const DEFAULT_MAX_CLIMB_MPS: f64 = 3.0;

/// Default largest descent rate, m/s: PX4's multicopter position controller limit
/// `MPC_Z_VEL_MAX_DN` (default 1 m/s).
pub const DEFAULT_MAX_DESCENT_MPS: f64 = 1.0;

/// Whether the altitude is one number for the mission or a decision per slot. Names are the
/// same in serde, [`std::str::FromStr`], [`std::fmt::Display`] and `VARIANTS`.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    Default,
    Serialize,
    Deserialize,
    strum::EnumString,
    strum::Display,
    strum::IntoStaticStr,
    strum::VariantNames,
)]
#[serde(rename_all = "lowercase")]
#[strum(serialize_all = "lowercase")]
pub enum AltitudeMode {
    /// One altitude `altitude_m` for the whole mission (the paper's model; today's plans).
    #[default]
    Fixed,
    /// An altitude per slot within [`Params::min_altitude_m`, `max_altitude_m`], changing by at
    /// most `max_climb_mps` δ up and `max_descent_mps` δ down per slot, from `altitude_m` at
    /// the start.
    Free,
}

impl AltitudeMode {
    /// The name used in mission files and messages.
    pub fn name(self) -> &'static str {
        self.into()
    }
}

/// The serde default of [`Params::max_climb_mps`].
pub fn default_max_climb_mps() -> f64 {
    DEFAULT_MAX_CLIMB_MPS
}

/// The serde default of [`Params::max_descent_mps`].
pub fn default_max_descent_mps() -> f64 {
    DEFAULT_MAX_DESCENT_MPS
}

/// The altitude bounds of a validated mission, m: `(min, max)`; `(H, H)` for a fixed one.
pub fn bounds_m(p: &Params) -> (f64, f64) {
    match p.altitude {
        AltitudeMode::Fixed => (p.altitude_m, p.altitude_m),
        AltitudeMode::Free => (
            p.min_altitude_m.unwrap_or(p.altitude_m),
            p.max_altitude_m.unwrap_or(p.altitude_m),
        ),
    }
}

/// The parameters of a slot flown at altitude `altitude_m` (`H_t`): `p` with `altitude_m` set
/// to it and the sensing radius of the same antenna there, `sensing_radius_m` · H_t / H
/// (r_s = λ_c H / (2 W_a cos² η) scales with the altitude: paper-notes erratum 5). Everything
/// the geometry derives from H (the centre offset H tan η, V_min, the resolutions and the
/// cell) then follows H_t.
pub fn params_at(p: &Params, altitude_m: f64) -> Params {
    let mut at = p.clone();
    at.sensing_radius_m = p.sensing_radius_m * (altitude_m / p.altitude_m);
    at.altitude_m = altitude_m;
    at
}

/// Checks the altitude settings of `p` (its `altitude_m` already checked); the error names the
/// field: the rates finite and > 0; with `free` both bounds present, finite, > 0 and
/// min ≤ `altitude_m` ≤ max; with `fixed` no bounds (they would be silently unused).
pub fn validate(p: &Params) -> Result<(), ParamError> {
    let bad = |field: &'static str, value: f64, reason: String| ParamError::Invalid {
        field,
        value,
        reason,
    };
    for (field, value) in [
        ("max_climb_mps", p.max_climb_mps),
        ("max_descent_mps", p.max_descent_mps),
    ] {
        if !value.is_finite() || value <= 0.0 {
            return Err(bad(field, value, "must be a finite number > 0".into()));
        }
    }
    let bounds = [
        ("min_altitude_m", p.min_altitude_m),
        ("max_altitude_m", p.max_altitude_m),
    ];
    match p.altitude {
        AltitudeMode::Fixed => {
            if let Some((field, Some(value))) = bounds.iter().find(|(_, v)| v.is_some()) {
                return Err(bad(
                    field,
                    *value,
                    "applies only with altitude = \"free\" (the mission's altitude is \"fixed\")"
                        .into(),
                ));
            }
        }
        AltitudeMode::Free => {
            for (field, value) in bounds {
                let Some(value) = value else {
                    return Err(bad(
                        field,
                        f64::NAN,
                        "is required with altitude = \"free\"".into(),
                    ));
                };
                if !value.is_finite() || value <= 0.0 {
                    return Err(bad(field, value, "must be a finite number > 0".into()));
                }
            }
            let (lo, hi) = bounds_m(p);
            if lo > p.altitude_m {
                return Err(bad(
                    "min_altitude_m",
                    lo,
                    format!(
                        "must not exceed altitude_m = {} m (the start altitude)",
                        p.altitude_m
                    ),
                ));
            }
            if hi < p.altitude_m {
                return Err(bad(
                    "max_altitude_m",
                    hi,
                    format!(
                        "must not be below altitude_m = {} m (the start altitude)",
                        p.altitude_m
                    ),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ParamsOverride;

    fn free(lo: Option<f64>, hi: Option<f64>) -> Params {
        let mut p = Params::default();
        p.apply(&ParamsOverride {
            altitude: Some(AltitudeMode::Free),
            min_altitude_m: lo,
            max_altitude_m: hi,
            ..Default::default()
        });
        p
    }

    #[test]
    fn defaults_are_fixed_with_px4_rates() {
        let p = Params::default();
        assert_eq!(p.altitude, AltitudeMode::Fixed);
        assert_eq!((p.max_climb_mps, p.max_descent_mps), (3.0, 1.0));
        assert_eq!(bounds_m(&p), (1000.0, 1000.0));
        validate(&p).unwrap();
        assert_eq!("free".parse::<AltitudeMode>().unwrap(), AltitudeMode::Free);
        assert_eq!(AltitudeMode::Fixed.name(), "fixed");
    }

    #[test]
    fn free_needs_both_bounds_around_the_start_altitude() {
        validate(&free(Some(600.0), Some(1200.0))).unwrap();
        validate(&free(Some(1000.0), Some(1000.0))).unwrap();
        for (p, field) in [
            (free(None, Some(1200.0)), "min_altitude_m"),
            (free(Some(600.0), None), "max_altitude_m"),
            (free(Some(1100.0), Some(1200.0)), "min_altitude_m"),
            (free(Some(600.0), Some(900.0)), "max_altitude_m"),
            (free(Some(-5.0), Some(1200.0)), "min_altitude_m"),
            (free(Some(600.0), Some(f64::INFINITY)), "max_altitude_m"),
        ] {
            let msg = p.validate().unwrap_err().to_string();
            assert!(msg.contains(field), "{field}: {msg}");
        }
        let msg = free(None, Some(1200.0)).validate().unwrap_err().to_string();
        assert!(msg.contains("altitude = \"free\""), "{msg}");
    }

    #[test]
    fn fixed_refuses_unused_bounds_and_bad_rates() {
        let mut p = Params::default();
        p.max_altitude_m = Some(1200.0);
        let msg = p.validate().unwrap_err().to_string();
        assert!(
            msg.contains("max_altitude_m") && msg.contains("fixed"),
            "{msg}"
        );
        for (field, bad) in [
            ("max_climb_mps", 0.0),
            ("max_climb_mps", f64::NAN),
            ("max_descent_mps", -1.0),
        ] {
            let mut p = Params::default();
            match field {
                "max_climb_mps" => p.max_climb_mps = bad,
                _ => p.max_descent_mps = bad,
            }
            let msg = p.validate().unwrap_err().to_string();
            assert!(msg.contains(field), "{field}={bad}: {msg}");
        }
    }
}
