//! Exact-geometry evaluation of any trajectory, independent of the optimiser (erratum 3 (docs/paper-notes.md)):
//! true speed, true heading, true sensing centre, true energy, the paper's and the general
//! resolutions, and the largest violation of every constraint of problem (p2).

use serde::{Deserialize, Serialize};

use crate::geometry::{
    azimuth_resolution_paper_m, bistatic_angle_rad, distance, heading_unit,
    range_resolution_general_m, range_resolution_paper_m, sensing_centre_m, Length, Point2,
    ResolutionCell, Vector2,
};
use crate::power::PowerModel;
use crate::{Mission, Trajectory};

mod vehicle;
pub use vehicle::{
    accel_time_s, accel_window_s, jerk_excess_mps2, jerk_window_s, over_jerk_limit,
    start_accel_time_s, start_to_slot_middle_s, start_velocity_lead_s, ACCEL_MARGIN_REL,
    ACCEL_TOL_REL, JERK_MARGIN_REL, JERK_TOL_REL,
};

/// Default tolerance for calling a trajectory feasible: metres for distances, m/s for speeds.
pub const FEASIBILITY_TOL: f64 = 1e-4;

/// Which resolution requirement a plan must meet in every landmark slot. Its names are the
/// same in serde, [`std::str::FromStr`], [`std::fmt::Display`] and `VARIANTS` (strum).
/// Its `Default` (`Paper`) is what a stored result without the field was made with (serde
/// reads old `summary.json` files with it); a new plan's default is
/// [`crate::DEFAULT_RESOLUTION`].
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
pub enum ResolutionMode {
    /// The paper's: δ_r ≤ d_min and δ_a ≤ d_min with its formulas (errata 2 (docs/paper-notes.md), 11).
    #[default]
    Paper,
    /// The general 2-D cell: its worst width (erratum 12 (docs/paper-notes.md)) ≤ d_min, which also keeps the
    /// plan away from blind geometry. Implies the paper's requirement in the default geometry.
    General,
}

impl ResolutionMode {
    /// All modes.
    pub const ALL: [ResolutionMode; 2] = [ResolutionMode::Paper, ResolutionMode::General];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        self.into()
    }
}

/// Which vehicle model a plan is made for.
///
/// Its `Default` (`Paper`) is what a stored result without the field was made with (serde
/// reads old `summary.json` files with it); a new plan's default is
/// [`crate::DEFAULT_DYNAMICS`].
///
/// Names are the same in serde, [`std::str::FromStr`], [`std::fmt::Display`] and `VARIANTS`.
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
pub enum Dynamics {
    /// The paper's model: any velocity in any slot, so the velocity may jump from slot to slot
    /// (the reproduction and the comparison schemes `paper`, `baseline`).
    #[default]
    Paper,
    /// A multirotor: the velocity changes by at most `max_accel_mps2` × δ from slot to slot, and
    /// by `max_accel_mps2` × δ/2 from the (instantaneous) start velocity into the first slot
    /// ([`accel_window_s`]; `Params::max_accel_mps2`, `Params::start_velocity_mps`); with a
    /// jerk limit (`Params::max_jerk_mps3`) the acceleration changes by at most
    /// `max_jerk_mps3` × [`jerk_window_s`] from slot to slot.
    Vehicle,
}

impl Dynamics {
    /// All models.
    pub const ALL: [Dynamics; 2] = [Dynamics::Paper, Dynamics::Vehicle];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        self.into()
    }
}

