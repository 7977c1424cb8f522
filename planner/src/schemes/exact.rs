//! The `exact` scheme: SCA on the exact geometry, every iterate feasible on it.
//!
//! Power is tied to the true velocity v_t = q_t − q_{t−1} (Zeng et al.): the induced term uses an
//! auxiliary a_t with 1/a_t² ≤ a_t² + ‖v_t‖²/(δ² v0²), whose right side is replaced by its tangent
//! at the previous iterate (a global lower bound, so the surrogate over-estimates the power).
//!
//! The true sensing centre c_t = q_t + D J v_t/‖v_t‖ (D = H tan η, J = rotation by −90°) is
//! replaced by its first-order expansion c̃_t around the previous velocity u_t, and the sensing
//! disc is shrunk by a bound of the expansion error: for the unit-vector map in the plane,
//! ‖c_t − c̃_t‖ ≤ κ_t ‖v_t − u_t‖² with κ_t = D / (√3 s_t²), valid while every velocity on the
//! segment [u_t, v_t] has norm ≥ s_t. That norm bound is enforced by the linear constraint
//! ĥ_t·v_t ≥ s_t (ĥ_t = u_t/‖u_t‖), which also carries the azimuth requirement ‖v_t‖ ≥ δ V_min
//! conservatively. The subproblem is therefore a convex inner approximation of the exact
//! problem that is tight at the previous iterate: each iterate is exactly feasible and its true
//! energy is no larger than the previous one (a majorisation–minimisation sequence).

use crate::evaluate::{Dynamics, ResolutionMode};
use crate::geometry::{heading_unit, Length, Point2, Vector2, RIGHT_TURN};
use crate::power::PowerModel;
use crate::socp::{Lin, ProblemBuilder};
use crate::{Mission, Trajectory};

mod altitude;
mod cell;
mod landmark;
mod vehicle;
pub use altitude::cell_altitude_margin;
use altitude::{altitude_rows, AltitudeVars};
pub use cell::{cell_margin, BEST_EFFORT_CELL_TARGET_FRACTION};

/// 1/√3: sup of ‖D²u‖/2 times s² for the unit-vector map u(v) = v/‖v‖ in the plane is 1/√3
/// (‖D²u(v)[d, d]‖ ≤ (2/√3)‖d‖²/‖v‖²).
pub const CENTRE_CURVATURE_BOUND: f64 = 0.577_350_269_189_625_8;

/// Unit of the speed variables V, w = V², z = V³ in the cone programs: with V in m/s, z ≈ V³
/// spans 10³–10⁵ next to auxiliaries of order 0.1, which Clarabel solves inaccurately and slowly;
/// in units of 20 m/s all are of order 1.
pub const SPEED_UNIT_MPS: f64 = 20.0;

/// Safety margin on the sensing radius, m (solver tolerances stay inside it).
pub const SENSING_MARGIN_M: f64 = 1e-3;
/// The speed a landmark slot must keep ([`ExactTuning::speed_keep_fraction`] of the previous
/// one) is capped at this fraction of the speed limit: a given path may be faster than the
/// limit, and a floor above the limit would make the program infeasible.
pub const KEEP_CAP_OF_LIMIT: f64 = 0.95;
/// Safety margin on the speed limits, m/s.
pub const SPEED_MARGIN_MPS: f64 = 1e-4;

/// What the `exact` machinery minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExactObjective {
    /// True propulsion energy (the `exact` scheme).
    Energy,
    /// Flight distance Σ‖q_t − q_{t−1}‖ (the baseline on the exact geometry).
    Distance,
}

impl ExactObjective {
    /// The objective's true value of an evaluated trajectory: energy in J or distance in m.
    pub fn true_value(self, ev: &crate::Evaluation) -> f64 {
        match self {
            ExactObjective::Energy => ev.energy_j,
            ExactObjective::Distance => ev.length_m,
        }
    }
}

