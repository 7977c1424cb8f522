//! The paper's Algorithm 1 exactly as printed (scheme `paper`) and its least-distance baseline
//! (scheme `baseline`): block coordinate descent between problem (p5) over (q, V, q_aux) with the
//! heading slacks (w, u) fixed, and the feasibility problem (p6) over (w, u).
//!
//! Corrections applied (the errata (docs/paper-notes.md)): the range constraint is used only when c/(B d_min) − sin η > 0
//! (item 2); eq. (explicit3) is used in its correct form (item 8); energies are reported in joules,
//! Σ P̃_t δ (item 10); the baseline minimises Σ‖q_t − q_{t−1}‖ (item 6); the sensing radius is
//! r_s (item 5). The relaxations of item 3 are kept on purpose: this scheme exists to reproduce
//! the paper, and every result is evaluated on the exact geometry beside its own objective.
//! (p6) is a pure feasibility problem whose set can shrink to a point (item 9): it is solved as
//! one cone program, and any slot whose returned (w, u) fails our own check keeps its previous
//! value, which (p5) guarantees to be feasible.
//!
//! With free altitude the state carries an altitude per slot ([`PaperState::with_altitudes`]),
//! at which (p5) and (p6) take the centre offset, the sensing radius and V_min, and
//! [`PaperState::solve_altitudes`] is the altitude step of the paper's alternating extension
//! (the driver alternates the two).

mod altitude;

pub use altitude::AltitudeStep;

use crate::altitude::params_at;
use crate::geometry::{Length, Vector2};
use crate::power::PowerModel;
use crate::schemes::exact::SPEED_UNIT_MPS as VU;
use crate::socp::{Lin, ProblemBuilder, SocpSolver, SolveError};
use crate::{Mission, Params, Trajectory};

/// What (p5) minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PaperObjective {
    /// Σ P̃_t δ (Algorithm 1).
    Energy,
    /// Σ ‖q_t − q_{t−1}‖ (the baseline).
    Distance,
}

/// The BCD state: (q, V, q_aux) from the last (p5), (w, u) from the last (p6).
#[derive(Debug, Clone, PartialEq)]
pub struct PaperState {
    /// Positions q_t.
    pub pos_m: Vec<[f64; 2]>,
    /// Speed variables V_t (not necessarily the true speeds).
    pub speed_mps: Vec<f64>,
    /// Induced auxiliaries q_t of eq. (mu).
    pub aux: Vec<f64>,
    /// Heading slacks w_t (≈ sin α_t).
    pub w: Vec<f64>,
    /// Heading slacks u_t (≈ cos α_t).
    pub u: Vec<f64>,
    start_m: [f64; 2],
    slot_s: f64,
    /// H_t per slot (free altitude, the alternating extension), or `None`: every slot at the
    /// mission's `altitude_m`, Algorithm 1 as printed.
    altitudes_m: Option<Vec<f64>>,
}

impl PaperState {
    /// The starting point of Algorithm 1 from a path: V^(0) its true speed, q^(0) from eq. (mu)
    /// with equality, (w, u)^(0) the true (sin, cos) of its heading.
    pub fn from_trajectory(mission: &Mission, traj: &Trajectory) -> Self {
        let model = PowerModel::new(mission.params());
        let speed: Vec<f64> = (1..=traj.slots()).map(|t| traj.speed_mps(t)).collect();
        let headings = traj.headings_rad();
        Self {
            pos_m: traj.pos_m.clone(),
            aux: speed.iter().map(|&v| model.induced_factor(v)).collect(),
            speed_mps: speed,
            w: headings.iter().map(|a| a.sin()).collect(),
            u: headings.iter().map(|a| a.cos()).collect(),
            start_m: traj.start_m,
            slot_s: traj.slot_s,
            altitudes_m: None,
        }
    }

    /// The same state with slot t flown at H_t = `altitudes_m[t − 1]`: (p5) and (p6) then take
    /// the centre offset H_t tan η, the sensing radius r_s H_t / H (erratum 5) and the azimuth
    /// floor V_min(H_t) of (p2.2) at the slot's altitude. `None` is Algorithm 1 as printed.
    pub fn with_altitudes(mut self, altitudes_m: Option<Vec<f64>>) -> Self {
        self.altitudes_m = altitudes_m;
        self
    }

    /// The altitudes the state is flown at, if per slot.
    pub fn altitudes_m(&self) -> Option<&[f64]> {
        self.altitudes_m.as_deref()
    }

    /// Slot t's centre offset D_t (m), sensing radius r_t (m) and azimuth floor V_min,t (m/s):
    /// the mission's own at a fixed altitude, those of [`params_at`] H_t with per-slot
    /// altitudes.
    fn slot_geometry(&self, p: &Params, t: usize) -> (f64, f64, f64) {
        match self.altitudes_m.as_ref().and_then(|z| z.get(t - 1)) {
            Some(&h) => {
                let at = params_at(p, h);
                (
                    at.centre_offset_m(),
                    at.sensing_radius_m,
                    at.min_speed_mps(),
                )
            }
            None => (p.centre_offset_m(), p.sensing_radius_m, p.min_speed_mps()),
        }
    }

