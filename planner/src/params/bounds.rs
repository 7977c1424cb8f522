//! The physical envelope of a mission: the largest (and least) values a real rotary-wing UAV
//! and a real cell can have. Each bound carries its source (docs/user-guide.md, "Physical
//! bounds", lists them beside the field tables); a value outside is refused by
//! [`super::Params::validate`] with the field, the value and the bound.
//!
//! The bounds are wide: they keep out values no vehicle or cell can have (a speed of 1e300 m/s
//! plans for hours), not unusual missions.

use super::{short, ParamError, Params};

/// Largest transmit bandwidth, Hz: 400 MHz, the widest NR channel (FR2, 3GPP TS 38.101-2
/// Table 5.3.5-1).
pub const MAX_BANDWIDTH_HZ: f64 = 400e6;
/// Least transmit bandwidth, Hz: 1.4 MHz, the narrowest LTE channel (3GPP TS 36.101 Table
/// 5.6-1).
pub const MIN_BANDWIDTH_HZ: f64 = 1.4e6;
/// Lowest carrier frequency of a cell, Hz: 410 MHz, the lower edge of NR's FR1 (3GPP TS
/// 38.101-1 Table 5.1-1).
pub const MIN_CARRIER_HZ: f64 = 410e6;
/// Highest carrier frequency of a cell, Hz: 71 GHz, the upper edge of NR's FR2-2 (3GPP TS
/// 38.101-2 Table 5.1-1).
pub const MAX_CARRIER_HZ: f64 = 71e9;
/// Highest altitude, m: 7000 m, the service ceiling of a production multirotor with
/// high-altitude propellers (DJI Matrice 350 RTK). FAA Part 107 (400 ft, 122 m) and EASA's
/// open category (120 m) limit flights without a waiver; the paper's 1000 m is a flight under
/// a waiver or in the specific category, so those are no bound here.
pub const MAX_ALTITUDE_M: f64 = 7000.0;
/// Largest speed, m/s (horizontal, climb and descent): 150 m/s, above the fastest rotary-wing
/// flight on record (the Eurocopter X³ compound helicopter, 472 km/h = 131 m/s, 2013; the FAI
/// record of a conventional helicopter, Westland Lynx, 400.87 km/h = 111 m/s, 1986).
pub const MAX_SPEED_MPS: f64 = 150.0;
/// Largest lean angle, degrees: 80°, the most ArduPilot's `ANGLE_MAX` allows (its range is
/// 1000–8000 centidegrees); a multirotor accelerates horizontally by g·tan(lean).
pub const MAX_TILT_DEG: f64 = 80.0;
/// Longest mission, s: 5 h, above the endurance record of a multirotor (a hybrid
/// petrol-electric one, Skyfront Tailwind, 4 h 34 min, 2017). Also the longest integration
/// time: no aperture outlasts the flight.
pub const MAX_HORIZON_S: f64 = 5.0 * 3600.0;
/// Largest distance of any position (start, BS, landmark) from the origin along either axis,
/// and largest sensing radius, m: 100 km, the largest LTE cell radius (PRACH preamble format 3,
/// 3GPP TS 36.211 Table 5.7.1-1).
pub const MAX_COORDINATE_M: f64 = 100e3;
/// Highest BS antenna, m: 150 m, the top of 3GPP TR 38.901's rural macro range (Table 7.4.1-1,
/// RMa, 10 m ≤ h_BS ≤ 150 m).
pub const MAX_BS_HEIGHT_M: f64 = 150.0;
/// Speed of sound in the ISA sea-level atmosphere, m/s: rotor blade tips stay below it.
pub const SPEED_OF_SOUND_MPS: f64 = 340.294;
/// Densest air, kg/m³: 1.6, above dry air at sea-level pressure and −50 °C (1.58 kg/m³;
/// the ISA sea-level value is 1.225).
pub const MAX_AIR_DENSITY_KGPM3: f64 = 1.6;
/// Heaviest vehicle, kg: 3000 kg, above the largest rotary-wing UAV in service (Northrop
/// Grumman MQ-8C Fire Scout, 2 722 kg maximum take-off weight).
pub const MAX_UAV_MASS_KG: f64 = 3000.0;
/// Largest horizontal jerk, m/s³: 500 m/s³, the largest value of PX4's jerk limit
/// `MPC_JERK_MAX` (range 0.5–500, default 8), which PX4 documents as essentially no limit.
pub const MAX_JERK_MPS3: f64 = 500.0;
/// Largest margin on a limit, %: 50 %. A margin is room for a flight controller's tracking
/// error; one of half the limit or more describes another vehicle, whose limit the mission
/// should state instead.
pub const MAX_MARGIN_PCT: f64 = 50.0;
/// Most landmarks of a mission: 10 000 (a work bound, not physics: the paper's layouts have 30
/// and 60; each landmark needs a slot of its own).
pub const MAX_LANDMARKS: usize = 10_000;