/// A landmark slot is called blind when the angle ψ between the range gradient and the track is
/// below this (the cell's cross-track extent is then more than 1/sin 5° ≈ 11 times its range width).
pub const BLIND_PSI_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// One slot of an evaluated trajectory. Points and vectors are `[f64; 2]` so that
/// `summary.json` and the wire messages keep their format.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SlotEval {
    /// Slot index t (1-based).
    pub t: usize,
    /// End time of the slot, tδ, s.
    pub t_s: f64,
    /// Position q_t, m.
    pub pos_m: [f64; 2],
    /// True velocity (q_t − q_{t−1})/δ, m/s.
    pub velocity_mps: [f64; 2],
    /// True speed, m/s.
    pub speed_mps: f64,
    /// True heading α_t, rad (kept from the previous slot in hover).
    pub heading_rad: f64,
    /// True sensing centre q_c^t, m.
    pub centre_m: [f64; 2],
    /// The landmark of this slot, if any.
    pub landmark_m: Option<[f64; 2]>,
    /// Distance from the true centre to the landmark, m.
    pub centre_error_m: Option<f64>,
    /// Landmark within the sensing radius of the true centre (true when the slot has no landmark).
    pub in_view: bool,
    /// True propulsion power P(V_t), W.
    pub power_w: f64,
    /// Energy of this slot, P(V_t) δ, J.
    pub slot_energy_j: f64,
    /// Cumulative energy up to the end of this slot, J.
    pub energy_j: f64,
    /// The paper's δ_r at the true centre, m.
    pub range_resolution_paper_m: f64,
    /// The paper's δ_a at the true speed, m.
    pub azimuth_resolution_paper_m: f64,
    /// The general bistatic δ_r (erratum 11 (docs/paper-notes.md)) at the sensed point, m.
    pub range_resolution_general_m: f64,
    /// Bistatic angle β at the sensed point, rad.
    pub bistatic_angle_rad: f64,
    /// |g|, norm of the bistatic range gradient at the sensed point.
    pub grad_norm: f64,
    /// Angle ψ between g and the track direction, rad.
    pub psi_rad: f64,
    /// Along-track width of the resolution cell, m.
    pub along_track_width_m: f64,
    /// Cross-track width of the resolution cell, m.
    pub cross_track_width_m: f64,
    /// Worst width of the resolution cell, m (erratum 12 (docs/paper-notes.md)).
    pub worst_width_m: f64,
    /// Acceleration into this slot, ‖v_t − v_{t−1}‖ / δ, and for the first slot ‖v_1 − v_0‖ / (δ/2)
    /// with v_0 the start velocity ([`accel_window_s`]), m/s².
    #[serde(default)]
    pub accel_mps2: f64,
    /// Jerk into this slot, ‖a_t − a_{t−1}‖ / [`jerk_window_s`] with a_t the acceleration into
    /// slot t ([`SlotEval::accel_mps2`] as a vector), m/s³; in the first slot from the mission's
    /// `start_accel_mps2`, and 0 where it states none (no acceleration before the start is
    /// assumed).
    #[serde(default)]
    pub jerk_mps3: f64,
    /// Altitude H_t at the end of the slot, m: the mission's `altitude_m` unless a profile is
    /// evaluated ([`evaluate_with_altitudes`]); 0 in results stored before the field.
    #[serde(default)]
    pub z_m: f64,
    /// Vertical rate of the slot, (H_t − H_{t−1}) / δ with H_0 = `altitude_m`, m/s (up
    /// positive; 0 at a fixed altitude).
    #[serde(default)]
    pub climb_mps: f64,
}

/// The largest violation of each constraint over the slots it applies to (0 = satisfied).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Violations {
    /// max over landmark slots of (‖q_g − q_c‖ − r_s)⁺, m.
    pub sensing_m: f64,
    /// max over landmark slots of (V_min − V_t)⁺ (azimuth requirement on the true speed), m/s.
    pub min_speed_mps: f64,
    /// max over all slots of (V_t − V_m)⁺, m/s.
    pub max_speed_mps: f64,
    /// max over landmark slots of (δ_r − d_min)⁺ with the paper's δ_r at the true centre, m.
    pub range_paper_m: f64,
    /// max over landmark slots of (worst cell width − d_min)⁺ (general cell, erratum 12 (docs/paper-notes.md)), m.
    pub worst_width_m: f64,
    /// max over all slots of ([`SlotEval::accel_mps2`] − a_max)⁺ (the vehicle's acceleration limit;
    /// counted in feasibility only under [`Dynamics::Vehicle`]), m/s².
    #[serde(default)]
    pub accel_mps2: f64,
    /// max over all slots of ([`SlotEval::jerk_mps3`] − j_max)⁺ (the vehicle's jerk limit, 0
    /// without one; counted in feasibility only under [`Dynamics::Vehicle`]), m/s³.
    #[serde(default)]
    pub jerk_mps3: f64,
    /// max over all slots of the altitude outside [`min_altitude_m`, `max_altitude_m`] (the
    /// mission's `altitude_m` for both at a fixed altitude), m.
    #[serde(default)]
    pub altitude_m: f64,
    /// max over all slots of (v_z − `max_climb_mps`)⁺ and (−v_z − `max_descent_mps`)⁺, m/s.
    #[serde(default)]
    pub climb_mps: f64,
}

