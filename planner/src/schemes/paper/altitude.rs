//! The altitude step of the paper's alternating three-dimensional extension (Section III-C, the
//! paragraph after (P6)): with the horizontal track and its auxiliaries {q_t, V_t, q_t, w_t,
//! u_t} fixed, the altitudes H_t are found by "a similar subproblem to (P6)", with H_t in place
//! of (w_t, u_t) in (29a) and of H in (29d):
//!
//! - (29a) find {H_t}, within the mission's bounds min ≤ H_t ≤ max and its climb and descent
//!   rates −descent δ ≤ H_t − H_{t−1} ≤ climb δ (H_0 = `altitude_m`), which the paper's 2-D
//!   model has no counterpart of;
//! - (29d) with H_t: ‖(x_t + w_t H_t tan η − x_g, y_t − u_t H_t tan η − y_g)‖ ≤ r_s H_t / H, the
//!   radius of the same antenna at H_t (erratum 5), a second-order cone in H_t;
//! - (p2.2) with H_t: λ_c H_t / (T_d d_min cos η) ≤ V_t, linear in H_t;
//! - eq. (explicit) with H_t, where the range constraint is not vacuous (erratum 2), expanded to
//!   first order in H_t at H_t^(ℓ) like (explicit3), in its correct form (erratum 8): the left
//!   side is convex in H_t, so the expansion is a safe inner approximation.
//!
//! (P6) is a pure feasibility problem because its variables do not enter the paper's energy;
//! the altitude does, through the climb power W max(v_z, 0) of the three-dimensional model
//! ([`crate::PowerModel::power_3d_w`]), and nothing else of the energy depends on H_t with the
//! track fixed. The feasibility problem is therefore solved with the climb energy Σ W c_t
//! (c_t ≥ H_t − H_{t−1}, c_t ≥ 0) as its objective: among the altitudes (P6) allows, one that
//! costs least to fly. The fixed auxiliaries satisfy every row at the previous H_t (the step
//! before made them so), so the previous profile is feasible, and the set can shrink to it
//! (as erratum 9 finds for (P6)): a profile whose answer fails our own check of the rows is not
//! taken, and the previous one stays.

use crate::altitude::bounds_m;
use crate::power::PowerModel;
use crate::socp::{Lin, ProblemBuilder, SocpSolver};
use crate::Mission;

use super::PaperState;

/// Margin on the climb and descent rates, m/s (the solver's tolerances stay inside it; the
/// exact check allows 1e-4).
const RATE_MARGIN_MPS: f64 = 1e-5;

/// Largest row violation, relative to 1 + the row's constant, at which the solver's profile is
/// taken.
const CHECK_TOL: f64 = 1e-7;

/// What the altitude step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AltitudeStep {
    /// Interior-point iterations.
    pub ipm_iterations: u32,
    /// Largest change of any H_t, m (0 when the previous profile stayed).
    pub max_change_m: f64,
}

