//! The vehicle limits between slots: the windows over which a slot-average velocity may change
//! (the acceleration limit) and over which the between-slot acceleration may change (the jerk
//! limit), and their tolerances.
//!
//! A plan's velocities are slot averages, v_t = (q_t − q_{t−1})/δ, the start velocity v₀ an
//! instant's (or, for a re-plan, the average of the slot flown before the start,
//! [`crate::params::StartVelocityKind`]). The acceleration into slot t is
//! a_t = (v_t − v_{t−1}) / [`accel_window_s`], and each a_t is a weighted mean of the true
//! acceleration a(τ), a_t = ∫ a(τ) k_t(τ) dτ with a kernel k_t ≥ 0 of unit mass: between two
//! slot averages the triangle of half-width δ centred on the slot boundary (t − 1) δ; from an
//! instantaneous v₀ into slot 1, v₁ − v₀ = (1/δ) ∫₀^δ (δ − τ) a(τ) dτ, the falling ramp
//! 2 (δ − τ)/δ² on [0, δ], whose mean is δ/3. [`accel_time_s`] is the mean of k_t.
//!
//! The jerk limit ‖ȧ‖ ≤ j_max bounds the change from a_{t−1} to a_t: with F_t the integral of
//! k_t from −∞, a_t − a_{t−1} = ∫ ȧ(τ) (F_{t−1}(τ) − F_t(τ)) dτ, and F_{t−1} ≥ F_t everywhere
//! (each kernel lies after the previous one), so ‖a_t − a_{t−1}‖ ≤ j_max ∫ (F_{t−1} − F_t) dτ
//! = j_max (mean of k_t − mean of k_{t−1}) = j_max [`jerk_window_s`], with equality at a
//! constant jerk. The window is δ between slot accelerations and 2δ/3 from the first slot's
//! acceleration (mean δ/3) to the second's (mean δ) after an instantaneous start velocity (δ
//! after a previous slot's average). No acceleration before the start is assumed unless the
//! mission states one (`Params::start_accel_mps2`), so the first slot's acceleration is bounded
//! by the acceleration limit only; a stated one is the acceleration at t = 0 (a point mass:
//! window δ/3 to the first slot's) after an instantaneous start velocity, and the acceleration
//! into the slot flown before (a triangle centred on −δ: window δ) after a previous slot's
//! average.

use super::{Dynamics, Evaluation};
use crate::params::StartVelocityKind;
use crate::Params;

/// The time from the start velocity's instant to the middle of slot `t` (≥ 1), s: (t − ½) δ from
/// an instantaneous start velocity at t = 0, (t − ½) δ + δ/2 from the average of the slot flown
/// before the start ([`crate::params::StartVelocityKind`]). At the acceleration limit the
/// UAV's slot-t velocity differs from the start velocity by at most a_max times this.
pub fn start_to_slot_middle_s(p: &Params, t: usize) -> f64 {
    (t as f64 - 0.5) * p.slot_s + start_velocity_lead_s(p)
}

/// How long before the start the start velocity holds, s: 0 for an instantaneous one, δ/2 for
/// the average of the slot flown before ([`crate::params::StartVelocityKind`]).
pub fn start_velocity_lead_s(p: &Params) -> f64 {
    match p.start_velocity_kind {
        StartVelocityKind::Instant => 0.0,
        StartVelocityKind::PreviousSlot => 0.5 * p.slot_s,
    }
}

/// The time over which slot `t`'s (average) velocity changes from the previous one, s: δ between
/// slot averages, and into the first slot [`start_to_slot_middle_s`] (δ/2 from an instantaneous
/// start velocity: from v₀ at constant acceleration a the UAV is at q₀ + v₀ δ + a δ²/2 after one
/// slot, so its average velocity there is v₀ + a δ/2).
pub fn accel_window_s(p: &Params, t: usize) -> f64 {
    if t == 1 {
        start_to_slot_middle_s(p, 1)
    } else {
        p.slot_s
    }
}

/// The time the acceleration into slot `t` (≥ 1) stands for, s from the start: the mean of the
/// weights it gives the true acceleration (module documentation). (t − 1) δ, the boundary
/// between slots t − 1 and t, for t ≥ 2; for the first slot δ/3 after an instantaneous start
/// velocity and 0 after a previous slot's average (the triangle centred on the start).
pub fn accel_time_s(p: &Params, t: usize) -> f64 {
    if t >= 2 {
        (t as f64 - 1.0) * p.slot_s
    } else {
        match p.start_velocity_kind {
            StartVelocityKind::Instant => p.slot_s / 3.0,
            StartVelocityKind::PreviousSlot => 0.0,
        }
    }
}