    /// The current positions as a trajectory.
    pub fn trajectory(&self, template: &Trajectory) -> Trajectory {
        Trajectory {
            slot_s: template.slot_s,
            start_m: self.start_m,
            pos_m: self.pos_m.clone(),
        }
    }

    fn q_prev(&self, t: usize) -> [f64; 2] {
        if t <= 1 {
            self.start_m
        } else {
            self.pos_m[t - 2]
        }
    }

    /// Solves (p5) (or the baseline's version) with (w, u) fixed and updates (q, V, q_aux).
    /// Returns the optimal value (J, or m for the baseline) and the interior-point iterations.
    pub fn solve_p5(
        &mut self,
        mission: &Mission,
        objective: PaperObjective,
        solver: &mut SocpSolver,
    ) -> Result<(f64, u32), SolveError> {
        let p = mission.params();
        let model = PowerModel::new(p);
        let n = mission.slots();
        let delta = p.slot_s;
        let v0 = p.induced_velocity_mps;
        let keepout = p.range_keepout_m();
        let per = match objective {
            PaperObjective::Energy => 7,   // x y V q_aux s w2 z
            PaperObjective::Distance => 4, // x y V dist
        };
        let idx = |t: usize, k: usize| (t - 1) * per + k;
        let mut b = ProblemBuilder::new(n * per);
        let scale = match objective {
            PaperObjective::Energy => 1.0 / (n as f64 * delta),
            PaperObjective::Distance => 1.0 / n as f64,
        };
        for t in 1..=n {
            let (x, y, vv) = (idx(t, 0), idx(t, 1), idx(t, 2));
            let (dx, dy) = if t == 1 {
                (
                    Lin::var(x, 1.0).plus_const(-self.start_m[0]),
                    Lin::var(y, 1.0).plus_const(-self.start_m[1]),
                )
            } else {
                (
                    Lin::var(x, 1.0).plus(idx(t - 1, 0), -1.0),
                    Lin::var(y, 1.0).plus(idx(t - 1, 1), -1.0),
                )
            };
            // (p2.3) ‖q_t − q_{t−1}‖ ≤ δ V_t ; (p2.4) 0 ≤ V_t ≤ V_m
            b.soc(Lin::var(vv, delta * VU), &[dx.clone(), dy.clone()]);
            b.nonneg(Lin::var(vv, -VU).plus_const(p.max_speed_mps));
            match objective {
                PaperObjective::Energy => {
                    let (qa, s, w2, z) = (idx(t, 3), idx(t, 4), idx(t, 5), idx(t, 6));
                    let c = delta * scale;
                    b.add_square_cost(vv, c * model.blade_quadratic_coeff() * VU * VU);
                    b.add_linear_cost(qa, c * model.induced_power_w);
                    b.add_linear_cost(z, c * model.parasite_coeff * VU.powi(3));
                    // (p42): 1/q² ≤ q0² + V0²/v0² + 2 q0 (q − q0) + 2 V0/v0² (V − V0)
                    let (q0, vk) = (self.aux[t - 1], self.speed_mps[t - 1]);
                    let k = 1.0 / (v0 * v0);
                    let l = Lin::var(qa, 2.0 * q0)
                        .plus(vv, 2.0 * vk * k * VU)
                        .plus_const(-q0 * q0 - vk * vk * k);
                    b.rotated_soc(
                        Lin::var(s, 1.0),
                        Lin::var(qa, 1.0),
                        &[Lin::constant_only(1.0)],
                    );
                    b.rotated_soc(l, Lin::constant_only(1.0), &[Lin::var(s, 1.0)]);
                    b.rotated_soc(
                        Lin::var(w2, 1.0),
                        Lin::constant_only(1.0),
                        &[Lin::var(vv, 1.0)],
                    );
                    b.rotated_soc(Lin::var(z, 1.0), Lin::var(vv, 1.0), &[Lin::var(w2, 1.0)]);
                }
                PaperObjective::Distance => {
                    let dist = idx(t, 3);
                    b.add_linear_cost(dist, scale);
                    b.soc(Lin::var(dist, 1.0), &[dx.clone(), dy.clone()]);
                }
            }
            let Some(g) = mission.target_m(t) else {
                continue;
            };
            let (w, u) = (self.w[t - 1], self.u[t - 1]);
            let (d, r, v_min) = self.slot_geometry(p, t);
            // (p2.2) V_t ≥ λ_c H/(T_d d_min cos η)
            b.nonneg(Lin::var(vv, VU).plus_const(-v_min));
            // (p52) w δ V ≤ y_t − y_{t−1} ; (p53) x_t − x_{t−1} ≤ u δ V
            b.nonneg(dy.clone().plus(vv, -w * delta * VU));
            b.nonneg(Lin::var(vv, u * delta * VU).minus_lin(&dx));
            // sensing disc with the modelled centre (x + w D, y − u D)
            b.soc(
                Lin::constant_only(r),
                &[
                    Lin::var(x, 1.0).plus_const(w * d - g[0]),
                    Lin::var(y, 1.0).plus_const(-u * d - g[1]),
                ],
            );
            // (explicit2), only when the range requirement is not vacuous
            if let Some(rk) = keepout.filter(|k| k.is_finite()) {
                let q0 = self.pos_m[t - 1];
                let ax = q0[0] + w * d - p.bs_m[0];
                let ay = q0[1] - u * d - p.bs_m[1];
                b.nonneg(
                    Lin::var(x, 2.0 * ax).plus(y, 2.0 * ay).plus_const(
                        ax * ax + ay * ay - 2.0 * ax * q0[0] - 2.0 * ay * q0[1] - rk * rk,
                    ),
                );
            }
        }
        let sol = solver.solve(&b)?;
        for t in 1..=n {
            self.pos_m[t - 1] = [sol.x[idx(t, 0)], sol.x[idx(t, 1)]];
            self.speed_mps[t - 1] = VU * sol.x[idx(t, 2)];
            if objective == PaperObjective::Energy {
                self.aux[t - 1] = sol.x[idx(t, 3)];
            }
        }
        let value = match objective {
            PaperObjective::Energy => {
                sol.objective / scale + n as f64 * delta * model.blade_power_w
            }
            PaperObjective::Distance => sol.objective / scale,
        };
        Ok((value, sol.iterations))
    }