impl PaperState {
    /// Solves the altitude subproblem (the module documentation) with the track and its
    /// auxiliaries fixed and sets the state's altitudes to its answer, or keeps the previous
    /// ones (`altitude_m` in every slot if the state had none) when the solver fails or its
    /// answer fails the check.
    pub fn solve_altitudes(&mut self, mission: &Mission, solver: &mut SocpSolver) -> AltitudeStep {
        let p = mission.params();
        let n = mission.slots();
        let previous = self
            .altitudes_m
            .clone()
            .unwrap_or_else(|| vec![p.altitude_m; n]);
        let (lo, hi) = bounds_m(p);
        let delta = p.slot_s;
        let tan = p.observation_angle_rad.tan();
        let radius_per_m = p.sensing_radius_m / p.altitude_m;
        let vmin_per_m = p.min_speed_mps() / p.altitude_m;
        let keepout = p.range_keepout_m().filter(|k| k.is_finite());
        let weight_n = PowerModel::new(p).weight_n;
        let up = ((p.max_climb_mps - RATE_MARGIN_MPS) * delta).max(0.0);
        let down = ((p.max_descent_mps - RATE_MARGIN_MPS) * delta).max(0.0);
        // variables: H_t at 2(t − 1), c_t at 2(t − 1) + 1
        let (h, c) = (|t: usize| 2 * (t - 1), |t: usize| 2 * (t - 1) + 1);
        let mut b = ProblemBuilder::new(2 * n);
        let mut rows: Vec<Lin> = Vec::new();
        let mut discs: Vec<(Lin, Lin, Lin)> = Vec::new();
        for t in 1..=n {
            let dz = if t == 1 {
                Lin::var(h(t), 1.0).plus_const(-p.altitude_m)
            } else {
                Lin::var(h(t), 1.0).plus(h(t - 1), -1.0)
            };
            b.add_linear_cost(c(t), weight_n / n as f64);
            rows.extend([
                Lin::var(h(t), 1.0).plus_const(-lo),
                Lin::var(h(t), -1.0).plus_const(hi),
                dz.clone().scaled(-1.0).plus_const(up),
                dz.clone().plus_const(down),
                Lin::var(c(t), 1.0).minus_lin(&dz),
                Lin::var(c(t), 1.0),
            ]);
            let Some(g) = mission.target_m(t) else {
                continue;
            };
            let q = self.pos_m[t - 1];
            let (w, u) = (self.w[t - 1], self.u[t - 1]);
            // (p2.2) at H_t: V_min(H_t) = H_t V_min(H) / H ≤ V_t
            rows.push(Lin::var(h(t), -vmin_per_m).plus_const(self.speed_mps[t - 1]));
            // (29d) at H_t
            discs.push((
                Lin::var(h(t), radius_per_m),
                Lin::var(h(t), w * tan).plus_const(q[0] - g[0]),
                Lin::var(h(t), -u * tan).plus_const(q[1] - g[1]),
            ));
            if let Some(rk) = keepout {
                // eq. (explicit) expanded in H_t at H_t^(ℓ): g(H0) + g'(H0) (H − H0) ≥ C_r
                let h0 = previous[t - 1];
                let ax = q[0] + w * h0 * tan - p.bs_m[0];
                let ay = q[1] - u * h0 * tan - p.bs_m[1];
                let slope = 2.0 * tan * (w * ax - u * ay);
                rows.push(
                    Lin::var(h(t), slope).plus_const(ax * ax + ay * ay - slope * h0 - rk * rk),
                );
            }
        }
        for row in &rows {
            b.nonneg(row.clone());
        }
        for (head, ex, ey) in &discs {
            b.soc(head.clone(), &[ex.clone(), ey.clone()]);
        }
        let keep = |state: &mut Self, ipm| {
            state.altitudes_m = Some(previous.clone());
            AltitudeStep {
                ipm_iterations: ipm,
                max_change_m: 0.0,
            }
        };
        let sol = match solver.solve(&b) {
            Ok(sol) => sol,
            Err(error) => {
                tracing::debug!(%error, "altitude subproblem not solved; keeping the altitudes");
                return keep(self, 0);
            }
        };
        let x = &sol.x;
        let rows_ok = rows
            .iter()
            .all(|row| row.eval(x) >= -CHECK_TOL * (1.0 + row.constant().abs()));
        let discs_ok = discs.iter().all(|(head, ex, ey)| {
            ex.eval(x).hypot(ey.eval(x)) <= head.eval(x) + CHECK_TOL * (1.0 + head.eval(x))
        });
        if !(rows_ok && discs_ok) {
            tracing::debug!("altitude subproblem's answer fails the check; keeping the altitudes");
            return keep(self, sol.iterations);
        }
        let z: Vec<f64> = (1..=n).map(|t| x[h(t)]).collect();
        let max_change_m = z
            .iter()
            .zip(&previous)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        self.altitudes_m = Some(z);
        AltitudeStep {
            ipm_iterations: sol.iterations,
            max_change_m,
        }
    }
}
