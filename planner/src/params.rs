//! Validated mission parameters (the paper's Table II plus what it leaves open; docs/user-guide.md lists them).
//!
//! [`Params`] holds every physical constant of the model under a name that carries its unit.
//! [`ParamsOverride`] is the `[params]` table of a mission file: every field optional, unknown
//! fields rejected. [`Params::validate`] checks every value and names the first bad field.

use serde::{Deserialize, Serialize};

use crate::altitude::{AltitudeMode, DEFAULT_MAX_CLIMB_MPS, DEFAULT_MAX_DESCENT_MPS};

pub mod bounds;
mod margins;

/// Speed of light in vacuum, m/s.
pub const SPEED_OF_LIGHT_MPS: f64 = 299_792_458.0;

/// A parameter that failed validation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// A value is NaN, infinite, or outside its allowed range (the reason names the bound).
    #[error("parameter `{field}` = {}: {reason}", Shown(*value))]
    Invalid {
        /// The parameter's name as it appears in a mission file's `[params]` table.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What the value must satisfy.
        reason: String,
    },
}

/// All parameters of the model, in SI units (names carry the unit).
///
/// Build one with [`Params::default`] (the default parameters) and [`Params::apply`], then call
/// [`Params::validate`]; a [`crate::Mission`] only ever holds validated parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Params {
    /// Transmit (OFDM) bandwidth B of the base station, Hz.
    pub bandwidth_hz: f64,
    /// Carrier wavelength λ_c, m.
    pub wavelength_m: f64,
    /// Coherent SAR integration time T_d, s.
    pub integration_time_s: f64,
    /// Observation (look) angle η of the side-looking receiver from nadir, rad, in (0, π/2).
    pub observation_angle_rad: f64,
    /// Required resolution d_min (the expected least object spacing), m.
    pub d_min_m: f64,
    /// UAV altitude H above ground, m.
    pub altitude_m: f64,
    /// Maximum UAV speed V_m, m/s.
    pub max_speed_mps: f64,
    /// Slot length δ, s.
    pub slot_s: f64,
    /// Mission horizon T, s (a whole number of slots).
    pub horizon_s: f64,
    /// Start position q_0 (x, y), m. Positions here are `[f64; 2]` (the mission files' format);
    /// the geometry converts them to nalgebra points.
    pub start_m: [f64; 2],
    /// Base-station ground position q_b (x, y), m.
    pub bs_m: [f64; 2],
    /// Base-station antenna height H_b, m.
    pub bs_height_m: f64,
    /// Radius r_s of the (circular) sensing area around the sensing centre, m.
    pub sensing_radius_m: f64,
    /// Blade-profile power in hover P_0, W.
    pub blade_power_w: f64,
    /// Rotor blade tip speed U_tip, m/s.
    pub tip_speed_mps: f64,
    /// Induced power in hover P_1, W.
    pub induced_power_w: f64,
    /// Mean rotor induced velocity in hover v_0, m/s.
    pub induced_velocity_mps: f64,
    /// Rotor solidity s (dimensionless).
    pub rotor_solidity: f64,
    /// Rotor disc area A, m².
    pub rotor_disc_area_m2: f64,
    /// Air density ρ, kg/m³.
    pub air_density_kgpm3: f64,
    /// Fuselage drag ratio d_f (dimensionless).
    pub fuselage_drag_ratio: f64,
    /// UAV mass, kg (Table II; informational, the power model already folds it in).
    pub uav_mass_kg: f64,
    /// Largest horizontal acceleration of the vehicle, m/s² (the vehicle dynamics only:
    /// `PlanOptions::dynamics`). Default g·tan 30° ≈ 5.66 m/s²: a multirotor accelerates
    /// horizontally by tilting its thrust, and ArduPilot's default lean-angle limit is
    /// ANGLE_MAX = 30° ([`DEFAULT_TILT_LIMIT_DEG`]).
    pub max_accel_mps2: f64,
    /// Largest horizontal jerk of the vehicle, m/s³ (the vehicle dynamics only): the acceleration
    /// between slots changes by at most this × [`crate::evaluate::jerk_window_s`] from slot to
    /// slot (from the second slot on: no acceleration before the start is assumed). `None` (the
    /// default): no jerk limit. A multirotor's horizontal acceleration is g·tan(tilt), so its jerk
    /// is bounded by how fast its attitude loop tilts it (g × the tilt rate near level flight);
    /// PX4's `MPC_JERK_MAX` defaults to 8 m/s³, ArduPilot's position controller to 5 m/s³.
    #[serde(default)]
    pub max_jerk_mps3: Option<f64>,
    /// Acceleration of the UAV at the start, (a_x, a_y) m/s² (the vehicle dynamics with a jerk
    /// limit only): the first slot's acceleration differs from it by at most `max_jerk_mps3` ×
    /// [`crate::evaluate::jerk_window_s`] of slot 1 (δ/3 after an instant's start velocity; for
    /// a re-plan continuing a flown track, whose start velocity is the previous slot's average,
    /// it is the acceleration into that slot, δ earlier). `None` (the default): none is assumed,
    /// and the first slot's acceleration is bounded by `max_accel_mps2` only.
    #[serde(default)]
    pub start_accel_mps2: Option<[f64; 2]>,
    /// Margin on the resolution requirement, % of `d_min_m`: the planner plans for
    /// d_min (1 − this/100), the azimuth speed V_min with it, so that the flown track keeps
    /// that room for a flight controller's tracking error; the plan is judged against d_min.
    /// 0 (the default): none. ([`Params::planning_limits`].)
    ///
    /// The margins are mission parameters, not planning options: like the limits they tighten,
    /// they describe the vehicle and its flight controller, not a way of planning. So they travel
    /// with the mission through every interface without a field of their own (mission files and
    /// the `[params]` a plan writes back, plan requests, the FMU's parameters, the Python
    /// package's `params`), a re-plan of a flown mission (the FMU's) keeps them, a mission with
    /// other margins gets another mission id, and `summary.json`, made from the mission and the
    /// plan, reports them with the room the plan keeps.
    #[serde(default)]
    pub resolution_margin_pct: f64,
    /// Margin on the acceleration limit, % of `max_accel_mps2`: the planner plans for
    /// a_max (1 − this/100) (the vehicle dynamics only); the plan is judged against a_max.
    /// 0 (the default): none.
    #[serde(default)]
    pub accel_margin_pct: f64,
    /// Margin on the jerk limit, % of `max_jerk_mps3`: the planner plans for
    /// j_max (1 − this/100) (the vehicle dynamics with a jerk limit only; no effect without
    /// `max_jerk_mps3`); the plan is judged against j_max. 0 (the default): none.
    #[serde(default)]
    pub jerk_margin_pct: f64,
    /// Velocity of the UAV as it passes the start q_0, (v_x, v_y) m/s; `None`: the rule of
    /// [`crate::Mission::start_velocity_mps`] (at rest, unless the first landmark comes too soon
    /// to reach the azimuth speed from rest).
    pub start_velocity_mps: Option<[f64; 2]>,
    /// What `start_velocity_mps` is: the velocity at the start instant (`instant`, default) or
    /// the average velocity of the slot flown just before the start (`previous-slot`: a re-plan
    /// that continues a flown track). It sets how far the first slot's velocity may differ from
    /// it under the vehicle dynamics ([`crate::evaluate::start_to_slot_middle_s`]). Not a
    /// mission-file parameter (a mission starts at an instant; [`ParamsOverride`] and the wire
    /// forms of a mission keep their layout): set it on the validated parameters
    /// ([`crate::Mission::with_params`]).
    #[serde(default)]
    pub start_velocity_kind: StartVelocityKind,
    /// `fixed` (default: the whole mission at `altitude_m`) or `free` (an altitude per slot
    /// within [`Params::min_altitude_m`, `max_altitude_m`] from `altitude_m` at the start;
    /// [`crate::altitude`]).
    #[serde(default)]
    pub altitude: AltitudeMode,
    /// Least altitude of a `free` mission, m (required with `free`, refused with `fixed`).
    #[serde(default)]
    pub min_altitude_m: Option<f64>,
    /// Greatest altitude of a `free` mission, m (required with `free`, refused with `fixed`).
    #[serde(default)]
    pub max_altitude_m: Option<f64>,
    /// Largest climb rate of a `free` mission, m/s. Default 3 m/s: PX4's `MPC_Z_VEL_MAX_UP`.
    #[serde(default = "crate::altitude::default_max_climb_mps")]
    pub max_climb_mps: f64,
    /// Largest descent rate of a `free` mission, m/s. Default 1 m/s: PX4's `MPC_Z_VEL_MAX_DN`.
    #[serde(default = "crate::altitude::default_max_descent_mps")]
    pub max_descent_mps: f64,
}