impl Violations {
    /// True when the constraints of (p2) (sensing, azimuth, max speed, paper range) hold within `tol`.
    pub fn p2_ok(&self, tol: f64) -> bool {
        self.sensing_m <= tol
            && self.min_speed_mps <= tol
            && self.max_speed_mps <= tol
            && self.range_paper_m <= tol
    }

    /// True when the altitude bounds and the climb and descent rates hold within `tol` (always
    /// for a trajectory at the mission's fixed altitude).
    pub fn altitude_ok(&self, tol: f64) -> bool {
        self.altitude_m <= tol && self.climb_mps <= tol
    }
}

/// A trajectory evaluated on the exact geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// Per-slot values.
    pub slots: Vec<SlotEval>,
    /// True propulsion energy Σ P(V_t) δ, J.
    pub energy_j: f64,
    /// Largest violations.
    pub violations: Violations,
    /// Least true speed over all slots, m/s.
    pub min_speed_mps: f64,
    /// Largest true speed over all slots, m/s.
    pub max_speed_mps: f64,
    /// Path length, m.
    pub length_m: f64,
    /// Slots with a landmark out of view.
    pub slots_out_of_view: usize,
    /// Landmark slots whose worst cell width exceeds d_min.
    pub slots_unresolved: usize,
    /// Landmark slots in blind geometry (ψ < [`BLIND_PSI_RAD`]).
    pub slots_blind: usize,
    /// Largest acceleration between consecutive slots (the first from the start velocity), m/s².
    #[serde(default)]
    pub max_accel_mps2: f64,
    /// The acceleration limit the violation is measured against, m/s².
    #[serde(default)]
    pub accel_limit_mps2: f64,
    /// Largest jerk between consecutive slot accelerations ([`SlotEval::jerk_mps3`]), m/s³.
    #[serde(default)]
    pub max_jerk_mps3: f64,
    /// The jerk limit the violation is measured against (the mission's `max_jerk_mps3`), m/s³;
    /// `None`: the mission sets none.
    #[serde(default)]
    pub jerk_limit_mps3: Option<f64>,
    /// Altitude at the start H_0 (the mission's `altitude_m`), m; 0 in results stored before
    /// the field.
    #[serde(default)]
    pub start_altitude_m: f64,
}

impl Evaluation {
    /// True when every constraint of (p2) holds on the exact geometry within [`FEASIBILITY_TOL`],
    /// and the altitude bounds and rates ([`Violations::altitude_ok`]).
    pub fn is_feasible(&self) -> bool {
        self.violations.p2_ok(FEASIBILITY_TOL) && self.violations.altitude_ok(FEASIBILITY_TOL)
    }

    /// [`Evaluation::is_feasible`], plus, under [`ResolutionMode::General`], the worst width of
    /// the resolution cell ≤ d_min in every landmark slot.
    pub fn is_feasible_for(&self, mode: ResolutionMode) -> bool {
        self.is_feasible()
            && match mode {
                ResolutionMode::Paper => true,
                ResolutionMode::General => self.violations.worst_width_m <= FEASIBILITY_TOL,
            }
    }