/// Tunables of one exact-SCA subproblem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactTuning {
    /// Fraction of the previous speed below which a landmark slot's speed may not drop in one
    /// iteration (keeps the centre-error bound finite); never above [`KEEP_CAP_OF_LIMIT`] of
    /// the speed limit.
    pub speed_keep_fraction: f64,
    /// Optional trust radius on ‖v_t − u_t‖ in landmark slots, m (set after a rejected step).
    pub trust_radius_m: Option<f64>,
    /// Factor on the centre-error bound κ: 1 is the proven bound (the subproblem is then an inner
    /// approximation); below 1 the model is optimistic and the driver must check each step on the
    /// exact geometry (it does, and falls back to 1 on a rejected step).
    pub kappa_scale: f64,
    /// Elastic mode (for an infeasible start): each landmark slot gets a violation slack σ_t
    /// (m of sensing radius, m/s of azimuth speed, m of range keep-out) charged at this many
    /// objective units (J or m) per unit; `None` = all constraints hard.
    pub elastic_weight: Option<f64>,
    /// Keep the landmark in view over the whole slot, not only at its end: the centre sweeps the
    /// segment from q_{t−1} + D n_t to q_t + D n_t during slot t (straight flight). Used on the
    /// coarse grid so that its solution, interpolated to the fine slots, stays feasible.
    pub whole_slot_sensing: bool,
    /// Which resolution requirement to impose in landmark slots.
    pub resolution: ResolutionMode,
    /// Best effort under [`ResolutionMode::General`]: each landmark slot's cell constraints get
    /// a deficit slack ρ_t ≥ 0 (m, linearised
    /// [`slot_deficit_m`](crate::shortfall::slot_deficit_m) at the previous iterate) charged at
    /// this many objective units (J) per metre; `None` = the cell constraints are hard.
    pub cell_slack_weight: Option<f64>,
    /// Cap on the surrogate energy, J (it over-estimates the true energy and is tight at the
    /// previous iterate, so an iterate that meets it has at most this true energy).
    pub energy_cap_j: Option<f64>,
    /// The vehicle model: under [`Dynamics::Vehicle`] every slot's velocity differs from the
    /// previous one by at most a_max δ (the first from the mission's start velocity by
    /// a_max δ/2, [`ExactTuning::first_accel_window_s`]), one
    /// second-order cone per slot (exact, no linearisation), and with the mission's jerk limit
    /// the acceleration from slot to slot by at most j_max × [`crate::evaluate::jerk_window_s`],
    /// one more cone per slot from the second on; in elastic mode each gets a slack.
    pub dynamics: Dynamics,
    /// The time over which the first slot's (average) velocity may differ from the start
    /// velocity, s (`None`: [`crate::evaluate::accel_window_s`] of slot 1, δ/2 from an
    /// instantaneous start velocity: from v₀ at constant acceleration a,
    /// q₁ − q₀ − v₀ δ = a δ²/2, so ‖v̄₁ − v₀‖ ≤ a_max δ/2). A coarse level of slots Δ sets Δ/2
    /// plus the start velocity's lead, so that its track, with the velocity interpolated linearly
    /// between slot middles onto the finer slots δ, keeps the limit there too.
    pub first_accel_window_s: Option<f64>,
}

impl Default for ExactTuning {
    fn default() -> Self {
        Self {
            speed_keep_fraction: 0.85,
            trust_radius_m: None,
            kappa_scale: 1.0,
            elastic_weight: None,
            whole_slot_sensing: false,
            resolution: ResolutionMode::Paper,
            cell_slack_weight: None,
            energy_cap_j: None,
            dynamics: Dynamics::Paper,
            first_accel_window_s: None,
        }
    }
}

