//! Altitude as a decision of the `exact` subproblem (missions with `altitude = "free"`): one
//! variable H_t per slot, with the terms of every H-dependent quantity expanded around the
//! previous profile H_t^(ℓ) so that the subproblem stays an inner approximation of the exact
//! problem at the slot's altitude ([`crate::altitude::params_at`]).
//!
//! - Bounds min ≤ H_t ≤ max and rates −descent δ ≤ H_t − H_{t−1} ≤ climb δ (H_0 = `altitude_m`):
//!   linear, exact.
//! - Climb power W max(v_z, 0): an epigraph c_t ≥ H_t − H_{t−1}, c_t ≥ 0 in the objective,
//!   W c_t per slot (J), exact.
//! - V_min(H_t) = λ_c H_t / (T_d d_min cos η) ≤ V_t: linear in H_t (carried by ĥ·v ≥ δ V_min(H_t)
//!   like the fixed altitude's floor).
//! - Sensing: the centre offset H_t tan η and the radius r_s H_t / H are linear in H_t; the
//!   centre's expansion c̃ = q_t + H_t tan η J ĥ + H_t^(ℓ) tan η J P v_t / ‖u_t‖ leaves the error
//!   D^(ℓ)(n(v) − ñ(v)) + tan η (H_t − H_t^(ℓ))(n(v) − n(u)), bounded by
//!   D^(ℓ) κ ‖Δv‖² + tan η |ΔH| ‖Δv‖ / s ≤ (D^(ℓ) κ + c tan η / (2 s)) ‖Δv‖² + tan η ΔH² / (2 c s)
//!   (the unit-vector map is 1/s-Lipschitz on the segment [u, v], whose norms are ≥ s; then
//!   |ΔH| ‖Δv‖ ≤ (c ‖Δv‖² + ΔH²/c)/2 with c = [`YOUNG_WEIGHT`], which the bound then carries). The error budget e_t covers it, so every iterate keeps the
//!   landmark in view at its own altitude.
//! - The resolution cell at H_t^(ℓ) with a margin L_H |H_t − H_t^(ℓ)| (hard constraints), L_H a
//!   safety-factored finite-difference bound ([`cell_altitude_margin`]), like the position's.

use crate::altitude::{bounds_m, params_at};
use crate::geometry::{CellLinear, Length, Point2};
use crate::params::{Params, SPEED_OF_LIGHT_MPS};
use crate::socp::{Lin, ProblemBuilder};

/// The altitude variables of one slot.
#[derive(Debug, Clone, Copy)]
pub(super) struct AltitudeVars {
    /// H_t, m.
    pub(super) h: usize,
    /// Climb epigraph c_t ≥ max(H_t − H_{t−1}, 0), m.
    pub(super) climb: usize,
    /// Hard cell constraints: m_H ≥ |H_t − H_t^(ℓ)| (for the altitude margin of the cell).
    pub(super) cell_shift: Option<usize>,
}

/// Margin on the climb and descent rates, m/s (solver tolerances stay inside it; the exact
/// check allows 1e-4).
const RATE_MARGIN_MPS: f64 = 1e-5;

/// Safety factor on the finite-difference estimate of the cell's altitude sensitivity.
const CELL_ALTITUDE_MARGIN_FACTOR: f64 = 3.0;

/// H_t − H_{t−1} as an affine expression (H_0 = the mission's `altitude_m`).
fn climb_expr(h: usize, prev_h: Option<usize>, start_altitude_m: f64) -> Lin {
    match prev_h {
        Some(ph) => Lin::var(h, 1.0).plus(ph, -1.0),
        None => Lin::var(h, 1.0).plus_const(-start_altitude_m),
    }
}

/// The rows of one slot's altitude: bounds, climb and descent rates, the climb epigraph.
pub(super) fn altitude_rows(
    b: &mut ProblemBuilder,
    p: &Params,
    av: AltitudeVars,
    prev_h: Option<usize>,
) {
    let (lo, hi) = bounds_m(p);
    let delta = p.slot_s;
    if hi - lo <= 0.0 {
        b.zero(Lin::var(av.h, 1.0).plus_const(-lo));
    } else {
        b.nonneg(Lin::var(av.h, 1.0).plus_const(-lo));
        b.nonneg(Lin::var(av.h, -1.0).plus_const(hi));
    }
    let dz = climb_expr(av.h, prev_h, p.altitude_m);
    let up = ((p.max_climb_mps - RATE_MARGIN_MPS) * delta).max(0.0);
    let down = ((p.max_descent_mps - RATE_MARGIN_MPS) * delta).max(0.0);
    b.nonneg(dz.clone().scaled(-1.0).plus_const(up));
    b.nonneg(dz.clone().plus_const(down));
    b.nonneg(Lin::var(av.climb, 1.0).minus_lin(&dz));
    b.nonneg(Lin::var(av.climb, 1.0));
}

/// The weight c of |ΔH| ‖Δv‖ ≤ (c ‖Δv‖² + ΔH²/c)/2 in the centre-error bound: ΔH (m) moves by
/// tens of metres where the step Δv (m per slot) moves by a fraction of one, so a large c makes
/// altitude steps cheap at little cost to the track's (which already pays D^(ℓ) κ ≫ c tan η/(2s)).
/// On the 200 m mission (600–1200 m, paper resolution) the free SCA takes 68 cone programs with
/// c = 1, 14 with 10, 10 with 30 and 300, to the same energy within 0.1 %.
pub(super) const YOUNG_WEIGHT: f64 = 30.0;

