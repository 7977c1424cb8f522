//! The variable tables: one row per model variable (name, value reference, type, causality,
//! variability, length, unit, description). Each table drives both the C entry points (get/set by
//! value reference, see [`crate::core`]) and the generated `modelDescription.xml`
//! (see [`crate::xml`]), as in modelica's Reference-FMUs. Start values are not stored here: they
//! are read from a freshly created model core, so the code that defines the defaults is the only
//! source of them.

/// The FMI type of a variable, as FMI 2 names it (FMI 3: `Float64`, `Int32`, `Boolean`, `String`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    /// FMI 2 `Real`, FMI 3 `Float64`.
    Real,
    /// FMI 2 `Integer`, FMI 3 `Int32`.
    Integer,
    /// `Boolean`.
    Boolean,
    /// `String`.
    String,
}

impl VarType {
    /// The element name in an FMI 3 model description.
    pub fn fmi3_name(self) -> &'static str {
        match self {
            VarType::Real => "Float64",
            VarType::Integer => "Int32",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
        }
    }

    /// The element name in an FMI 2 model description.
    pub fn fmi2_name(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
        }
    }
}

/// FMI causality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// A parameter, set before initialisation.
    Parameter,
    /// An input, set before each step.
    Input,
    /// An output.
    Output,
    /// A local variable (visible, not connectable).
    Local,
    /// The independent variable (time; FMI 3 only).
    Independent,
}

impl Causality {
    /// The attribute value in modelDescription.xml.
    pub fn name(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
            Causality::Independent => "independent",
        }
    }
}

/// FMI variability.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    /// Fixed after initialisation.
    Fixed,
    /// Changes only at communication points (or events).
    Discrete,
    /// May change at any time.
    Continuous,
}

impl Variability {
    /// The attribute value in modelDescription.xml.
    pub fn name(self) -> &'static str {
        match self {
            Variability::Fixed => "fixed",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }
}

/// One model variable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Var {
    /// Name (FMI 3; FMI 2 flattens arrays to `name[1]`, `name[2]`, ...).
    pub name: &'static str,
    /// Value reference. An array of length n occupies `vr..vr+n` in FMI 2 (one per element) and
    /// `vr` alone in FMI 3.
    pub vr: u32,
    /// Type.
    pub ty: VarType,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// Number of elements (1: scalar).
    pub len: usize,
    /// Unit (declared in `UnitDefinitions`), if any.
    pub unit: Option<&'static str>,
    /// Description.
    pub description: &'static str,
}

impl Var {
    /// True when this is the independent variable `time`, which only FMI 3 lists.
    pub fn fmi3_only(&self) -> bool {
        self.causality == Causality::Independent
    }

    /// True for outputs and locals, which the model computes ("calculated").
    pub fn is_calculated(&self) -> bool {
        matches!(self.causality, Causality::Output | Causality::Local)
    }
}

/// A unit: name and SI base-unit exponents (kg, m, s, rad).
#[derive(Debug, Clone, Copy)]
pub struct Unit {
    /// The unit's name as variables refer to it.
    pub name: &'static str,
    /// Exponent of kg.
    pub kg: i32,
    /// Exponent of m.
    pub m: i32,
    /// Exponent of s.
    pub s: i32,
    /// Exponent of rad.
    pub rad: i32,
}

/// A unit with its exponents of kg, m, s and rad.
const fn unit(name: &'static str, kg: i32, m: i32, s: i32, rad: i32) -> Unit {
    Unit {
        name,
        kg,
        m,
        s,
        rad,
    }
}

/// Every unit a table may use.
pub const UNITS: &[Unit] = &[
    unit("Hz", 0, 0, -1, 0),
    unit("m", 0, 1, 0, 0),
    unit("s", 0, 0, 1, 0),
    unit("rad", 0, 0, 0, 1),
    unit("m/s", 0, 1, -1, 0),
    unit("m/s2", 0, 1, -2, 0),
    unit("m/s3", 0, 1, -3, 0),
    unit("W", 1, 2, -3, 0),
    unit("J", 1, 2, -2, 0),
    unit("kg", 1, 0, 0, 0),
    unit("m2", 0, 2, 0, 0),
    unit("kg/m3", 1, -3, 0, 0),
];

/// A log category the models use (declared in `LogCategories`).
#[derive(Debug, Clone, Copy)]
pub struct LogCategory {
    /// Name passed to the logger.
    pub name: &'static str,
    /// What it reports.
    pub description: &'static str,
}