/// Variable layout of one slot.
#[derive(Debug, Clone, Copy)]
struct SlotVars {
    x: usize,
    y: usize,
    /// Speed epigraph V_t ≥ ‖v_t‖/δ, in units of [`SPEED_UNIT_MPS`].
    v: usize,
    /// Energy only: induced auxiliary a_t, its helper s_t (s a ≥ 1, s² ≤ L), w_t ≥ V², z_t ≥ V³
    /// (w, z in units of SPEED_UNIT_MPS², SPEED_UNIT_MPS³).
    energy: Option<[usize; 4]>,
    /// Landmark slots: centre-error budget e_t.
    e: Option<usize>,
    /// Elastic mode: violation slack σ_t.
    sigma: Option<usize>,
    /// General resolution with hard cell constraints: m_t ≥ ‖q_t − q_t^(ℓ)‖ (for the position
    /// margin of the cell terms).
    shift: Option<usize>,
    /// Best effort: the cell's deficit slack ρ_t, m.
    rho: Option<usize>,
    /// Elastic mode under the vehicle dynamics: the acceleration slack τ_t, m of step change.
    accel_slack: Option<usize>,
    /// Elastic mode under the vehicle dynamics with a jerk limit, in every slot with a jerk
    /// cone: the jerk slack, m of change of the step's change (δ² × the acceleration change).
    jerk_slack: Option<usize>,
    /// Free altitude: the slot's altitude variables.
    alt: Option<AltitudeVars>,
}

/// The linearisation data of one slot, from the previous iterate.
#[derive(Debug, Clone, Copy)]
struct SlotLin {
    /// Previous step u_t = q_t − q_{t−1}, m.
    step_m: Vector2<f64>,
    /// Unit heading of u_t (or the carried-over heading in hover).
    dir: Vector2<f64>,
    /// Induced factor ι(‖u_t‖/δ).
    aux: f64,
    /// Previous true centre.
    centre_m: Point2<f64>,
}

/// The exact-geometry SCA subproblem for one iteration.
#[derive(Debug)]
pub struct ExactSubproblem {
    /// The assembled cone program.
    pub builder: ProblemBuilder,
    vars: Vec<SlotVars>,
    objective_scale: f64,
    objective: ExactObjective,
    constant_j: f64,
    /// Free altitude: the altitude bounds, for [`ExactSubproblem::altitudes_m`].
    altitude_bounds_m: Option<(f64, f64)>,
}

impl ExactSubproblem {
    /// Assembles the subproblem around the iterate `prev` (at the mission's altitude).
    pub fn build(
        mission: &Mission,
        prev: &Trajectory,
        objective: ExactObjective,
        tuning: &ExactTuning,
    ) -> Self {
        Self::build_profile(mission, prev, None, objective, tuning)
    }

    /// Assembles the subproblem with the altitude H_t of every slot a variable (module
    /// `altitude`), around the iterate `prev` flown at `prev_altitudes_m` (one per slot; H_0 is
    /// the mission's `altitude_m`). A profile of another length is read as the mission's
    /// altitude where it has no entry.
    pub fn build_with_altitudes(
        mission: &Mission,
        prev: &Trajectory,
        prev_altitudes_m: &[f64],
        objective: ExactObjective,
        tuning: &ExactTuning,
    ) -> Self {
        Self::build_profile(mission, prev, Some(prev_altitudes_m), objective, tuning)
    }