    /// Within the acceleration limit in every slot, to [`ACCEL_TOL_REL`], and within the jerk
    /// limit, where the mission sets one, to [`JERK_TOL_REL`].
    pub fn is_flyable(&self) -> bool {
        self.violations.accel_mps2 <= ACCEL_TOL_REL * self.accel_limit_mps2
            && self
                .jerk_limit_mps3
                .is_none_or(|limit| self.violations.jerk_mps3 <= JERK_TOL_REL * limit)
    }

    /// [`Evaluation::is_feasible_for`], plus, under [`Dynamics::Vehicle`], the acceleration
    /// and jerk limits in every slot ([`Evaluation::is_flyable`]).
    pub fn is_feasible_with(&self, mode: ResolutionMode, dynamics: Dynamics) -> bool {
        self.is_feasible_for(mode) && self.meets(dynamics)
    }

    /// Whether the plan meets the vehicle model `dynamics` (always under [`Dynamics::Paper`]).
    pub fn meets(&self, dynamics: Dynamics) -> bool {
        match dynamics {
            Dynamics::Paper => true,
            Dynamics::Vehicle => self.is_flyable(),
        }
    }
}

/// An altitude profile that does not fit its trajectory.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("altitude profile: {got} altitudes for a trajectory of {expected} slots")]
pub struct AltitudeProfileError {
    /// The trajectory's number of slots.
    pub expected: usize,
    /// The number of altitudes given.
    pub got: usize,
}

/// Evaluates `traj` against `mission` on the exact geometry, at the mission's altitude
/// `altitude_m` in every slot.
pub fn evaluate(mission: &Mission, traj: &Trajectory) -> Evaluation {
    evaluate_profile(mission, traj, None)
}

/// Evaluates `traj` with the altitude H_t = `altitudes_m[t − 1]` in slot t (H_0 = the mission's
/// `altitude_m`): every quantity that depends on H takes the slot's (the sensing centre
/// H_t tan η ahead of the track's normal, the sensing radius `sensing_radius_m` H_t /
/// `altitude_m` of the same antenna (paper-notes erratum 5), V_min, the paper's and the
/// general resolutions and cell), the power is [`PowerModel::power_3d_w`] at the slot's climb
/// rate, and the altitude bounds and rates are checked ([`Violations::altitude_m`],
/// [`Violations::climb_mps`]). A profile at `altitude_m` throughout gives [`evaluate`]'s result.
pub fn evaluate_with_altitudes(
    mission: &Mission,
    traj: &Trajectory,
    altitudes_m: &[f64],
) -> Result<Evaluation, AltitudeProfileError> {
    if altitudes_m.len() != traj.slots() {
        return Err(AltitudeProfileError {
            expected: traj.slots(),
            got: altitudes_m.len(),
        });
    }
    Ok(evaluate_profile(mission, traj, Some(altitudes_m)))
}

