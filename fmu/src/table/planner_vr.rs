/// `time` (FMI 3 only).
pub const TIME: u32 = 0;
/// First scalar/array mission parameter.
pub const FIRST_PARAM: u32 = 1;
/// `start_m` (array of 2).
pub const START_M: u32 = 10;
/// `bs_m` (array of 2).
pub const BS_M: u32 = 12;
/// `start_velocity_mps` (array of 2).
pub const START_VELOCITY: u32 = 26;
/// `max_jerk_mps3` (NaN: the mission file's, else none).
pub const MAX_JERK: u32 = 28;
/// `mission_file`.
pub const MISSION_FILE: u32 = 100;
/// `resolution` (String): the initial plan's resolution requirement.
pub const RESOLUTION: u32 = 101;
/// `strict_resolution` (Boolean).
pub const STRICT_RESOLUTION: u32 = 102;
/// `max_extra_energy_pct`.
pub const MAX_EXTRA_ENERGY_PCT: u32 = 103;
/// `dynamics` (String): the vehicle model of every plan.
pub const DYNAMICS: u32 = 104;
/// `landmark_x_in_m`.
pub const LANDMARK_X_IN: u32 = 200;
/// `landmark_y_in_m`.
pub const LANDMARK_Y_IN: u32 = 201;
/// `x_m`.
pub const X: u32 = 300;
/// `y_m`.
pub const Y: u32 = 301;
/// `speed_mps`.
pub const SPEED: u32 = 302;
/// `heading_rad`.
pub const HEADING: u32 = 303;
/// `power_w`.
pub const POWER: u32 = 304;
/// `energy_j`.
pub const ENERGY: u32 = 305;
/// `xc_m`.
pub const XC: u32 = 306;
/// `yc_m`.
pub const YC: u32 = 307;
/// `landmark_x_m`.
pub const LANDMARK_X: u32 = 308;
/// `landmark_y_m`.
pub const LANDMARK_Y: u32 = 309;
/// `in_view`.
pub const IN_VIEW: u32 = 310;
/// `range_resolution_m`.
pub const RANGE_RES: u32 = 311;
/// `azimuth_resolution_m`.
pub const AZIMUTH_RES: u32 = 312;
/// `range_resolution_paper_m`.
pub const RANGE_RES_PAPER: u32 = 313;
/// `azimuth_resolution_paper_m`.
pub const AZIMUTH_RES_PAPER: u32 = 314;
/// `worst_cell_width_m`.
pub const WORST_WIDTH: u32 = 315;
/// `replan_count`.
pub const REPLAN_COUNT: u32 = 316;
/// `slots_out_of_view`.
pub const SLOTS_OUT_OF_VIEW: u32 = 317;
/// `plan_resolution`.
pub const PLAN_RESOLUTION: u32 = 318;
/// `commanded_accel_mps2`.
pub const COMMANDED_ACCEL: u32 = 319;
/// `commanded_accel_x_mps2`.
pub const COMMANDED_ACCEL_X: u32 = 320;
/// `commanded_accel_y_mps2`.
pub const COMMANDED_ACCEL_Y: u32 = 321;
/// `z_m`.
pub const Z: u32 = 322;
/// `climb_mps`.
pub const CLIMB: u32 = 323;
/// `plan_solve_time_s` (local).
pub const SOLVE_TIME: u32 = 400;
/// `plan_lower_bound_j` (local).
pub const LOWER_BOUND: u32 = 401;
/// `plan_bound_gap_pct` (local).
pub const BOUND_GAP: u32 = 402;
/// Hidden (not in modelDescription.xml) Integer/Int32 variable for tests, settable only in
/// a build with the `test-hooks` feature (elsewhere an unknown value reference): setting it
/// to [`crate::core::PANIC_IN_DO_STEP`] makes the next doStep panic inside the model core,
/// to prove that no panic crosses the C boundary.
pub const DEBUG_INJECT_PANIC: u32 = 0x7FFF_0001;