    fn build_profile(
        mission: &Mission,
        prev: &Trajectory,
        prev_altitudes_m: Option<&[f64]>,
        objective: ExactObjective,
        tuning: &ExactTuning,
    ) -> Self {
        let p = mission.params();
        let model = PowerModel::new(p);
        let n = mission.slots();
        let delta = p.slot_s;
        let v_max = p.max_speed_mps - SPEED_MARGIN_MPS;
        let v0 = p.induced_velocity_mps;

        let (vars, next) = layout(mission, objective, tuning, prev_altitudes_m.is_some());
        let mut b = ProblemBuilder::new(next);
        let prev_z = |t: usize| {
            prev_altitudes_m
                .and_then(|a| a.get(t - 1).copied())
                .unwrap_or(p.altitude_m)
        };

        let lin = linearise(mission, prev, &model, prev_altitudes_m);

        let objective_scale = objective_terms(&mut b, &vars, objective, &model, tuning, delta);
        if let Some(cap) = tuning.energy_cap_j {
            energy_cap(&mut b, &vars, &model, delta, cap);
        }

        // per-slot constraints
        for t in 1..=n {
            let sv = vars[t - 1];
            let l = lin[t - 1];
            // v_t = q_t − q_{t−1} as affine expressions
            let (vx, vy) = step_exprs(&vars, t, prev.start_m);
            // speed epigraph: δ V ≥ ‖v‖ ; V ≤ V_m
            b.soc(
                Lin::var(sv.v, delta * SPEED_UNIT_MPS),
                &[vx.clone(), vy.clone()],
            );
            b.nonneg(Lin::var(sv.v, -SPEED_UNIT_MPS).plus_const(v_max));
            if tuning.dynamics == Dynamics::Vehicle {
                vehicle::accel_cone(
                    &mut b,
                    mission,
                    tuning,
                    (&vars, prev.start_m),
                    t,
                    (&vx, &vy),
                );
                vehicle::jerk_cone(&mut b, mission, tuning, (&vars, prev.start_m), t);
            }

            if let Some(av) = sv.alt {
                let prev_h = (t > 1).then(|| vars[t - 2].alt.map(|a| a.h)).flatten();
                altitude_rows(&mut b, p, av, prev_h);
            }

            if let Some(energy) = sv.energy {
                energy_cones(
                    &mut b,
                    energy,
                    sv.v,
                    &l,
                    (&vx, &vy),
                    delta * delta * v0 * v0,
                );
            }

            let (Some(g), Some(e)) = (mission.target_m(t), sv.e) else {
                continue;
            };
            landmark::landmark_rows(
                &mut b,
                mission,
                tuning,
                landmark::LandmarkSlot {
                    sv,
                    lin: l,
                    q0: Point2::from(prev.q(t)),
                    landmark_m: g,
                    e,
                    alt: sv.alt.map(|av| (av, prev_z(t))),
                },
                (&vx, &vy),
            );
        }
        Self {
            builder: b,
            vars,
            objective_scale,
            objective,
            constant_j: n as f64 * delta * model.blade_power_w,
            altitude_bounds_m: prev_altitudes_m.map(|_| crate::altitude::bounds_m(p)),
        }
    }

    /// The altitude profile of a solution vector (one per slot, m), clamped into the altitude
    /// bounds against the solver's last digits (clamping keeps the rates: it is monotone and
    /// 1-Lipschitz, and H_0 is within the bounds); `None` when the subproblem was built at the
    /// mission's altitude.
    pub fn altitudes_m(&self, x: &[f64]) -> Option<Vec<f64>> {
        let (lo, hi) = self.altitude_bounds_m?;
        Some(
            self.vars
                .iter()
                .map(|sv| {
                    sv.alt
                        .and_then(|av| x.get(av.h).copied())
                        .map_or(f64::NAN, |z| z.clamp(lo, hi))
                })
                .collect(),
        )
    }

    /// The trajectory of a solution vector.
    pub fn trajectory(&self, x: &[f64], template: &Trajectory) -> Trajectory {
        Trajectory {
            slot_s: template.slot_s,
            start_m: template.start_m,
            pos_m: self
                .vars
                .iter()
                .map(|sv| {
                    [
                        x.get(sv.x).copied().unwrap_or(f64::NAN),
                        x.get(sv.y).copied().unwrap_or(f64::NAN),
                    ]
                })
                .collect(),
        }
    }

    /// The subproblem's own objective in physical units: energy in J (Energy, including the
    /// constant blade term N δ P0 that the cone program omits) or distance in m (Distance), plus
    /// the elastic penalty in elastic mode.
    pub fn physical_objective(&self, solver_objective: f64) -> f64 {
        match self.objective {
            ExactObjective::Energy => solver_objective / self.objective_scale + self.constant_j,
            ExactObjective::Distance => solver_objective / self.objective_scale,
        }
    }