/// What [`Params::start_velocity_mps`] is. The plan's velocities are slot averages, each the
/// velocity at its slot's middle; the start velocity's instant sets how long the UAV has, at the
/// acceleration limit, to change it into the first slot's.
#[derive(
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    strum::IntoStaticStr,
    strum::VariantNames,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum StartVelocityKind {
    /// The velocity at the start instant t = 0 (a mission's start): the first slot's average,
    /// δ/2 later, differs from it by at most a_max δ/2 (from v₀ at constant acceleration a the
    /// UAV is at q₀ + v₀ δ + a δ²/2 after one slot).
    #[default]
    Instant,
    /// The average velocity of the slot flown just before the start (a re-plan continuing a
    /// flown track): its middle lies δ/2 before the start, so the first slot's average differs
    /// from it by at most a_max δ, as between any two slots.
    PreviousSlot,
}

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY_MPS2: f64 = 9.806_65;

/// The tilt (lean-angle) limit behind the default of [`Params::max_accel_mps2`], degrees:
/// ArduPilot's default ANGLE_MAX of 30° (copter parameter ANGLE_MAX = 3000 centidegrees).
pub const DEFAULT_TILT_LIMIT_DEG: f64 = 30.0;

/// The default horizontal acceleration limit, g·tan([`DEFAULT_TILT_LIMIT_DEG`]) ≈ 5.662 m/s².
pub fn default_max_accel_mps2() -> f64 {
    STANDARD_GRAVITY_MPS2 * DEFAULT_TILT_LIMIT_DEG.to_radians().tan()
}