/// The log categories. Errors and warnings are always reported; the others only with debug
/// logging on (and the category enabled).
pub const LOG_CATEGORIES: &[LogCategory] = &[
    LogCategory {
        name: "logStatusError",
        description:
            "Errors: bad calls, bad values, missions that cannot be flown (always reported).",
    },
    LogCategory {
        name: "logStatusWarning",
        description:
            "Warnings, e.g. a re-plan that leaves slots out of view or failed so the previous plan is kept (always reported).",
    },
    LogCategory {
        name: "logEvents",
        description: "Mission loading, planning and receding-horizon re-planning.",
    },
    LogCategory {
        name: "logCalls",
        description: "Every FMI call with its arguments.",
    },
];

/// Index of a category in [`LOG_CATEGORIES`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    /// `logStatusError`.
    Error = 0,
    /// `logStatusWarning`.
    Warning = 1,
    /// `logEvents`.
    Events = 2,
    /// `logCalls`.
    Calls = 3,
}

impl Category {
    /// The category's name.
    pub fn name(self) -> &'static str {
        LOG_CATEGORIES[self as usize].name
    }
}

/// Value references of the planner model.
pub mod planner_vr;

const fn param(
    name: &'static str,
    vr: u32,
    unit: Option<&'static str>,
    description: &'static str,
) -> Var {
    Var {
        name,
        vr,
        ty: VarType::Real,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 1,
        unit,
        description,
    }
}

const fn output(
    name: &'static str,
    vr: u32,
    ty: VarType,
    unit: Option<&'static str>,
    description: &'static str,
) -> Var {
    Var {
        name,
        vr,
        ty,
        causality: Causality::Output,
        variability: match ty {
            VarType::Real => Variability::Continuous,
            _ => Variability::Discrete,
        },
        len: 1,
        unit,
        description,
    }
}

const fn time_var() -> Var {
    Var {
        name: "time",
        vr: 0,
        ty: VarType::Real,
        causality: Causality::Independent,
        variability: Variability::Continuous,
        len: 1,
        unit: Some("s"),
        description: "Simulation time",
    }
}

use planner_vr as pv;

