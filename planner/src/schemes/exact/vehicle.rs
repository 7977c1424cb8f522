//! The vehicle limits of the exact subproblem: one second-order cone per slot for the
//! acceleration limit and, with a jerk limit, one per slot from the second on for the jerk. Both
//! are exact (linear in the positions inside a cone), so every iterate meets them on the exact
//! geometry.

use crate::evaluate::{accel_window_s, jerk_window_s, ACCEL_MARGIN_REL, JERK_MARGIN_REL};
use crate::socp::{Lin, ProblemBuilder};
use crate::Mission;

use super::{step_exprs, ExactTuning, SlotVars};

/// The time over which the first slot's velocity may change from the start velocity, s
/// ([`ExactTuning::first_accel_window_s`], else [`accel_window_s`] of slot 1).
fn first_window_s(mission: &Mission, tuning: &ExactTuning) -> f64 {
    tuning
        .first_accel_window_s
        .unwrap_or_else(|| accel_window_s(mission.params(), 1))
}

/// δ² a_t as affine expressions of the positions, a_t the acceleration into slot `t`: the step
/// change s_t − s_{t−1} for t ≥ 2, and (δ/w)(s₁ − v₀ δ) into the first slot (w its window,
/// v₀ the start velocity).
fn scaled_accel_exprs(
    mission: &Mission,
    tuning: &ExactTuning,
    (vars, start_m): (&[SlotVars], [f64; 2]),
    t: usize,
) -> (Lin, Lin) {
    let delta = mission.params().slot_s;
    let (sx, sy) = step_exprs(vars, t, start_m);
    if t == 1 {
        let v0 = mission.start_velocity_mps();
        let k = delta / first_window_s(mission, tuning);
        (
            sx.plus_const(-v0[0] * delta).scaled(k),
            sy.plus_const(-v0[1] * delta).scaled(k),
        )
    } else {
        let (px, py) = step_exprs(vars, t - 1, start_m);
        (sx.minus_lin(&px), sy.minus_lin(&py))
    }
}

/// The vehicle's acceleration limit into slot `t`: ‖v_t − v_{t−1}‖ ≤ a_max δ in steps,
/// ‖s_t − s_{t−1}‖ ≤ a_max δ² (1 − [`ACCEL_MARGIN_REL`]) (+ τ_t in elastic mode), with
/// s_0 = v_0 δ from the mission's start velocity and, for the first slot, a_max δ w
/// (w = [`ExactTuning::first_accel_window_s`], δ/2 by default: v₀ is the velocity at t = 0).
pub(super) fn accel_cone(
    b: &mut ProblemBuilder,
    mission: &Mission,
    tuning: &ExactTuning,
    (vars, start_m): (&[SlotVars], [f64; 2]),
    t: usize,
    (vx, vy): (&Lin, &Lin),
) {
    let p = mission.params();
    let delta = p.slot_s;
    let (dx, dy, window) = if t == 1 {
        let v0 = mission.start_velocity_mps();
        (
            vx.clone().plus_const(-v0[0] * delta),
            vy.clone().plus_const(-v0[1] * delta),
            first_window_s(mission, tuning),
        )
    } else {
        let (px, py) = step_exprs(vars, t - 1, start_m);
        (vx.clone().minus_lin(&px), vy.clone().minus_lin(&py), delta)
    };
    let mut head = Lin::constant_only(p.max_accel_mps2 * delta * window * (1.0 - ACCEL_MARGIN_REL));
    if let Some(tau) = vars[t - 1].accel_slack {
        head = head.plus(tau, 1.0);
    }
    b.soc(head, &[dx, dy]);
}

/// The vehicle's jerk limit into slot `t`, where the mission sets one:
/// ‖a_t − a_{t−1}‖ ≤ j_max ω_t with ω_t = [`jerk_window_s`], in positions
/// ‖δ² a_t − δ² a_{t−1}‖ ≤ j_max ω_t δ² (1 − [`JERK_MARGIN_REL`]) (+ the slack in elastic
/// mode): the third difference s_t − 2 s_{t−1} + s_{t−2} of the positions from the third slot
/// on, into the second slot s₂ − s₁ − (δ/w)(s₁ − v₀ δ) (w the first slot's window), and into
/// the first (δ/w)(s₁ − v₀ δ) − δ² a₀ from the mission's start acceleration a₀. Nothing in the
/// first slot when the mission states no start acceleration, or without a limit.
pub(super) fn jerk_cone(
    b: &mut ProblemBuilder,
    mission: &Mission,
    tuning: &ExactTuning,
    (vars, start_m): (&[SlotVars], [f64; 2]),
    t: usize,
) {
    let p = mission.params();
    let (Some(limit), Some(window)) = (p.max_jerk_mps3, jerk_window_s(p, t)) else {
        return;
    };
    let delta = p.slot_s;
    let (ax, ay) = scaled_accel_exprs(mission, tuning, (vars, start_m), t);
    let (px, py) = match (t, p.start_accel_mps2) {
        (1, Some(a0)) => (
            Lin::constant_only(a0[0] * delta * delta),
            Lin::constant_only(a0[1] * delta * delta),
        ),
        _ => scaled_accel_exprs(mission, tuning, (vars, start_m), t - 1),
    };
    let mut head = Lin::constant_only(limit * window * delta * delta * (1.0 - JERK_MARGIN_REL));
    if let Some(tau) = vars[t - 1].jerk_slack {
        head = head.plus(tau, 1.0);
    }
    b.soc(head, &[ax.minus_lin(&px), ay.minus_lin(&py)]);
}