/// The landmark slot's error-bound coefficients (A, B) of e ≥ A ‖Δv‖² + B ΔH² (module
/// documentation): `kappa` is the fixed altitude's κ D^(ℓ) factor (already scaled), `s` the
/// speed floor of the segment, m per slot.
pub(super) fn error_coefficients(p: &Params, kappa: f64, s: f64) -> (f64, f64) {
    let tan = p.observation_angle_rad.tan();
    let c = YOUNG_WEIGHT;
    (kappa + c * tan / (2.0 * s), tan / (2.0 * c * s))
}

/// Altitude sensitivity L_H of the worst-width cone at altitude `p.altitude_m` (the previous
/// iterate's H_t^(ℓ)): for speeds up to V_m, |f(H, v) − f(H^(ℓ), v)| ≤ L_H |H − H^(ℓ)| for the
/// cone function f of [`super::cell_margin`], by finite differences of 1 m up and down, times
/// a safety factor.
pub fn cell_altitude_margin(p: &Params, q0: Point2<f64>, landmark: Point2<f64>) -> f64 {
    let cl = CellLinear::new(p, q0, landmark);
    let k_cross = SPEED_OF_LIGHT_MPS / (p.bandwidth_hz * p.d_min_m);
    let h0 = cl.ellipse_h(p, p.d_min_m);
    let step = 1.0;
    let mut l: f64 = 0.0;
    for dir in [1.0, -1.0] {
        let p2 = params_at(p, p.altitude_m + dir * step);
        let c2 = CellLinear::new(&p2, q0, landmark);
        let dk = (c2.cross - cl.cross).length() / step;
        let dh = (c2.ellipse_h(&p2, p.d_min_m) - h0).abs() / step;
        let da = (c2.doppler_map - cl.doppler_map)
            .iter()
            .map(|x| x * x)
            .sum::<f64>()
            .sqrt()
            / step;
        l = l.max((dk + k_cross * da) * p.max_speed_mps + k_cross * dh);
    }
    l * CELL_ALTITUDE_MARGIN_FACTOR
}

/// m_H ≥ |H_t − `h0`| as two linear rows.
pub(super) fn shift_rows(b: &mut ProblemBuilder, shift: usize, h: usize, h0: f64) {
    b.nonneg(Lin::var(shift, 1.0).plus(h, -1.0).plus_const(h0));
    b.nonneg(Lin::var(shift, 1.0).plus(h, 1.0).plus_const(-h0));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{distance, Matrix2, Vector2};
    use proptest::prelude::*;

    proptest! {
        /// The cell cone at H^(ℓ) with the altitude margin implies it at H^(ℓ) + ΔH
        /// (|ΔH| ≤ 30 m, H^(ℓ) in 500–1500 m, speeds ≤ V_m, UAV ≥ 500 m from the landmark).
        #[test]
        fn cell_altitude_margin_is_conservative(
            qx in -3000.0f64..3000.0, qy in -3000.0f64..3000.0,
            lx in -1500.0f64..1500.0, ly in -1500.0f64..1500.0,
            h0 in 500.0f64..1500.0, dh in -30.0f64..30.0,
            vx in -50.0f64..50.0, vy in -50.0f64..50.0,
        ) {
            let base = Params::default();
            let p = params_at(&base, h0);
            let q0 = Point2::new(qx, qy);
            let lm = Point2::new(lx, ly);
            prop_assume!(distance(&q0, &lm) > 500.0);
            let v = Vector2::new(vx, vy);
            prop_assume!(v.norm() <= p.max_speed_mps);
            let l = cell_altitude_margin(&p, q0, lm);
            let k_cross = SPEED_OF_LIGHT_MPS / (p.bandwidth_hz * p.d_min_m);
            let f = |h: f64| {
                let ph = params_at(&p, h);
                let c = CellLinear::new(&ph, q0, lm);
                c.cross.dot(&v)
                    - k_cross * c.doppler_gradient(v).norm().hypot(c.ellipse_h(&ph, p.d_min_m))
            };
            prop_assert!(f(h0 + dh) >= f(h0) - l * dh.abs() - 1e-12);
        }

        /// The centre's error bound with the altitude term: for u, v with ĥ·v ≥ s, ‖u‖ ≥ s,
        /// the true centre offset D n(v) at D = D0 + tan η ΔH is within
        /// D0 κ ‖Δv‖² + tan η/(2s) (c ‖Δv‖² + ΔH²/c) of the linear one.
        #[test]
        fn centre_error_bound_with_altitude(
            ux in -30.0f64..30.0, uy in -30.0f64..30.0,
            dx in -20.0f64..20.0, dy in -20.0f64..20.0,
            frac in 0.05f64..1.0, h0 in 500.0f64..1500.0, dh in -40.0f64..40.0,
        ) {
            let p = Params::default();
            let tan = p.observation_angle_rad.tan();
            let u = Vector2::new(ux, uy);
            let un = u.norm();
            prop_assume!(un > 0.5);
            let d = Vector2::new(dx, dy);
            let v = u + d;
            let hat = u.normalize();
            let s = frac * un;
            prop_assume!(hat.dot(&v) >= s);
            let pm = Matrix2::identity() - hat * hat.transpose();
            let d0 = h0 * tan;
            // J is a rotation: the norms are those of the unrotated vectors
            let exact = v.normalize() * (h0 + dh) * tan;
            let lin = hat * (h0 + dh) * tan + pm * v * (d0 / un);
            let err = (exact - lin).norm();
            let kappa = d0 * super::super::CENTRE_CURVATURE_BOUND / (s * s);
            let (a, bq) = error_coefficients(&p, kappa, s);
            let bound = a * d.norm_squared() + bq * dh * dh;
            prop_assert!(err <= bound * (1.0 + 1e-9) + 1e-9, "err {} > bound {}", err, bound);
        }
    }
}