/// [`evaluate_with_altitudes`], `None` for the mission's altitude in every slot.
fn evaluate_profile(
    mission: &Mission,
    traj: &Trajectory,
    altitudes_m: Option<&[f64]>,
) -> Evaluation {
    let p = mission.params();
    let model = PowerModel::new(p);
    let (lowest_m, highest_m) = crate::altitude::bounds_m(p);
    let mut prev_z = p.altitude_m;
    let headings = traj.headings_rad();
    let mut slots = Vec::with_capacity(traj.slots());
    let mut viol = Violations::default();
    let mut energy = 0.0;
    let mut min_speed = f64::INFINITY;
    let mut max_speed: f64 = 0.0;
    let mut out_of_view = 0;
    let mut unresolved = 0;
    let mut blind = 0;
    let mut max_accel: f64 = 0.0;
    let mut max_jerk: f64 = 0.0;
    let mut prev_vel = mission.start_velocity_mps();
    let mut prev_accel: Option<Vector2<f64>> = p.start_accel_mps2.map(Vector2::from);
    for t in 1..=traj.slots() {
        let pos = traj.q(t);
        let vel = traj.velocity_mps(t);
        let change = Vector2::from(vel) - Vector2::from(prev_vel);
        let accel = change.length() / accel_window_s(p, t);
        let accel_vec = change / accel_window_s(p, t);
        let jerk = match (prev_accel, jerk_window_s(p, t)) {
            (Some(a), Some(w)) => (accel_vec - a).length() / w,
            _ => 0.0,
        };
        prev_vel = vel;
        prev_accel = Some(accel_vec);
        max_accel = max_accel.max(accel);
        max_jerk = max_jerk.max(jerk);
        let speed = Vector2::from(vel).length();
        let heading = headings[t - 1];
        let z = altitudes_m
            .and_then(|a| a.get(t - 1).copied())
            .unwrap_or(p.altitude_m);
        let climb = (z - prev_z) / p.slot_s;
        prev_z = z;
        viol.altitude_m = viol.altitude_m.max(lowest_m - z).max(z - highest_m);
        viol.climb_mps = viol
            .climb_mps
            .max(climb - p.max_climb_mps)
            .max(-climb - p.max_descent_mps);
        // the slot's parameters: the mission's own at its altitude (bit for bit the fixed plans)
        let at_z;
        let ps = if z == p.altitude_m {
            p
        } else {
            at_z = crate::altitude::params_at(p, z);
            &at_z
        };
        let v_min = ps.min_speed_mps();
        let centre = sensing_centre_m(pos, heading, ps.centre_offset_m());
        let landmark = mission.target_m(t);
        let power = model.power_3d_w(speed, climb);
        let slot_energy = power * p.slot_s;
        energy += slot_energy;
        min_speed = min_speed.min(speed);
        max_speed = max_speed.max(speed);
        viol.max_speed_mps = viol.max_speed_mps.max(speed - p.max_speed_mps);
        let sensed = landmark.unwrap_or(centre);
        // Velocity for the Doppler geometry: the true one, or the heading at unit speed in hover
        // (the cell's shape; its along-track width is then infinite through δ_a anyway).
        let cell_vel = if speed > 0.0 {
            vel
        } else {
            (heading_unit(heading) * 1e-12).into()
        };
        let cell = ResolutionCell::new(ps, pos, cell_vel, sensed);
        let range_paper = range_resolution_paper_m(ps, centre);
        let az_paper = azimuth_resolution_paper_m(ps, speed);
        let centre_error = landmark.map(|g| distance(&Point2::from(g), &Point2::from(centre)));
        let in_view = centre_error.is_none_or(|e| e <= ps.sensing_radius_m);
        if let Some(e) = centre_error {
            viol.sensing_m = viol.sensing_m.max(e - ps.sensing_radius_m);
            viol.min_speed_mps = viol.min_speed_mps.max(v_min - speed);
            viol.range_paper_m = viol.range_paper_m.max(range_paper - p.d_min_m);
            viol.worst_width_m = viol.worst_width_m.max(cell.worst_width_m - p.d_min_m);
            if !in_view {
                out_of_view += 1;
            }
            if cell.worst_width_m > p.d_min_m || cell.worst_width_m.is_nan() {
                unresolved += 1;
            }
            if cell.psi_rad < BLIND_PSI_RAD || cell.psi_rad.is_nan() {
                blind += 1;
            }
        }
        slots.push(SlotEval {
            t,
            t_s: t as f64 * p.slot_s,
            pos_m: pos,
            velocity_mps: vel,
            speed_mps: speed,
            heading_rad: heading,
            centre_m: centre,
            landmark_m: landmark,
            centre_error_m: centre_error,
            in_view,
            power_w: power,
            slot_energy_j: slot_energy,
            energy_j: energy,
            range_resolution_paper_m: range_paper,
            azimuth_resolution_paper_m: az_paper,
            range_resolution_general_m: range_resolution_general_m(ps, pos, sensed),
            bistatic_angle_rad: bistatic_angle_rad(ps, pos, sensed),
            grad_norm: cell.grad_norm,
            psi_rad: cell.psi_rad,
            along_track_width_m: cell.along_track_width_m,
            cross_track_width_m: cell.cross_track_width_m,
            worst_width_m: cell.worst_width_m,
            accel_mps2: accel,
            jerk_mps3: jerk,
            z_m: z,
            climb_mps: climb,
        });
    }
    viol.accel_mps2 = (max_accel - p.max_accel_mps2).max(0.0);
    viol.jerk_mps3 = p.max_jerk_mps3.map_or(0.0, |j| (max_jerk - j).max(0.0));
    // clamp negatives (the max started at 0 so they are ≥ 0 already, except NaN)
    for v in [
        &mut viol.sensing_m,
        &mut viol.min_speed_mps,
        &mut viol.max_speed_mps,
        &mut viol.range_paper_m,
        &mut viol.worst_width_m,
        &mut viol.accel_mps2,
        &mut viol.jerk_mps3,
        &mut viol.altitude_m,
        &mut viol.climb_mps,
    ] {
        if v.is_nan() {
            *v = f64::INFINITY;
        }
    }
    Evaluation {
        length_m: traj.length_m(),
        slots,
        energy_j: energy,
        violations: viol,
        min_speed_mps: if min_speed.is_finite() {
            min_speed
        } else {
            0.0
        },
        max_speed_mps: max_speed,
        slots_out_of_view: out_of_view,
        slots_unresolved: unresolved,
        slots_blind: blind,
        max_accel_mps2: max_accel,
        accel_limit_mps2: p.max_accel_mps2,
        max_jerk_mps3: max_jerk,
        jerk_limit_mps3: p.max_jerk_mps3,
        start_altitude_m: p.altitude_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{LandmarkWindow, LandmarksSpec};
    use crate::Params;

    /// A straight track north at 20 m/s with the landmark exactly at the broadside centre.
    #[test]
    fn straight_track_closed_form() {
        let mut p = Params::default();
        p.horizon_s = 10.0;
        p.start_m = [-1000.0, 0.0];
        let spec = LandmarksSpec {
            points: Some(vec![LandmarkWindow {
                x_m: 0.0,
                y_m: 100.0,
                from_s: 0.0,
                to_s: 10.0,
            }]),
            ..Default::default()
        };
        let m = Mission::new("t", p.clone(), &spec).unwrap();
        let traj = Trajectory {
            slot_s: 0.5,
            start_m: p.start_m,
            pos_m: (1..=20).map(|t| [-1000.0, 10.0 * t as f64]).collect(),
        };
        let e = evaluate(&m, &traj);
        let model = PowerModel::new(&p);
        assert!((e.energy_j - 10.0 * model.power_w(20.0)).abs() < 1e-9);
        assert!(e.is_feasible());
        // centre x = 0, y = q_y; farthest from (0,100) at t=20 (y=200): 100 m
        assert!((e.slots[19].centre_error_m.unwrap() - 100.0).abs() < 1e-9);
        assert_eq!(e.violations.sensing_m, 0.0);
        assert!((e.slots[0].centre_m[0]).abs() < 1e-9);
    }

    #[test]
    fn violations_are_reported() {
        let mut p = Params::default();
        p.horizon_s = 1.0;
        let spec = LandmarksSpec {
            points: Some(vec![LandmarkWindow {
                x_m: 5000.0,
                y_m: 0.0,
                from_s: 0.0,
                to_s: 1.0,
            }]),
            ..Default::default()
        };
        let m = Mission::new("t", p.clone(), &spec).unwrap();
        let traj = Trajectory {
            slot_s: 0.5,
            start_m: p.start_m,
            pos_m: vec![p.start_m, [p.start_m[0] + 40.0, p.start_m[1]]],
        };
        let e = evaluate(&m, &traj);
        assert!(!e.is_feasible());
        assert!(e.violations.sensing_m > 4000.0);
        assert!((e.violations.min_speed_mps - p.min_speed_mps()).abs() < 1e-9); // slot 1 hovers
        assert!((e.violations.max_speed_mps - 30.0).abs() < 1e-9); // 80 m/s in slot 2
        assert_eq!(e.slots_out_of_view, 2);
    }
}