    /// Largest violation slack σ_t of a repair solution, m.
    pub fn max_slack(&self, x: &[f64]) -> f64 {
        self.vars
            .iter()
            .filter_map(|sv| sv.sigma.and_then(|s| x.get(s).copied()))
            .fold(0.0, f64::max)
    }
}

/// The objective of the subproblem, scaled to a mean power (W) or a mean step (m) for
/// conditioning: the energy (or distance) terms, the elastic and deficit slacks' costs. Returns
/// the scale.
fn objective_terms(
    b: &mut ProblemBuilder,
    vars: &[SlotVars],
    objective: ExactObjective,
    model: &PowerModel,
    tuning: &ExactTuning,
    delta: f64,
) -> f64 {
    let n = vars.len();
    let objective_scale = match objective {
        ExactObjective::Distance => 1.0 / n as f64,
        ExactObjective::Energy => 1.0 / (n as f64 * delta),
    };
    for sv in vars {
        match (objective, sv.energy) {
            (ExactObjective::Distance, _) => {
                b.add_linear_cost(sv.v, SPEED_UNIT_MPS * delta * objective_scale)
            }
            (_, Some([a, _s, _w, z])) => {
                let c = delta * objective_scale;
                b.add_square_cost(
                    sv.v,
                    c * model.blade_quadratic_coeff() * SPEED_UNIT_MPS.powi(2),
                );
                b.add_linear_cost(a, c * model.induced_power_w);
                b.add_linear_cost(z, c * model.parasite_coeff * SPEED_UNIT_MPS.powi(3));
            }
            _ => {}
        }
        if let (Some(av), ExactObjective::Energy) = (sv.alt, objective) {
            // W max(v_z, 0) δ = W c_t, J
            b.add_linear_cost(av.climb, model.weight_n * objective_scale);
        }
        if let (Some(sig), Some(w)) = (sv.sigma, tuning.elastic_weight) {
            b.add_linear_cost(sig, w * objective_scale);
        }
        if let (Some(tau), Some(w)) = (sv.accel_slack, tuning.elastic_weight) {
            // τ/δ is the velocity change beyond the limit, m/s (phase I's measure)
            b.add_linear_cost(tau, w * objective_scale / delta);
            b.nonneg(Lin::var(tau, 1.0));
        }
        if let (Some(tau), Some(w)) = (sv.jerk_slack, tuning.elastic_weight) {
            // τ/δ² is the acceleration change beyond the limit, m/s² (phase I's measure)
            b.add_linear_cost(tau, w * objective_scale / (delta * delta));
            b.nonneg(Lin::var(tau, 1.0));
        }
        if let (Some(rho), Some(w)) = (sv.rho, tuning.cell_slack_weight) {
            b.add_linear_cost(rho, w * objective_scale);
            b.nonneg(Lin::var(rho, 1.0));
        }
    }
    objective_scale
}

/// The variable layout of the subproblem: each slot's variables, and their number.
fn layout(
    mission: &Mission,
    objective: ExactObjective,
    tuning: &ExactTuning,
    free_altitude: bool,
) -> (Vec<SlotVars>, usize) {
    let n = mission.slots();
    let mut vars = Vec::with_capacity(n);
    let mut next = 0usize;
    let mut take = || {
        next += 1;
        next - 1
    };
    for t in 1..=n {
        let landmark = mission.target_m(t).is_some();
        let x = take();
        let y = take();
        let v = take();
        let energy =
            (objective != ExactObjective::Distance).then(|| [take(), take(), take(), take()]);
        let e = landmark.then(&mut take);
        let sigma = (landmark && tuning.elastic_weight.is_some()).then(&mut take);
        let general = landmark && tuning.resolution == ResolutionMode::General;
        let best_effort = general && tuning.cell_slack_weight.is_some();
        let shift = (general && !best_effort).then(&mut take);
        let rho = best_effort.then(&mut take);
        let elastic_vehicle =
            tuning.elastic_weight.is_some() && tuning.dynamics == Dynamics::Vehicle;
        let accel_slack = elastic_vehicle.then(&mut take);
        let p = mission.params();
        let jerk_limited =
            p.max_jerk_mps3.is_some() && crate::evaluate::jerk_window_s(p, t).is_some();
        let jerk_slack = (elastic_vehicle && jerk_limited).then(&mut take);
        let alt = free_altitude.then(|| AltitudeVars {
            h: take(),
            climb: take(),
            cell_shift: shift.map(|_| take()),
        });
        vars.push(SlotVars {
            x,
            y,
            v,
            energy,
            e,
            sigma,
            shift,
            rho,
            accel_slack,
            jerk_slack,
            alt,
        });
    }
    (vars, next)
}