/// The planner model's variables. Every mission parameter has the name of its `[params]` entry in
/// a mission file; `start_m` and `bs_m` are arrays of 2 (FMI 2: `start_m[1]`, `start_m[2]`).
pub const PLANNER_VARS: &[Var] = &[
    time_var(),
    param("bandwidth_hz", pv::FIRST_PARAM, Some("Hz"), "BS transmit bandwidth B"),
    param("wavelength_m", 2, Some("m"), "Carrier wavelength lambda_c"),
    param("integration_time_s", 3, Some("s"), "Coherent SAR integration time T_d"),
    param("observation_angle_rad", 4, Some("rad"), "Observation (look) angle eta from nadir, in (0, pi/2)"),
    param("d_min_m", 5, Some("m"), "Required resolution d_min"),
    param("altitude_m", 6, Some("m"), "UAV altitude H"),
    param("max_speed_mps", 7, Some("m/s"), "Maximum UAV speed V_m"),
    param("slot_s", 8, Some("s"), "Slot length delta"),
    param("horizon_s", 9, Some("s"), "Mission horizon T (a whole number of slots)"),
    Var {
        name: "start_m",
        vr: pv::START_M,
        ty: VarType::Real,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 2,
        unit: Some("m"),
        description: "UAV start position q_0 (x, y)",
    },
    Var {
        name: "bs_m",
        vr: pv::BS_M,
        ty: VarType::Real,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 2,
        unit: Some("m"),
        description: "Base-station ground position q_b (x, y)",
    },
    param("bs_height_m", 14, Some("m"), "Base-station antenna height H_b"),
    param("sensing_radius_m", 15, Some("m"), "Radius r_s of the sensing area"),
    param("blade_power_w", 16, Some("W"), "Blade-profile power in hover P_0"),
    param("tip_speed_mps", 17, Some("m/s"), "Rotor blade tip speed U_tip"),
    param("induced_power_w", 18, Some("W"), "Induced power in hover P_1"),
    param("induced_velocity_mps", 19, Some("m/s"), "Mean rotor induced velocity in hover v_0"),
    param("rotor_solidity", 20, None, "Rotor solidity s"),
    param("rotor_disc_area_m2", 21, Some("m2"), "Rotor disc area A"),
    param("air_density_kgpm3", 22, Some("kg/m3"), "Air density rho"),
    param("fuselage_drag_ratio", 23, None, "Fuselage drag ratio d_f"),
    param("uav_mass_kg", 24, Some("kg"), "UAV mass (informational)"),
    param("max_accel_mps2", 25, Some("m/s2"), "Largest horizontal acceleration a_max between consecutive slots (default g tan 30 deg, a 30 deg tilt limit); the plans keep to it under dynamics = vehicle only"),
    Var {
        name: "start_velocity_mps",
        vr: pv::START_VELOCITY,
        ty: VarType::Real,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 2,
        unit: Some("m/s"),
        description: "UAV velocity at the start q_0 (v_x, v_y), from which the first slot's acceleration is counted. Both NaN (the start value): the mission file's start_velocity_mps, else the mission's rule (at rest, unless the first landmark comes too soon to reach the azimuth speed from rest). Both finite: this velocity (its speed at most max_speed_mps); one NaN and one finite is refused at ExitInitializationMode. After initialisation it reads the value in effect.",
    },
    param("max_jerk_mps3", pv::MAX_JERK, Some("m/s3"), "Largest horizontal jerk j_max: the acceleration between slots changes by at most j_max times slot_s from slot to slot (2/3 of that into the second slot), under dynamics = vehicle only. NaN (the start value): the mission file's max_jerk_mps3, else no jerk limit; a finite value must be > 0 and at most 500 (refused at ExitInitializationMode otherwise). After initialisation it reads the value in effect (NaN: none)"),
    param("resolution_margin_pct", 29, None, "Margin on the resolution requirement, percent of d_min_m (0 to 50, default 0): every plan, the re-plans included, is made for d_min (1 - margin/100) and the azimuth speed with it, and judged against d_min"),
    param("accel_margin_pct", 30, None, "Margin on max_accel_mps2, percent (0 to 50, default 0): the plans are made for a_max (1 - margin/100) under dynamics = vehicle, so the commanded acceleration keeps that room"),
    param("jerk_margin_pct", 31, None, "Margin on max_jerk_mps3, percent (0 to 50, default 0): the plans are made for j_max (1 - margin/100) under dynamics = vehicle; no effect without a jerk limit"),
    Var {
        name: "mission_file",
        vr: pv::MISSION_FILE,
        ty: VarType::String,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 1,
        unit: None,
        description: "Mission file (TOML or JSON); a relative path is looked up in the FMU's resources/ directory, then in the working directory. Its [params] are overridden by the parameters set through FMI.",
    },
    Var {
        name: "resolution",
        vr: pv::RESOLUTION,
        ty: VarType::String,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 1,
        unit: None,
        description: "Resolution requirement of the initial plan (cellsar-planner plan --resolution): general (the default: the worst width of the general resolution cell within d_min in every landmark slot, or where the geometry does not allow it the best effort, as cellsar-planner plan, cellsar run and the Python package plan) or paper (the paper's resolutions within d_min: the least-energy plan). Re-plans inside a step (after a landmark move) always use paper, to stay fast; output plan_resolution says which plan is flown.",
    },
    Var {
        name: "strict_resolution",
        vr: pv::STRICT_RESOLUTION,
        ty: VarType::Boolean,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 1,
        unit: None,
        description: "Initial plan under resolution general only (cellsar-planner plan --strict-resolution): refuse a mission whose resolution cell cannot be held within d_min in every landmark slot (ExitInitializationMode returns Error naming the first slot) instead of planning the best effort. Refused at ExitInitializationMode under resolution paper. Re-plans inside a step ignore it (they use paper).",
    },
    Var {
        name: "max_extra_energy_pct",
        vr: pv::MAX_EXTRA_ENERGY_PCT,
        ty: VarType::Real,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 1,
        unit: None,
        description: "Initial plan's best effort only (cellsar-planner plan --max-extra-energy-pct), in percent: the best-resolved plan that uses at most this many percent more energy than the least-energy plan; NaN (the default): no cap. A negative or infinite value is refused at the set, a finite one under resolution paper at ExitInitializationMode. Re-plans inside a step ignore it (they use paper).",
    },
    Var {
        name: "dynamics",
        vr: pv::DYNAMICS,
        ty: VarType::String,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        len: 1,
        unit: None,
        description: "Vehicle model of every plan, the initial plan and the re-plans inside a step (cellsar-planner plan --dynamics): vehicle (the velocity changes by at most max_accel_mps2 times slot_s from slot to slot, and by half that from start_velocity_mps into the first slot; a re-plan continues from the velocity flown, a slot average, with the whole max_accel_mps2 times slot_s; with max_jerk_mps3 the acceleration changes by at most max_jerk_mps3 times slot_s from slot to slot, a re-plan counting from the acceleration flown; each limit less its margin, *_margin_pct) or paper (the paper's model: the velocity may jump). The start value is the library's default (planner::DEFAULT_DYNAMICS).",
    },
    Var {
        name: "landmark_x_in_m",
        vr: pv::LANDMARK_X_IN,
        ty: VarType::Real,
        causality: Causality::Input,
        variability: Variability::Continuous,
        len: 1,
        unit: Some("m"),
        description: "Landmark of the current window, x: the window of slot ceil(t/slot_s), whose landmark landmark_x_m reports at the same time (NaN: the plan's own). A finite value (with landmark_y_in_m finite too) that differs from the plan's landmark moves it and re-plans the rest of the horizon, for the paper's resolution (output plan_resolution = 0). Infinite values are refused.",
    },
    Var {
        name: "landmark_y_in_m",
        vr: pv::LANDMARK_Y_IN,
        ty: VarType::Real,
        causality: Causality::Input,
        variability: Variability::Continuous,
        len: 1,
        unit: Some("m"),
        description: "Landmark of the current window, y (NaN: the plan's own; both inputs NaN or both finite)",
    },
    output("x_m", pv::X, VarType::Real, Some("m"), "UAV position x (linear within a slot)"),
    output("y_m", pv::Y, VarType::Real, Some("m"), "UAV position y (linear within a slot)"),
    output("speed_mps", pv::SPEED, VarType::Real, Some("m/s"), "True speed of the current slot"),
    output("heading_rad", pv::HEADING, VarType::Real, Some("rad"), "True heading of the current slot, in [0, 2 pi)"),
    output("power_w", pv::POWER, VarType::Real, Some("W"), "Propulsion power of the current slot"),
    output("energy_j", pv::ENERGY, VarType::Real, Some("J"), "Propulsion energy used since the start"),
    output("xc_m", pv::XC, VarType::Real, Some("m"), "Sensing centre x (H tan eta right of the track)"),
    output("yc_m", pv::YC, VarType::Real, Some("m"), "Sensing centre y"),
    output("landmark_x_m", pv::LANDMARK_X, VarType::Real, Some("m"), "Landmark of the current slot, x (NaN: none)"),
    output("landmark_y_m", pv::LANDMARK_Y, VarType::Real, Some("m"), "Landmark of the current slot, y (NaN: none)"),
    output("in_view", pv::IN_VIEW, VarType::Boolean, None, "The slot's landmark lies within r_s of the sensing centre at the slot end (true without a landmark)"),
    output("range_resolution_m", pv::RANGE_RES, VarType::Real, Some("m"), "General bistatic range resolution at the sensed point (erratum 11 (docs/paper-notes.md))"),
    output("azimuth_resolution_m", pv::AZIMUTH_RES, VarType::Real, Some("m"), "General azimuth (Doppler) resolution at the sensed point"),
    output("range_resolution_paper_m", pv::RANGE_RES_PAPER, VarType::Real, Some("m"), "The paper's range resolution c/(B (sin eta + sin theta)) at the sensing centre"),
    output("azimuth_resolution_paper_m", pv::AZIMUTH_RES_PAPER, VarType::Real, Some("m"), "The paper's azimuth resolution at the true speed"),
    output("worst_cell_width_m", pv::WORST_WIDTH, VarType::Real, Some("m"), "Worst width of the resolution cell at the sensed point (erratum 12 (docs/paper-notes.md))"),
    output("replan_count", pv::REPLAN_COUNT, VarType::Integer, None, "Receding-horizon re-plans so far"),
    output("slots_out_of_view", pv::SLOTS_OUT_OF_VIEW, VarType::Integer, None, "Slots of the plan (whole horizon, flown ones included) whose landmark is not within r_s of the sensing centre at the slot end, against the landmarks in effect (moved ones included); 0 for a plan that keeps every landmark in view"),
    output("plan_resolution", pv::PLAN_RESOLUTION, VarType::Integer, None, "Resolution requirement of the plan flown now: 1 = general, 0 = paper. Before any re-plan it is the parameter resolution (default general: the general cell as a best effort, the default of cellsar-planner plan, cellsar run and the Python package); after a re-plan (a landmark move) 0: every re-plan plans the least-energy plan for the paper's resolution, to stay fast"),
    output("commanded_accel_mps2", pv::COMMANDED_ACCEL, VarType::Real, Some("m/s2"), "Commanded horizontal acceleration of the current slot t, |v_t - v_(t-1)| / slot_s: the plan's slot-to-slot velocity difference over the slot duration, and into the first slot |v_1 - v_0| / (slot_s / 2) from v_0 = start_velocity_mps, the velocity at t = 0; the accel_mps2 of trajectory.csv; at most max_accel_mps2 (to 1e-6 relative) under dynamics = vehicle"),
    output("commanded_accel_x_mps2", pv::COMMANDED_ACCEL_X, VarType::Real, Some("m/s2"), "x component of commanded_accel_mps2: (v_t - v_(t-1)) / slot_s, x (over slot_s / 2 into the first slot)"),
    output("commanded_accel_y_mps2", pv::COMMANDED_ACCEL_Y, VarType::Real, Some("m/s2"), "y component of commanded_accel_mps2: (v_t - v_(t-1)) / slot_s, y (over slot_s / 2 into the first slot)"),
    output("z_m", pv::Z, VarType::Real, Some("m"), "UAV altitude (linear within a slot): the plan's altitude per slot for a mission with altitude = free (planned by the exact scheme, as cellsar-planner plan does), altitude_m for a fixed one; the z_m of trajectory.csv"),
    output("climb_mps", pv::CLIMB, VarType::Real, Some("m/s"), "Climb rate of the current slot, (z_t - z_(t-1)) / slot_s (negative: descent; 0 for a fixed altitude); the climb_mps of trajectory.csv"),
    Var {
        name: "plan_solve_time_s",
        vr: pv::SOLVE_TIME,
        ty: VarType::Real,
        causality: Causality::Local,
        variability: Variability::Discrete,
        len: 1,
        unit: Some("s"),
        description: "Wall time of the last plan or re-plan, all its planner calls included",
    },
    Var {
        name: "plan_lower_bound_j",
        vr: pv::LOWER_BOUND,
        ty: VarType::Real,
        causality: Causality::Local,
        variability: Variability::Discrete,
        len: 1,
        unit: Some("J"),
        description: "A lower bound on the energy of every trajectory that meets the mission (landmarks as moved) under the plan's vehicle model: the per-slot power floor over the speeds each slot must keep and the distances to fly between the start and the landmarks (docs/paper-notes.md); NaN where none holds",
    },
    Var {
        name: "plan_bound_gap_pct",
        vr: pv::BOUND_GAP,
        ty: VarType::Real,
        causality: Causality::Local,
        variability: Variability::Discrete,
        len: 1,
        unit: None,
        description: "How far the plan's energy over the whole horizon lies above plan_lower_bound_j, in % of the plan's energy",
    },
];