/// The largest horizontal acceleration, g·tan([`MAX_TILT_DEG`]) ≈ 55.6 m/s².
pub fn max_accel_mps2() -> f64 {
    super::STANDARD_GRAVITY_MPS2 * MAX_TILT_DEG.to_radians().tan()
}

/// The shortest carrier wavelength, c / [`MAX_CARRIER_HZ`] ≈ 4.22 mm.
pub fn min_wavelength_m() -> f64 {
    super::SPEED_OF_LIGHT_MPS / MAX_CARRIER_HZ
}

/// The longest carrier wavelength, c / [`MIN_CARRIER_HZ`] ≈ 0.731 m.
pub fn max_wavelength_m() -> f64 {
    super::SPEED_OF_LIGHT_MPS / MIN_CARRIER_HZ
}

/// The refusal of `value` of `field` above `bound`, naming where the bound comes from.
pub(super) fn above(field: &'static str, value: f64, bound: f64, why: &str) -> ParamError {
    ParamError::Invalid {
        field,
        value,
        reason: format!("must be at most {} ({why})", short(bound)),
    }
}

/// The bounds of the fields that are not plain scalars: positions within
/// [`MAX_COORDINATE_M`], the free altitude's bounds within [`MAX_ALTITUDE_M`], the climb and
/// descent rates within [`MAX_SPEED_MPS`] (the rest of each field's rule is checked before).
pub(super) fn check_others(p: &Params) -> Result<(), ParamError> {
    for (field, v) in [("start_m", p.start_m), ("bs_m", p.bs_m)] {
        for value in v {
            if value.abs() > MAX_COORDINATE_M {
                return Err(ParamError::Invalid {
                    field,
                    value,
                    reason: format!(
                        "coordinates must lie within ±{} m of the origin (the largest LTE \
                         cell radius)",
                        short(MAX_COORDINATE_M)
                    ),
                });
            }
        }
    }
    for (field, value) in [
        ("min_altitude_m", p.min_altitude_m),
        ("max_altitude_m", p.max_altitude_m),
    ] {
        if let Some(value) = value.filter(|v| *v > MAX_ALTITUDE_M) {
            return Err(above(field, value, MAX_ALTITUDE_M, ALTITUDE_WHY));
        }
    }
    for (field, value) in [
        ("max_climb_mps", p.max_climb_mps),
        ("max_descent_mps", p.max_descent_mps),
    ] {
        if value > MAX_SPEED_MPS {
            return Err(above(field, value, MAX_SPEED_MPS, SPEED_WHY));
        }
    }
    Ok(())
}

/// Where [`MAX_ALTITUDE_M`] comes from, in refusals.
pub(super) const ALTITUDE_WHY: &str = "the service ceiling of a production multirotor";
/// Where [`MAX_JERK_MPS3`] comes from, in refusals.
pub(super) const JERK_WHY: &str = "the largest jerk limit PX4 allows, MPC_JERK_MAX = 500";
/// Where [`MAX_MARGIN_PCT`] comes from, in refusals.
pub(super) const MARGIN_WHY: &str = "half the limit: state the vehicle's own limit instead";
/// Where [`MAX_SPEED_MPS`] comes from, in refusals.
pub(super) const SPEED_WHY: &str = "above the fastest rotary-wing flight on record, 131 m/s";