/// The linearisation data of every slot around the iterate `prev`.
fn linearise(
    mission: &Mission,
    prev: &Trajectory,
    model: &PowerModel,
    prev_altitudes_m: Option<&[f64]>,
) -> Vec<SlotLin> {
    let p = mission.params();
    let delta = p.slot_s;
    let tan = p.observation_angle_rad.tan();
    let offset_at = |t: usize| match prev_altitudes_m.and_then(|a| a.get(t - 1)) {
        Some(z) => z * tan,
        None => p.centre_offset_m(),
    };
    let headings = prev.headings_rad();
    (1..=mission.slots())
        .map(|t| {
            let step = Vector2::from(prev.step_m(t));
            let dir = step
                .direction()
                .unwrap_or_else(|| heading_unit(headings[t - 1]));
            SlotLin {
                step_m: step,
                dir,
                aux: model.induced_factor(step.length() / delta),
                centre_m: Point2::from(prev.q(t)) + RIGHT_TURN * dir * offset_at(t),
            }
        })
        .collect()
}

/// The energy cones of one slot: the induced auxiliary `a` (with its helper `s`) against the
/// tangent at the previous step, and w ≥ V², z ≥ V³ for the speed epigraph `v`; `step` is the
/// slot's (v_x, v_y), `delta2_v02` is δ² v0².
fn energy_cones(
    b: &mut ProblemBuilder,
    [a, s, w, z]: [usize; 4],
    v: usize,
    l: &SlotLin,
    (vx, vy): (&Lin, &Lin),
    delta2_v02: f64,
) {
    // L = 2 a0 a − a0² + (2 u·v − ‖u‖²)/(δ² v0²)  (tangent of a² + ‖v‖²/(δ² v0²))
    let k = 1.0 / delta2_v02;
    let u = l.step_m;
    let lexpr = Lin::var(a, 2.0 * l.aux)
        .plus_const(-l.aux * l.aux - k * u.norm_squared())
        .plus_lin(&vx.clone().scaled(2.0 * k * u.x))
        .plus_lin(&vy.clone().scaled(2.0 * k * u.y));
    // s a ≥ 1 ; s² ≤ L
    b.rotated_soc(
        Lin::var(s, 1.0),
        Lin::var(a, 1.0),
        &[Lin::constant_only(1.0)],
    );
    b.rotated_soc(lexpr, Lin::constant_only(1.0), &[Lin::var(s, 1.0)]);
    // V² ≤ w ; w² ≤ z V
    b.rotated_soc(
        Lin::var(w, 1.0),
        Lin::constant_only(1.0),
        &[Lin::var(v, 1.0)],
    );
    b.rotated_soc(Lin::var(z, 1.0), Lin::var(v, 1.0), &[Lin::var(w, 1.0)]);
}

