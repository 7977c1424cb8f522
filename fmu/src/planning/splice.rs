//! The rest of a mission after a splice: what a re-plan from a flown slot starts from (position,
//! velocity and altitude flown there) and covers (the windows still ahead), and the altitude
//! profile spliced from the flown part and the re-plan.

use planner::{LandmarkWindow, Mission, Trajectory};

/// The altitude profile of a re-plan from `from_slot`: `current_m` (the plan flown; `None`: at
/// the mission's `altitude_m`) up to slot `from_slot`, then `planned_m` (the sub-mission's plan;
/// `None`: at its altitude `sub_altitude_m`); `None` when neither has a profile.
pub(super) fn splice_altitudes_m(
    mission: &Mission,
    current_m: Option<&[f64]>,
    planned_m: Option<&[f64]>,
    from_slot: usize,
    sub_altitude_m: f64,
) -> Option<Vec<f64>> {
    if current_m.is_none() && planned_m.is_none() {
        return None;
    }
    let mut spliced = match current_m {
        Some(z) => z.get(..from_slot).unwrap_or(z).to_vec(),
        None => vec![mission.params().altitude_m; from_slot],
    };
    match planned_m {
        Some(z) => spliced.extend_from_slice(z),
        None => spliced.resize(mission.slots(), sub_altitude_m),
    }
    Some(spliced)
}

/// The part of the horizon a re-plan from `from_slot` covers (see [`replan`]).
pub(super) struct Remainder {
    /// Time of `from_slot`, s: the sub-mission's clock starts there.
    pub(super) shift_s: f64,
    /// Slots left after `from_slot`.
    pub(super) remaining: usize,
    /// The windows still (partly) ahead, with their index in the mission, shifted by `shift_s`.
    pub(super) future: Vec<(usize, LandmarkWindow)>,
    /// The sub-mission's parameters: starting at q_{from_slot} (at H_{from_slot} for a
    /// free-altitude plan), over the remaining slots.
    pub(super) sub_params: planner::Params,
    /// The rest of the current plan, as the sub-mission's warm start.
    pub(super) init: Trajectory,
    /// The moved window's first and last slot in the sub-mission (1-based), when it has any left.
    pub(super) moved_slots: Option<(usize, usize)>,
}

/// The remainder of `moved` (the mission with window `window` moved) after `from_slot`
/// (`from_slot < moved.slots()`), flown so far along `current` at `altitudes_m` (`None`: the
/// mission's fixed altitude).
pub(super) fn remainder(
    moved: &Mission,
    current: &Trajectory,
    altitudes_m: Option<&[f64]>,
    from_slot: usize,
    window: usize,
) -> Remainder {
    let p = moved.params();
    let slot_s = p.slot_s;
    let n = moved.slots();
    let shift_s = from_slot as f64 * slot_s;
    let remaining = n - from_slot;
    let sched = moved.schedule();
    let later = sched.slot_landmark.get(from_slot..).unwrap_or(&[]);
    let future: Vec<(usize, LandmarkWindow)> = sched
        .landmarks
        .iter()
        .enumerate()
        .filter(|(i, _)| later.contains(&Some(*i)))
        .map(|(i, w)| {
            (
                i,
                LandmarkWindow {
                    x_m: w.x_m,
                    y_m: w.y_m,
                    from_s: (w.from_s - shift_s).max(0.0),
                    to_s: (w.to_s - shift_s).min(remaining as f64 * slot_s),
                },
            )
        })
        .collect();
    let mut sub_params = p.clone();
    sub_params.start_m = current.q(from_slot);
    sub_params.horizon_s = remaining as f64 * slot_s;
    if from_slot > 0 {
        sub_params.start_velocity_mps = Some(splice_velocity_mps(current, from_slot, p));
        // a slot average, not the velocity at the splice instant: the next slot's average may
        // differ from it by a_max δ
        sub_params.start_velocity_kind = planner::StartVelocityKind::PreviousSlot;
        // under a jerk limit the re-plan's first acceleration counts from the one flown into
        // that slot, so the commanded acceleration does not jump at the splice
        if p.max_jerk_mps3.is_some() {
            sub_params.start_accel_mps2 = Some(splice_accel_mps2(moved, current, from_slot));
        }
    }
    // the altitude flown at q_{from_slot}, within the bounds (a plan meets them to rounding)
    if let Some(h) = from_slot
        .checked_sub(1)
        .and_then(|k| altitudes_m?.get(k).copied())
    {
        let (lo, hi) = planner::altitude::bounds_m(p);
        sub_params = planner::altitude::params_at(&sub_params, h.clamp(lo, hi));
    }
    let init = Trajectory {
        slot_s,
        start_m: current.q(from_slot),
        pos_m: current.pos_m.get(from_slot..).unwrap_or(&[]).to_vec(),
    };
    // the moved window's slots in the sub-mission (1-based), when it has any left
    let moved_slots = later
        .iter()
        .position(|l| *l == Some(window))
        .zip(later.iter().rposition(|l| *l == Some(window)))
        .map(|(a, b)| (a + 1, b + 1));
    Remainder {
        shift_s,
        remaining,
        future,
        sub_params,
        init,
        moved_slots,
    }
}

/// The UAV's velocity as it passes q_{from_slot} on `current` (`from_slot` ≥ 1): that of the
/// last committed slot, (q_{from_slot} − q_{from_slot−1})/δ, at most the speed limit (a plan may
/// pass it by rounding). It is the sub-mission's start velocity (of kind
/// [`planner::StartVelocityKind::PreviousSlot`]), so that a re-plan under the
/// vehicle dynamics (`planner::PlanOptions::dynamics`) continues from the velocity flown instead
/// of the mission's start rule; the paper's dynamics ignore it.
fn splice_velocity_mps(current: &Trajectory, from_slot: usize, p: &planner::Params) -> [f64; 2] {
    let (a, b) = (current.q(from_slot - 1), current.q(from_slot));
    let v = [(b[0] - a[0]) / p.slot_s, (b[1] - a[1]) / p.slot_s];
    let speed = v[0].hypot(v[1]);
    if speed > p.max_speed_mps {
        let k = p.max_speed_mps / speed;
        [v[0] * k, v[1] * k]
    } else {
        v
    }
}

/// The acceleration flown into slot `from_slot` (≥ 1) of `current`, (v_k − v_{k−1}) over its
/// window ([`planner::evaluate::accel_window_s`]; v₀ the mission's start velocity), at most
/// `max_accel_mps2` (a plan may pass it by rounding): the sub-mission's start acceleration,
/// from which a re-plan's first slot counts its jerk.
fn splice_accel_mps2(mission: &Mission, current: &Trajectory, from_slot: usize) -> [f64; 2] {
    let p = mission.params();
    let velocity = |k: usize| {
        if k == 0 {
            return mission.start_velocity_mps();
        }
        let (a, b) = (current.q(k - 1), current.q(k));
        [(b[0] - a[0]) / p.slot_s, (b[1] - a[1]) / p.slot_s]
    };
    let (a, b) = (velocity(from_slot - 1), velocity(from_slot));
    let w = planner::evaluate::accel_window_s(p, from_slot);
    let acc = [(b[0] - a[0]) / w, (b[1] - a[1]) / w];
    let magnitude = acc[0].hypot(acc[1]);
    if magnitude > p.max_accel_mps2 {
        let k = p.max_accel_mps2 / magnitude;
        [acc[0] * k, acc[1] * k]
    } else {
        acc
    }
}