/// Value references of the landmark-mover model.
pub mod mover_vr {
    /// `time` (FMI 3 only).
    pub const TIME: u32 = 0;
    /// `move_at_s`.
    pub const MOVE_AT: u32 = 1;
    /// `offset_x_m`.
    pub const OFFSET_X: u32 = 2;
    /// `offset_y_m`.
    pub const OFFSET_Y: u32 = 3;
    /// `hold_s`.
    pub const HOLD: u32 = 4;
    /// `landmark_x_m` (input).
    pub const IN_X: u32 = 10;
    /// `landmark_y_m` (input).
    pub const IN_Y: u32 = 11;
    /// `landmark_x_out_m`.
    pub const OUT_X: u32 = 20;
    /// `landmark_y_out_m`.
    pub const OUT_Y: u32 = 21;
    /// `moved`.
    pub const MOVED: u32 = 22;
}

/// The landmark-mover model's variables: a small partner FMU for coupled co-simulation. It reads
/// the planner's current landmark and, from `move_at_s` on, outputs that landmark shifted by
/// (`offset_x_m`, `offset_y_m`) for `hold_s` seconds (NaN otherwise: "no override").
pub const MOVER_VARS: &[Var] = &[
    time_var(),
    param(
        "move_at_s",
        mover_vr::MOVE_AT,
        Some("s"),
        "Time of the move: at the end of the step that reaches it, the input landmark plus the offset is latched",
    ),
    param(
        "offset_x_m",
        mover_vr::OFFSET_X,
        Some("m"),
        "Shift of the landmark, x",
    ),
    param(
        "offset_y_m",
        mover_vr::OFFSET_Y,
        Some("m"),
        "Shift of the landmark, y",
    ),
    param(
        "hold_s",
        mover_vr::HOLD,
        Some("s"),
        "How long the moved landmark is output (0: until the end; negative values are refused)",
    ),
    Var {
        name: "landmark_x_m",
        vr: mover_vr::IN_X,
        ty: VarType::Real,
        causality: Causality::Input,
        variability: Variability::Continuous,
        len: 1,
        unit: Some("m"),
        description: "The planner's current landmark, x (connect landmark_x_m of CellsarPlanner; NaN: none)",
    },
    Var {
        name: "landmark_y_m",
        vr: mover_vr::IN_Y,
        ty: VarType::Real,
        causality: Causality::Input,
        variability: Variability::Continuous,
        len: 1,
        unit: Some("m"),
        description: "The planner's current landmark, y",
    },
    output(
        "landmark_x_out_m",
        mover_vr::OUT_X,
        VarType::Real,
        Some("m"),
        "Moved landmark x (NaN: no override)",
    ),
    output(
        "landmark_y_out_m",
        mover_vr::OUT_Y,
        VarType::Real,
        Some("m"),
        "Moved landmark y (NaN: no override)",
    ),
    output(
        "moved",
        mover_vr::MOVED,
        VarType::Boolean,
        None,
        "The moved landmark is being output",
    ),
];