/// Σ_t δ (P₀-quadratic · w_t + P_i a_t + parasite · z_t) + N δ P₀ ≤ `cap_j`: the surrogate energy
/// (with w_t ≥ V_t², z_t ≥ V_t³, a_t the induced auxiliary) capped.
fn energy_cap(
    b: &mut ProblemBuilder,
    vars: &[SlotVars],
    model: &PowerModel,
    delta: f64,
    cap_j: f64,
) {
    let constant = vars.len() as f64 * delta * model.blade_power_w;
    let mut e = Lin::constant_only(cap_j - constant);
    for sv in vars {
        if let Some(av) = sv.alt {
            e = e.plus(av.climb, -model.weight_n);
        }
        if let Some([a, _s, w, z]) = sv.energy {
            e = e
                .plus(
                    w,
                    -delta * model.blade_quadratic_coeff() * SPEED_UNIT_MPS.powi(2),
                )
                .plus(a, -delta * model.induced_power_w)
                .plus(z, -delta * model.parasite_coeff * SPEED_UNIT_MPS.powi(3));
        }
    }
    b.nonneg(e);
}

/// (x_t − x_{t−1}, y_t − y_{t−1}) as affine expressions (q_0 is a constant).
fn step_exprs(vars: &[SlotVars], t: usize, start_m: [f64; 2]) -> (Lin, Lin) {
    let cur = vars[t - 1];
    if t == 1 {
        (
            Lin::var(cur.x, 1.0).plus_const(-start_m[0]),
            Lin::var(cur.y, 1.0).plus_const(-start_m[1]),
        )
    } else {
        let prev = vars[t - 2];
        (
            Lin::var(cur.x, 1.0).plus(prev.x, -1.0),
            Lin::var(cur.y, 1.0).plus(prev.y, -1.0),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Matrix2;
    use proptest::prelude::*;

    proptest! {
        /// The expansion error of the unit-vector map is within the bound κ‖v − u‖² whenever the
        /// segment [u, v] stays at least s away from the origin (checked here through ĥ·v ≥ s,
        /// ‖u‖ ≥ s, exactly the subproblem's constraints).
        #[test]
        fn centre_error_bound_is_conservative(
            ux in -30.0f64..30.0, uy in -30.0f64..30.0,
            dx in -20.0f64..20.0, dy in -20.0f64..20.0,
            frac in 0.05f64..1.0,
        ) {
            let u = Vector2::new(ux, uy);
            let un = u.norm();
            prop_assume!(un > 0.5);
            let d = Vector2::new(dx, dy);
            let v = u + d;
            let h = u.normalize();
            let s = frac * un;
            prop_assume!(h.dot(&v) >= s);
            let p = Matrix2::identity() - h * h.transpose();
            let lin = h + p * d / un;
            let err = (v.normalize() - lin).norm();
            let bound = CENTRE_CURVATURE_BOUND * d.norm_squared() / (s * s);
            prop_assert!(err <= bound * (1.0 + 1e-9) + 1e-12, "err {} > bound {}", err, bound);
        }

        /// The induced-power constraint's right side is below the true one everywhere and equal at u.
        #[test]
        fn induced_tangent_is_below(
            ux in -25.0f64..25.0, uy in -25.0f64..25.0, vx in -25.0f64..25.0, vy in -25.0f64..25.0,
            a in 0.05f64..1.5,
        ) {
            let model = PowerModel::new(&crate::Params::default());
            let delta = 0.5;
            let v0 = 5.4;
            let k = 1.0 / (delta * delta * v0 * v0);
            let u = Vector2::new(ux, uy);
            let a0 = model.induced_factor(u.norm() / delta);
            let v = Vector2::new(vx, vy);
            let lhs_true = a * a + k * v.norm_squared();
            let lin = 2.0 * a0 * a - a0 * a0 + k * (2.0 * u.dot(&v) - u.norm_squared());
            prop_assert!(lin <= lhs_true + 1e-9);
            let at_u = 2.0 * a0 * a0 - a0 * a0 + k * u.norm_squared();
            prop_assert!((at_u - (a0 * a0 + k * u.norm_squared())).abs() < 1e-9);
        }
    }
}
