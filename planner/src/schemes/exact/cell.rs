//! The resolution-cell constraint of the `exact` scheme: the cell's worst width (the major axis
//! of its ellipse, erratum 12 (docs/paper-notes.md)) within d_min in a landmark slot, as one
//! second-order cone in the velocity, with a position margin (hard) or a deficit slack (best
//! effort).

use crate::geometry::{CellLinear, Length, Point2, Vector2};
use crate::params::SPEED_OF_LIGHT_MPS;
use crate::socp::{Lin, ProblemBuilder};
use crate::Params;

/// Where the resolution-cell constraints of one landmark slot are expanded.
#[derive(Debug, Clone, Copy)]
pub(super) struct ResolutionSlot {
    /// Previous position q_t^(ℓ).
    pub(super) q0: Point2<f64>,
    /// Previous step u_t.
    pub(super) step0: Vector2<f64>,
    /// The landmark.
    pub(super) landmark: Point2<f64>,
    pub(super) x: usize,
    pub(super) y: usize,
    /// Hard cell constraints: m_t ≥ ‖q_t − q0‖ (for the position margin).
    pub(super) shift: Option<usize>,
    pub(super) sigma: Option<usize>,
    /// Best effort: the deficit slack ρ_t.
    pub(super) rho: Option<usize>,
}

/// Safety factor on the finite-difference Lipschitz estimates of the cell terms in q.
const CELL_MARGIN_FACTOR: f64 = 3.0;

/// Position sensitivity L of the worst-width cone around `q0`: for speeds up to V_m,
/// |f(q, v) − f(q0, v)| ≤ L ‖q − q0‖ for f = s k(q)·v − c/(B d_min) ‖(A(q) v, h(q))‖
/// ([`CellLinear`], [`CellLinear::ellipse_h`]): L = (‖Δk‖ + c/(B d_min) ‖ΔA‖_F) V_m +
/// c/(B d_min) |Δh| per metre, estimated by finite differences and multiplied by
/// `CELL_MARGIN_FACTOR`; the property test in this module checks the bound.
pub fn cell_margin(p: &crate::Params, q0: Point2<f64>, landmark: Point2<f64>) -> f64 {
    let cl = CellLinear::new(p, q0, landmark);
    let k_cross = SPEED_OF_LIGHT_MPS / (p.bandwidth_hz * p.d_min_m);
    let h0 = cl.ellipse_h(p, p.d_min_m);
    let step = 1.0;
    let mut l: f64 = 0.0;
    for dir in [Vector2::x(), Vector2::y(), -Vector2::x(), -Vector2::y()] {
        let c2 = CellLinear::new(p, q0 + dir * step, landmark);
        let dk = (c2.cross - cl.cross).length() / step;
        let dh = (c2.ellipse_h(p, p.d_min_m) - h0).abs() / step;
        // Frobenius norm of the change of A (summed in the order of the entries: A is symmetric)
        let da = (c2.doppler_map - cl.doppler_map)
            .iter()
            .map(|x| x * x)
            .sum::<f64>()
            .sqrt()
            / step;
        l = l.max((dk + k_cross * da) * p.max_speed_mps + k_cross * dh);
    }
    l * CELL_MARGIN_FACTOR
}

/// Best effort plans the cell against this fraction of d_min. Its deficit model leaves out the
/// position margin (see `resolution_cell_constraints`), so a step lands on the model's
/// boundary, which the true cell at the moved position slightly exceeds; planning 5 % inside
/// d_min lands the true widths at or under it. On the default 30 m mission, from the
/// least-energy plan: 0.97 leaves 15 slots unresolved after 40 cone programs, 0.95 the same 15
/// after 27, 1.0 oscillates between 5 and 8 unresolved windows of widths just above d_min.
pub const BEST_EFFORT_CELL_TARGET_FRACTION: f64 = 0.95;