/// Finds the variable (and element) that a value reference addresses. FMI 2 addresses array
/// elements one by one (`vr + i`); FMI 3 addresses a whole array by its `vr`.
pub fn lookup(table: &'static [Var], vr: u32, fmi2: bool) -> Option<(&'static Var, usize)> {
    table.iter().find_map(|v| {
        if fmi2 {
            if v.fmi3_only() {
                return None;
            }
            let off = vr.checked_sub(v.vr)? as usize;
            (off < v.len).then_some((v, off))
        } else {
            (v.vr == vr).then_some((v, 0))
        }
    })
}

/// The FMI 2 name of element `i` of `var` (`name[i+1]` for arrays).
pub fn fmi2_name(var: &Var, i: usize) -> String {
    if var.len == 1 {
        var.name.to_string()
    } else {
        format!("{}[{}]", var.name, i + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_table(table: &[Var]) {
        let mut names = std::collections::HashSet::new();
        let mut used = std::collections::HashSet::new();
        for v in table {
            assert!(names.insert(v.name), "duplicate name {}", v.name);
            for i in 0..v.len as u32 {
                assert!(
                    used.insert(v.vr + i),
                    "value reference {} used twice",
                    v.vr + i
                );
            }
            if let Some(u) = v.unit {
                assert!(
                    UNITS.iter().any(|x| x.name == u),
                    "unit {u} of {} undeclared",
                    v.name
                );
            }
            assert!(!v.description.is_empty());
        }
    }

    #[test]
    fn tables_are_consistent() {
        check_table(PLANNER_VARS);
        check_table(MOVER_VARS);
    }

    #[test]
    fn every_mission_parameter_is_a_variable() {
        for name in planner::Params::scalar_names() {
            let v = PLANNER_VARS
                .iter()
                .find(|v| v.name == name)
                .unwrap_or_else(|| panic!("parameter {name} missing from the table"));
            assert_eq!(v.causality, Causality::Parameter);
        }
        for name in ["start_m", "bs_m", "start_velocity_mps"] {
            assert!(PLANNER_VARS.iter().any(|v| v.name == name && v.len == 2));
        }
        // the optional jerk limit (NaN: none)
        assert!(PLANNER_VARS
            .iter()
            .any(|v| v.name == "max_jerk_mps3" && v.vr == planner_vr::MAX_JERK));
    }

    #[test]
    fn lookup_by_version() {
        let (v, i) = lookup(PLANNER_VARS, planner_vr::START_M + 1, true).unwrap();
        assert_eq!((v.name, i), ("start_m", 1));
        assert!(lookup(PLANNER_VARS, planner_vr::START_M + 1, false).is_none());
        assert!(lookup(PLANNER_VARS, planner_vr::TIME, true).is_none());
        assert_eq!(lookup(PLANNER_VARS, 0, false).unwrap().0.name, "time");
        assert_eq!(fmi2_name(v, 1), "start_m[2]");
    }
}