    /// Solves the feasibility problem (p6) for (w, u) with (q, V) fixed. Slots whose new (w, u)
    /// fail our check (or all, if the solver fails) keep their previous values, which (p5) made
    /// feasible. Returns the interior-point iterations.
    pub fn solve_p6(&mut self, mission: &Mission, solver: &mut SocpSolver) -> u32 {
        let p = mission.params();
        let delta = p.slot_s;
        let keepout = p.range_keepout_m().filter(|k| k.is_finite());
        let slots: Vec<usize> = (1..=mission.slots())
            .filter(|&t| mission.target_m(t).is_some())
            .collect();
        if slots.is_empty() {
            return 0;
        }
        let mut b = ProblemBuilder::new(2 * slots.len());
        let mut checks: Vec<(usize, f64, Vec<Lin>, Vec<Lin>)> = Vec::with_capacity(slots.len());
        for (k, &t) in slots.iter().enumerate() {
            let (wv, uv) = (2 * k, 2 * k + 1);
            let (d, r, _) = self.slot_geometry(p, t);
            let g = mission.target_m(t).unwrap_or([0.0, 0.0]);
            let q = self.pos_m[t - 1];
            let qp = self.q_prev(t);
            let vdelta = (delta * self.speed_mps[t - 1]).max(1e-12);
            let sin_hi = (q[1] - qp[1]) / vdelta;
            let cos_lo = (q[0] - qp[0]) / vdelta;
            let mut lin_rows = vec![
                Lin::var(wv, 1.0).plus_const(1.0),
                Lin::var(wv, -1.0).plus_const(sin_hi),
                Lin::var(uv, 1.0).plus_const(-cos_lo),
                Lin::var(uv, -1.0).plus_const(1.0),
            ];
            if let Some(rk) = keepout {
                // (explicit3) corrected (erratum 8 (docs/paper-notes.md))
                let (w0, u0) = (self.w[t - 1], self.u[t - 1]);
                let ax = q[0] + w0 * d - p.bs_m[0];
                let ay = q[1] - u0 * d - p.bs_m[1];
                lin_rows.push(
                    Lin::var(wv, 2.0 * d * ax)
                        .plus(uv, -2.0 * d * ay)
                        .plus_const(
                            ax * ax + ay * ay - 2.0 * d * ax * w0 + 2.0 * d * ay * u0 - rk * rk,
                        ),
                );
            }
            for row in &lin_rows {
                b.nonneg(row.clone());
            }
            let soc = vec![
                Lin::constant_only(r),
                Lin::var(wv, d).plus_const(q[0] - g[0]),
                Lin::var(uv, -d).plus_const(q[1] - g[1]),
            ];
            b.soc(soc[0].clone(), &soc[1..]);
            checks.push((t, r, lin_rows, soc));
        }
        let Ok(sol) = solver.solve(&b) else {
            tracing::debug!("(p6) not solved; keeping the previous (w, u)");
            return 0;
        };
        let tol = 1e-7;
        for (k, (t, r, rows, soc)) in checks.iter().enumerate() {
            let r = *r;
            let x = &sol.x;
            let lin_ok = rows
                .iter()
                .all(|row| row.eval(x) >= -tol * (1.0 + row.constant().abs()));
            let tail = Vector2::new(soc[1].eval(x), soc[2].eval(x)).length();
            if lin_ok && tail <= r + tol * (1.0 + r) {
                self.w[t - 1] = x[2 * k];
                self.u[t - 1] = x[2 * k + 1];
            }
        }
        sol.iterations
    }
}