/// The time the mission's start acceleration (`Params::start_accel_mps2`) stands for, s from
/// the start: 0 after an instantaneous start velocity (the acceleration at that instant), −δ
/// after a previous slot's average (the acceleration into that slot).
pub fn start_accel_time_s(p: &Params) -> f64 {
    match p.start_velocity_kind {
        StartVelocityKind::Instant => 0.0,
        StartVelocityKind::PreviousSlot => -p.slot_s,
    }
}

/// The time over which the acceleration into slot `t` changes from the previous slot's, s:
/// [`accel_time_s`] of `t` less that of `t − 1`, so that ‖a_t − a_{t−1}‖ ≤ j_max × this for
/// every flight whose jerk stays within j_max (module documentation): δ from the third slot on,
/// and into the second 2δ/3 after an instantaneous start velocity (δ after a previous slot's
/// average). For the first slot, from the mission's start acceleration where it states one
/// ([`start_accel_time_s`]: δ/3, or δ), else `None`: no acceleration before the start is
/// assumed.
pub fn jerk_window_s(p: &Params, t: usize) -> Option<f64> {
    match t {
        0 => None,
        1 => p
            .start_accel_mps2
            .map(|_| accel_time_s(p, 1) - start_accel_time_s(p)),
        _ => Some(accel_time_s(p, t) - accel_time_s(p, t - 1)),
    }
}

/// Relative tolerance on the acceleration limit: a slot is within it when its acceleration is at
/// most `max_accel_mps2` × (1 + this). The planner's constraint keeps
/// [`ACCEL_MARGIN_REL`] inside the limit.
pub const ACCEL_TOL_REL: f64 = 1e-7;

/// Relative margin inside the acceleration limit that the planner's constraint keeps (solver
/// tolerances stay inside it).
pub const ACCEL_MARGIN_REL: f64 = 1e-6;

/// Relative tolerance on the jerk limit: a slot is within it when its jerk is at most
/// `max_jerk_mps3` × (1 + this). The planner's constraint keeps [`JERK_MARGIN_REL`] inside it.
pub const JERK_TOL_REL: f64 = 1e-7;

/// Relative margin inside the jerk limit that the planner's constraint keeps (solver tolerances
/// stay inside it).
pub const JERK_MARGIN_REL: f64 = 1e-6;

/// Whether a slot's jerk `jerk_mps3` is above the mission's jerk limit (to [`JERK_TOL_REL`];
/// never without a limit).
pub fn over_jerk_limit(p: &Params, jerk_mps3: f64) -> bool {
    p.max_jerk_mps3
        .is_some_and(|limit| jerk_mps3 > limit * (1.0 + JERK_TOL_REL) || jerk_mps3.is_nan())
}