impl Default for Params {
    fn default() -> Self {
        Self {
            bandwidth_hz: 150e6,
            wavelength_m: 0.1,
            integration_time_s: 1.0,
            observation_angle_rad: std::f64::consts::FRAC_PI_4,
            d_min_m: 20.0,
            altitude_m: 1000.0,
            max_speed_mps: 50.0,
            slot_s: 0.5,
            horizon_s: 300.0,
            start_m: [-1000.0, -500.0],
            bs_m: [1000.0, -1000.0],
            bs_height_m: 50.0,
            sensing_radius_m: 200.0,
            blade_power_w: 3.4,
            tip_speed_mps: 60.0,
            induced_power_w: 118.0,
            induced_velocity_mps: 5.4,
            rotor_solidity: 0.02,
            rotor_disc_area_m2: 0.5,
            air_density_kgpm3: 1.225,
            fuselage_drag_ratio: 0.3,
            uav_mass_kg: 2.0,
            max_accel_mps2: default_max_accel_mps2(),
            max_jerk_mps3: None,
            start_accel_mps2: None,
            resolution_margin_pct: 0.0,
            accel_margin_pct: 0.0,
            jerk_margin_pct: 0.0,
            start_velocity_mps: None,
            start_velocity_kind: StartVelocityKind::Instant,
            altitude: AltitudeMode::Fixed,
            min_altitude_m: None,
            max_altitude_m: None,
            max_climb_mps: DEFAULT_MAX_CLIMB_MPS,
            max_descent_mps: DEFAULT_MAX_DESCENT_MPS,
        }
    }
}

/// The `[params]` table of a mission file: any subset of [`Params`], unknown names rejected.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)] // one field per `Params` field, same name and meaning
pub struct ParamsOverride {
    pub bandwidth_hz: Option<f64>,
    pub wavelength_m: Option<f64>,
    pub integration_time_s: Option<f64>,
    pub observation_angle_rad: Option<f64>,
    pub d_min_m: Option<f64>,
    pub altitude_m: Option<f64>,
    pub max_speed_mps: Option<f64>,
    pub slot_s: Option<f64>,
    pub horizon_s: Option<f64>,
    pub start_m: Option<[f64; 2]>,
    pub bs_m: Option<[f64; 2]>,
    pub bs_height_m: Option<f64>,
    pub sensing_radius_m: Option<f64>,
    pub blade_power_w: Option<f64>,
    pub tip_speed_mps: Option<f64>,
    pub induced_power_w: Option<f64>,
    pub induced_velocity_mps: Option<f64>,
    pub rotor_solidity: Option<f64>,
    pub rotor_disc_area_m2: Option<f64>,
    pub air_density_kgpm3: Option<f64>,
    pub fuselage_drag_ratio: Option<f64>,
    pub uav_mass_kg: Option<f64>,
    pub max_accel_mps2: Option<f64>,
    pub max_jerk_mps3: Option<f64>,
    pub start_accel_mps2: Option<[f64; 2]>,
    pub resolution_margin_pct: Option<f64>,
    pub accel_margin_pct: Option<f64>,
    pub jerk_margin_pct: Option<f64>,
    pub start_velocity_mps: Option<[f64; 2]>,
    pub altitude: Option<AltitudeMode>,
    pub min_altitude_m: Option<f64>,
    pub max_altitude_m: Option<f64>,
    pub max_climb_mps: Option<f64>,
    pub max_descent_mps: Option<f64>,
}