/// The worst width of the resolution cell ≤ d_min (erratum 12 (docs/paper-notes.md)), convexified.
///
/// At a fixed UAV position the worst width (the major axis of the cell's ellipse) is at most d
/// exactly where s k·v ≥ c/(B d) ‖(A v, h)‖ (CellLinear): one second-order cone in the velocity
/// v, with s the side of the blind line the previous iterate is on and d the width required.
///
/// - Hard constraints (`rs.shift`): d = d_min, and the dependence on the position is covered by
///   a margin L ‖q_t − q_t^(ℓ)‖ with L a (safety-factored) finite-difference bound
///   ([`cell_margin`]), so the constraint is exact at the previous iterate and every solution
///   meets it.
/// - Best effort (`rs.rho`): d = [`BEST_EFFORT_CELL_TARGET_FRACTION`] d_min, a deficit slack,
///   and no position margin. The model is then optimistic, and the driver checks every step on
///   the exact geometry (the merit must fall); with the proven margin the slack SCA creeps.
///
/// `p` are the parameters at the slot's previous altitude; with a free altitude and hard
/// constraints, `altitude_shift` is the variable m_H ≥ |H_t − H_t^(ℓ)| and the cone gets the
/// margin [`super::cell_altitude_margin`] m_H too.
pub(super) fn resolution_cell_constraints(
    b: &mut ProblemBuilder,
    p: &Params,
    altitude_shift: Option<usize>,
    rs: ResolutionSlot,
    vx: &Lin,
    vy: &Lin,
) {
    let delta = p.slot_s;
    let d_m = match rs.rho {
        Some(_) => BEST_EFFORT_CELL_TARGET_FRACTION * p.d_min_m,
        None => p.d_min_m,
    };
    let cl = CellLinear::new(p, rs.q0, rs.landmark);
    let side = if cl.cross.dot(&rs.step0) >= 0.0 {
        1.0
    } else {
        -1.0
    };
    let k_cross = SPEED_OF_LIGHT_MPS / (p.bandwidth_hz * d_m);
    let h = k_cross * cl.ellipse_h(p, d_m);
    // s k·v/δ, with v the step (m per slot)
    let mut head = vx
        .clone()
        .scaled(side * cl.cross.x / delta)
        .plus_lin(&vy.clone().scaled(side * cl.cross.y / delta));
    if let Some(shift) = rs.shift {
        // m ≥ ‖q_t − q0‖
        b.soc(
            Lin::var(shift, 1.0),
            &[
                Lin::var(rs.x, 1.0).plus_const(-rs.q0.x),
                Lin::var(rs.y, 1.0).plus_const(-rs.q0.y),
            ],
        );
        head = head.plus(shift, -cell_margin(p, rs.q0, rs.landmark));
    }
    if let Some(m) = altitude_shift {
        head = head.plus(m, -super::cell_altitude_margin(p, rs.q0, rs.landmark));
    }
    if let Some(sig) = rs.sigma {
        // one metre of slack relaxes the width requirement by about one metre
        let rhs = cl.grad.length() / (p.integration_time_s * d_m);
        head = head.plus(sig, rhs / d_m);
    }
    let a = cl.doppler_map;
    if let Some(rho) = rs.rho {
        // ρ ≥ d (c/(B d) ‖(A v, h)‖ − s k·v) / (c/(B d) ‖(A u, h)‖): zero where the cone holds,
        // d (1 − s k·u / (c/(B d) ‖(A u, h)‖)) at the previous iterate's velocity u
        let au = (k_cross * (a * (rs.step0 / delta))).length().hypot(h);
        head = head.plus(rho, au.max(1e-12) / d_m);
    }
    let av = |i: usize| {
        vx.clone()
            .scaled(k_cross * a[(i, 0)] / delta)
            .plus_lin(&vy.clone().scaled(k_cross * a[(i, 1)] / delta))
    };
    b.soc(head, &[av(0), av(1), Lin::constant_only(h)]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::distance;
    use proptest::prelude::*;

    proptest! {
        /// The cell constraints linearised at q0 with the position margin imply the exact ones at
        /// q0 + Δq (|Δq| ≤ 60 m, speeds ≤ V_m, UAV at least 500 m from the landmark).
        #[test]
        fn cell_margin_is_conservative(
            qx in -3000.0f64..3000.0, qy in -3000.0f64..3000.0,
            lx in -1500.0f64..1500.0, ly in -1500.0f64..1500.0,
            dqx in -60.0f64..60.0, dqy in -60.0f64..60.0,
            vx in -50.0f64..50.0, vy in -50.0f64..50.0,
        ) {
            let p = crate::Params::default();
            let q0 = Point2::new(qx, qy);
            let lm = Point2::new(lx, ly);
            prop_assume!(distance(&q0, &lm) > 500.0);
            let v = Vector2::new(vx, vy);
            prop_assume!(v.norm() <= p.max_speed_mps);
            let dq = Vector2::new(dqx, dqy);
            let q1 = q0 + dq;
            let l = cell_margin(&p, q0, lm);
            let k_cross = SPEED_OF_LIGHT_MPS / (p.bandwidth_hz * p.d_min_m);
            let f = |q: Point2<f64>| {
                let c = CellLinear::new(&p, q, lm);
                c.cross.dot(&v)
                    - k_cross * c.doppler_gradient(v).norm().hypot(c.ellipse_h(&p, p.d_min_m))
            };
            let dq = dq.norm();
            prop_assert!(f(q1) >= f(q0) - l * dq - 1e-12);
        }
    }
}