/// The acceleration change beyond the jerk limit summed over the slots,
/// Σ_t (jerk_t − j_max)⁺ × [`jerk_window_s`], m/s²: what the elastic subproblem's jerk slacks
/// bound (phase I's measure). 0 under [`Dynamics::Paper`] or without a jerk limit.
pub fn jerk_excess_mps2(p: &Params, ev: &Evaluation, dynamics: Dynamics) -> f64 {
    let Some(limit) = p.max_jerk_mps3.filter(|_| dynamics == Dynamics::Vehicle) else {
        return 0.0;
    };
    ev.slots
        .iter()
        .filter_map(|s| jerk_window_s(p, s.t).map(|w| (s.jerk_mps3 - limit).max(0.0) * w))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Slot averages of a flight at constant jerk j from v₀ (and acceleration a₀ at t = 0):
    /// v(τ) = v₀ + a₀ τ + j τ²/2, averaged over [(t − 1) δ, t δ] in closed form.
    fn slot_average(v0: f64, a0: f64, j: f64, delta: f64, t: i32) -> f64 {
        let (lo, hi) = ((f64::from(t) - 1.0) * delta, f64::from(t) * delta);
        let integral = |x: f64| v0 * x + a0 * x * x / 2.0 + j * x * x * x / 6.0;
        (integral(hi) - integral(lo)) / delta
    }

    /// At a constant jerk every slot acceleration equals the true acceleration at its
    /// [`accel_time_s`], so the acceleration changes by exactly j × [`jerk_window_s`]: the
    /// windows are tight, for an instantaneous start velocity and a previous slot's average.
    #[test]
    fn constant_jerk_changes_the_slot_accelerations_by_exactly_the_window() {
        let (v0, a0, j, delta) = (3.0, -1.5, 7.0, 0.5);
        for kind in [StartVelocityKind::Instant, StartVelocityKind::PreviousSlot] {
            let p = Params {
                slot_s: delta,
                start_velocity_kind: kind,
                ..Params::default()
            };
            // the start velocity: the instant's, or the average of the slot before the start
            let start = match kind {
                StartVelocityKind::Instant => v0,
                StartVelocityKind::PreviousSlot => slot_average(v0, a0, j, delta, 0),
            };
            let v = |t: usize| {
                if t == 0 {
                    start
                } else {
                    slot_average(v0, a0, j, delta, t as i32)
                }
            };
            let accel = |t: usize| (v(t) - v(t - 1)) / accel_window_s(&p, t);
            for t in 1..=6 {
                let expected = a0 + j * accel_time_s(&p, t);
                assert!((accel(t) - expected).abs() < 1e-12, "{kind:?} slot {t}");
            }
            assert_eq!(jerk_window_s(&p, 1), None);
            for t in 2..=6 {
                let w = jerk_window_s(&p, t).unwrap_or(f64::NAN);
                assert!(
                    ((accel(t) - accel(t - 1)) - j * w).abs() < 1e-12,
                    "{kind:?} {t}"
                );
            }
        }
        let p = Params {
            slot_s: delta,
            ..Params::default()
        };
        // the closed forms of the module documentation
        assert!((jerk_window_s(&p, 2).unwrap_or(0.0) - 2.0 * delta / 3.0).abs() < 1e-15);
        assert!((jerk_window_s(&p, 3).unwrap_or(0.0) - delta).abs() < 1e-15);
    }

    /// A stated start acceleration: at a constant jerk the first slot's acceleration differs
    /// from it by exactly j × the first window, from the instant's acceleration a₀ (window δ/3)
    /// and from the acceleration into the slot flown before (window δ).
    #[test]
    fn the_first_slot_counts_its_jerk_from_a_stated_start_acceleration() {
        let (v0, a0, j, delta) = (3.0, -1.5, 7.0, 0.5);
        for kind in [StartVelocityKind::Instant, StartVelocityKind::PreviousSlot] {
            let p = Params {
                slot_s: delta,
                start_velocity_kind: kind,
                start_accel_mps2: Some([0.0, 0.0]),
                ..Params::default()
            };
            let (start_v, start_a) = match kind {
                StartVelocityKind::Instant => (v0, a0),
                StartVelocityKind::PreviousSlot => {
                    let before = slot_average(v0, a0, j, delta, 0);
                    let earlier = slot_average(v0, a0, j, delta, -1);
                    (before, (before - earlier) / delta)
                }
            };
            let a1 = (slot_average(v0, a0, j, delta, 1) - start_v) / accel_window_s(&p, 1);
            let w = jerk_window_s(&p, 1).unwrap_or(f64::NAN);
            assert!(
                ((a1 - start_a) - j * w).abs() < 1e-12,
                "{kind:?}: {a1} {start_a} {w}"
            );
        }
        let p = Params {
            slot_s: delta,
            start_accel_mps2: Some([0.0, 0.0]),
            ..Params::default()
        };
        assert!((jerk_window_s(&p, 1).unwrap_or(0.0) - delta / 3.0).abs() < 1e-15);
    }

    /// Any flight within the jerk limit, here a jerk that switches sign between ±j within the
    /// slots (bang-bang, integrated exactly), changes its slot accelerations by at most
    /// j × [`jerk_window_s`].
    #[test]
    fn a_jerk_limited_flight_keeps_the_window_bound() {
        let (j, delta) = (4.0, 0.5);
        let p = Params {
            slot_s: delta,
            ..Params::default()
        };
        // jerk +j until 0.3 s, −j until 1.1 s, +j after; velocity by exact integration
        let switches = [0.0, 0.3, 1.1, f64::INFINITY];
        let jerk_at = |k: usize| if k.is_multiple_of(2) { j } else { -j };
        let velocity = |x: f64| {
            let (mut v, mut a) = (0.0, 0.0);
            for k in 0..3 {
                let (lo, hi) = (switches[k], switches[k + 1].min(x));
                if hi <= lo {
                    break;
                }
                let dt = hi - lo;
                v += a * dt + jerk_at(k) * dt * dt / 2.0;
                a += jerk_at(k) * dt;
            }
            v
        };
        // slot averages by Simpson's rule on a fine grid (exact for piecewise cubics between
        // switches, which fall on grid points)
        let average = |t: usize| {
            let (lo, n) = ((t as f64 - 1.0) * delta, 1000);
            let h = delta / n as f64;
            let sum: f64 = (0..=n)
                .map(|i| {
                    let w = if i == 0 || i == n {
                        1.0
                    } else if i % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    w * velocity(lo + i as f64 * h)
                })
                .sum();
            sum * h / 3.0 / delta
        };
        let v = |t: usize| if t == 0 { 0.0 } else { average(t) };
        let accel = |t: usize| (v(t) - v(t - 1)) / accel_window_s(&p, t);
        for t in 2..=6 {
            let w = jerk_window_s(&p, t).unwrap_or(f64::NAN);
            let change = (accel(t) - accel(t - 1)).abs();
            assert!(
                change <= j * w * (1.0 + 1e-9),
                "slot {t}: {change} > {}",
                j * w
            );
        }
    }
}