/// A value as refusals show it: in full between 1e-4 and 1e15 (`1.5707963267948966`), with an
/// exponent outside (`1e300`, not 301 digits).
struct Shown(f64);

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&x.abs()) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

/// Which values a scalar parameter may take.
#[derive(Debug, Clone, Copy)]
enum Range {
    /// Strictly positive.
    Positive,
    /// Zero or more.
    NonNegative,
    /// Open interval (lo, hi).
    Open(f64, f64),
    /// Positive and at most the bound; the text says where the bound comes from.
    PositiveAtMost(f64, &'static str),
    /// Zero or more and at most the bound; the text says where the bound comes from.
    NonNegativeAtMost(f64, &'static str),
    /// Within [lo, hi]; the text says where the bounds come from.
    Closed(f64, f64, &'static str),
}

/// One entry of the parameter table: name, accessor.
type Field = (
    &'static str,
    fn(&Params) -> f64,
    fn(&mut Params, f64),
    Range,
);

macro_rules! scalar_fields {
    ($( $name:ident : $range:expr ),* $(,)?) => {
        /// Every scalar parameter with its name, getter, setter and allowed range.
        fn scalar_fields() -> [Field; [$( stringify!($name) ),*].len()] {
            [
                $( (stringify!($name), |p: &Params| p.$name, |p: &mut Params, v: f64| p.$name = v, $range) ),*
            ]
        }
        impl Params {
            /// Overwrites every field that `o` sets.
            pub fn apply(&mut self, o: &ParamsOverride) {
                $( if let Some(v) = o.$name { self.$name = v; } )*
                if let Some(v) = o.start_m { self.start_m = v; }
                if let Some(v) = o.bs_m { self.bs_m = v; }
                if let Some(v) = o.start_velocity_mps { self.start_velocity_mps = Some(v); }
                if let Some(v) = o.max_jerk_mps3 { self.max_jerk_mps3 = Some(v); }
                if let Some(v) = o.start_accel_mps2 { self.start_accel_mps2 = Some(v); }
                if let Some(v) = o.altitude { self.altitude = v; }
                if let Some(v) = o.min_altitude_m { self.min_altitude_m = Some(v); }
                if let Some(v) = o.max_altitude_m { self.max_altitude_m = Some(v); }
                if let Some(v) = o.max_climb_mps { self.max_climb_mps = v; }
                if let Some(v) = o.max_descent_mps { self.max_descent_mps = v; }
            }
        }
    };
}

scalar_fields! {
    bandwidth_hz: Range::Closed(
        bounds::MIN_BANDWIDTH_HZ,
        bounds::MAX_BANDWIDTH_HZ,
        "from the narrowest LTE channel to the widest NR channel",
    ),
    wavelength_m: Range::Closed(
        bounds::min_wavelength_m(),
        bounds::max_wavelength_m(),
        "the carriers of NR, 410 MHz to 71 GHz",
    ),
    integration_time_s: Range::PositiveAtMost(
        bounds::MAX_HORIZON_S,
        "no aperture outlasts the longest multirotor flight",
    ),
    observation_angle_rad: Range::Open(0.0, std::f64::consts::FRAC_PI_2),
    d_min_m: Range::Positive,
    altitude_m: Range::PositiveAtMost(bounds::MAX_ALTITUDE_M, bounds::ALTITUDE_WHY),
    max_speed_mps: Range::PositiveAtMost(bounds::MAX_SPEED_MPS, bounds::SPEED_WHY),
    slot_s: Range::Positive,
    horizon_s: Range::PositiveAtMost(
        bounds::MAX_HORIZON_S,
        "above the endurance record of a multirotor, 4 h 34 min",
    ),
    bs_height_m: Range::NonNegativeAtMost(
        bounds::MAX_BS_HEIGHT_M,
        "the highest BS of 3GPP TR 38.901's rural macro cell",
    ),
    sensing_radius_m: Range::PositiveAtMost(
        bounds::MAX_COORDINATE_M,
        "the largest LTE cell radius",
    ),
    blade_power_w: Range::NonNegative,
    tip_speed_mps: Range::PositiveAtMost(
        bounds::SPEED_OF_SOUND_MPS,
        "rotor blade tips stay below the speed of sound",
    ),
    induced_power_w: Range::NonNegative,
    induced_velocity_mps: Range::Positive,
    rotor_solidity: Range::NonNegativeAtMost(
        1.0,
        "the blades' area over the disc's",
    ),
    rotor_disc_area_m2: Range::NonNegative,
    air_density_kgpm3: Range::NonNegativeAtMost(
        bounds::MAX_AIR_DENSITY_KGPM3,
        "above dry air at sea level and -50 °C",
    ),
    fuselage_drag_ratio: Range::NonNegative,
    uav_mass_kg: Range::PositiveAtMost(
        bounds::MAX_UAV_MASS_KG,
        "above the largest rotary-wing UAV in service",
    ),
    max_accel_mps2: Range::PositiveAtMost(
        bounds::max_accel_mps2(),
        "g tan 80°, the largest lean angle ArduPilot allows",
    ),
    resolution_margin_pct: Range::NonNegativeAtMost(bounds::MAX_MARGIN_PCT, bounds::MARGIN_WHY),
    accel_margin_pct: Range::NonNegativeAtMost(bounds::MAX_MARGIN_PCT, bounds::MARGIN_WHY),
    jerk_margin_pct: Range::NonNegativeAtMost(bounds::MAX_MARGIN_PCT, bounds::MARGIN_WHY),
}

/// `x` with at most six significant digits and no trailing zeros (`1.5708`, `600.001`, `2`),
/// for limits and derived values in messages; the offending value itself is printed in full.
fn short(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let digits = 6 - 1 - x.abs().log10().floor() as i32;
    let text = format!("{:.*}", digits.max(0) as usize, x);
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// Largest number of slots a mission may have (keeps memory and solve time bounded).
pub const MAX_SLOTS: usize = 200_000;

impl Params {
    /// Sets a scalar parameter by its mission-file name; `Err` names an unknown field.
    pub fn set_by_name(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        for (field, _, set, _) in scalar_fields() {
            if field == name {
                set(self, value);
                return Ok(());
            }
        }
        Err(ParamError::Invalid {
            field: "params",
            value,
            reason: format!("unknown scalar parameter `{name}`"),
        })
    }

    /// Reads a scalar parameter by its mission-file name.
    pub fn get_by_name(&self, name: &str) -> Option<f64> {
        scalar_fields()
            .into_iter()
            .find(|(field, ..)| *field == name)
            .map(|(_, get, ..)| get(self))
    }

    /// Names of all scalar parameters, in table order.
    pub fn scalar_names() -> impl Iterator<Item = &'static str> {
        scalar_fields().into_iter().map(|(name, ..)| name)
    }

    /// Checks every value, against the physical envelope too ([`bounds`]); the error names the
    /// first bad field, its value and the bound.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (field, get, _, range) in scalar_fields() {
            let value = get(self);
            let bad = |reason: &str| ParamError::Invalid {
                field,
                value,
                reason: reason.to_string(),
            };
            if !value.is_finite() {
                return Err(bad("must be a finite number"));
            }
            match range {
                Range::Positive | Range::PositiveAtMost(..) if value <= 0.0 => {
                    return Err(bad("must be > 0"))
                }
                Range::NonNegative | Range::NonNegativeAtMost(..) if value < 0.0 => {
                    return Err(bad("must be >= 0"))
                }
                Range::PositiveAtMost(hi, why) | Range::NonNegativeAtMost(hi, why)
                    if value > hi =>
                {
                    return Err(bounds::above(field, value, hi, why))
                }
                Range::Open(lo, hi) if !(value > lo && value < hi) => {
                    return Err(bad(&format!(
                        "must lie in the open interval ({}, {})",
                        short(lo),
                        short(hi)
                    )))
                }
                Range::Closed(lo, hi, why) if !(lo..=hi).contains(&value) => {
                    return Err(bad(&format!(
                        "must lie in [{}, {}] ({why})",
                        short(lo),
                        short(hi)
                    )))
                }
                _ => {}
            }
        }
        for (field, v) in [("start_m", self.start_m), ("bs_m", self.bs_m)] {
            for value in v {
                if !value.is_finite() {
                    return Err(ParamError::Invalid {
                        field,
                        value,
                        reason: "coordinates must be finite numbers".into(),
                    });
                }
            }
        }
        if let Some(v) = self.start_velocity_mps {
            for value in v {
                if !value.is_finite() {
                    return Err(ParamError::Invalid {
                        field: "start_velocity_mps",
                        value,
                        reason: "components must be finite numbers".into(),
                    });
                }
            }
            let speed = v[0].hypot(v[1]);
            if speed > self.max_speed_mps {
                return Err(ParamError::Invalid {
                    field: "start_velocity_mps",
                    value: speed,
                    reason: format!(
                        "its speed must not exceed max_speed_mps = {} m/s",
                        short(self.max_speed_mps)
                    ),
                });
            }
        }
        let ratio = self.horizon_s / self.slot_s;
        let slots = ratio.round();
        if (ratio - slots).abs() > 1e-6 * ratio.max(1.0) || slots < 1.0 {
            return Err(ParamError::Invalid {
                field: "horizon_s",
                value: self.horizon_s,
                reason: format!(
                    "must be a whole, non-zero number of slots of slot_s = {} s (ratio {})",
                    self.slot_s,
                    short(ratio)
                ),
            });
        }
        if slots > MAX_SLOTS as f64 {
            return Err(ParamError::Invalid {
                field: "horizon_s",
                value: self.horizon_s,
                reason: format!("gives {slots} slots, more than the supported {MAX_SLOTS}"),
            });
        }
        margins::validate_jerk(self)?;
        crate::altitude::validate(self)?;
        bounds::check_others(self)
    }

    /// Number of slots T_w = T / δ.
    pub fn slots(&self) -> usize {
        (self.horizon_s / self.slot_s).round().max(0.0) as usize
    }

    /// Ground distance from the UAV to its sensing centre, H tan η, m.
    pub fn centre_offset_m(&self) -> f64 {
        self.altitude_m * self.observation_angle_rad.tan()
    }

    /// Slant range from the UAV to its sensing centre, R_r = H / cos η, m.
    pub fn slant_range_m(&self) -> f64 {
        self.altitude_m / self.observation_angle_rad.cos()
    }

    /// Least speed that meets the azimuth requirement δ_a ≤ d_min (paper eq. p2.2):
    /// V_min = λ_c H / (T_d d_min cos η), m/s.
    pub fn min_speed_mps(&self) -> f64 {
        self.wavelength_m * self.altitude_m
            / (self.integration_time_s * self.d_min_m * self.observation_angle_rad.cos())
    }

    /// Right-hand side of the squared range constraint, sin θ_t ≥ c/(B d_min) − sin η.
    /// When this is ≤ 0 the range requirement holds everywhere (erratum 2 (docs/paper-notes.md)).
    pub fn range_sin_threshold(&self) -> f64 {
        SPEED_OF_LIGHT_MPS / (self.bandwidth_hz * self.d_min_m) - self.observation_angle_rad.sin()
    }

    /// The least ground distance between the sensing centre and the BS that meets the paper's
    /// range requirement, `sqrt(C_r)` of eq. (explicit), or `None` when the requirement is vacuous
    /// (threshold ≤ 0). Returns `Some(f64::INFINITY)` when it can never be met (threshold ≥ 1).
    pub fn range_keepout_m(&self) -> Option<f64> {
        let k = self.range_sin_threshold();
        if k <= 0.0 {
            None
        } else if k >= 1.0 {
            Some(f64::INFINITY)
        } else {
            // sin θ ≥ k  <=>  d / sqrt(d² + H_b²) ≥ k  <=>  d² ≥ k² H_b² / (1 − k²)
            Some(self.bs_height_m * k / (1.0 - k * k).sqrt())
        }
    }

    /// The sensing radius that the defaults (docs/user-guide.md) derives from the antenna height W_a:
    /// r_s = λ_c H / (2 W_a cos² η).
    pub fn sensing_radius_from_antenna_m(&self, antenna_height_m: f64) -> f64 {
        let c = self.observation_angle_rad.cos();
        self.wavelength_m * self.altitude_m / (2.0 * antenna_height_m * c * c)
    }
}

#[cfg(test)]
mod tests;
