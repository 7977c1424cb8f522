//! Before solving: necessary conditions of feasibility (reported with the first bad slot), and a
//! start trajectory built by a guidance law that orbits a reference point gliding along the
//! landmark sequence (a clockwise orbit of radius H tan η keeps a point at the sensing centre).

use serde::{Deserialize, Serialize};

use crate::evaluate::{Dynamics, ResolutionMode, ACCEL_MARGIN_REL};
use crate::geometry::{distance, heading_unit, Point2, ResolutionCell, Vector2, RIGHT_TURN};
use crate::power::PowerModel;
use crate::{Mission, Trajectory};

/// Why a mission cannot be flown, found before solving.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[error("mission cannot be flown: slot {slot} (t = {t_s} s): {reason}")]
pub struct Infeasibility {
    /// First slot (1-based) where the mission fails.
    pub slot: usize,
    /// End time of that slot, s.
    pub t_s: f64,
    /// What cannot be met.
    pub reason: String,
}

/// The earliest slot `t` in `first..=last` (1-based) at whose end a UAV that starts at
/// `p.start_m` could have landmark `g_m` in view, or `None` when no slot of that range can.
///
/// This is a necessary condition only (it ignores everything but the speed limit and the
/// sensing geometry), so a slot it rules out is certainly infeasible. After t − 1 slots the UAV is
/// within V_m (t − 1) δ of the start; in slot t it moves by s ≤ V_m δ along its heading and the
/// sensing centre lies H tan η to the right of that heading, so the centre lies within
/// V_m (t − 1) δ + √((V_m δ)² + (H tan η)²) and beyond H tan η − V_m (t − 1) δ of the start. The
/// [`precheck`] uses it for the first landmark slot (a looser bound of a full slot of travel
/// V_m δ towards the landmark, about 15 m more on the default mission, let landmarks just out
/// of reach through, and phase I then searched for seconds before it gave up).
pub fn earliest_in_view_slot(
    p: &crate::Params,
    g_m: [f64; 2],
    first: usize,
    last: usize,
) -> Option<usize> {
    // the planner accepts plans that violate speed and sensing by up to FEASIBILITY_TOL
    let tol = crate::evaluate::FEASIBILITY_TOL;
    let offset = p.centre_offset_m();
    let v_step = (p.max_speed_mps + tol) * p.slot_s;
    let r = p.sensing_radius_m + tol;
    let d = distance(&Point2::from(p.start_m), &Point2::from(g_m));
    let last_hop = v_step.hypot(offset);
    let slack = 1e-9 * (1.0 + d + offset);
    (first.max(1)..=last).find(|&t| {
        let travel = v_step * (t - 1) as f64;
        d <= travel + last_hop + r + slack && d + travel + r + slack >= offset
    })
}

/// Whether a UAV that has landmark `g1_m` in view at the end of some slot can have `g2_m` in
/// view at the end of the slot `slots` (≥ 1) later: a necessary condition only, with the same
/// argument as [`earliest_in_view_slot`]. At the first slot the UAV lies within H tan η + r_s of
/// `g1_m` (its centre within r_s, the centre H tan η from it); it then flies at most
/// V_m δ (slots − 1) before the last slot, in which it moves by s ≤ V_m δ and its centre ends
/// √(s² + (H tan η)²) from where it was. So the landmarks can lie at most
/// 2 r_s + H tan η + √((V_m δ)² + (H tan η)²) + V_m δ (slots − 1) apart, about V_m δ − 0.2 m
/// less on the default mission than the bound 2 (H tan η + r_s) + V_m δ slots of two annuli.
pub fn reachable_between(p: &crate::Params, g1_m: [f64; 2], g2_m: [f64; 2], slots: usize) -> bool {
    let tol = crate::evaluate::FEASIBILITY_TOL;
    let offset = p.centre_offset_m();
    let v_step = (p.max_speed_mps + tol) * p.slot_s;
    let r = p.sensing_radius_m + tol;
    let d = distance(&Point2::from(g1_m), &Point2::from(g2_m));
    let reach = 2.0 * r + offset + v_step.hypot(offset) + v_step * slots.saturating_sub(1) as f64;
    d <= reach + 1e-9 * (1.0 + d + offset)
}

/// [`precheck`], and under [`Dynamics::Vehicle`] also: the azimuth speed V_min reachable by the
/// first landmark slot t₀ from the start velocity v₀ at the acceleration limit,
/// ‖v₀‖ + a_max δ (t₀ − ½) ≥ V_min (a necessary condition: slot t₀'s average velocity is that of
/// its middle, (t₀ − ½) δ after the start).
pub fn precheck_with(mission: &Mission, dynamics: Dynamics) -> Result<(), Infeasibility> {
    precheck(mission)?;
    if dynamics == Dynamics::Paper {
        return Ok(());
    }
    let p = mission.params();
    let Some(t0) = (1..=mission.slots()).find(|&t| mission.target_m(t).is_some()) else {
        return Ok(());
    };
    let v0 = mission.start_velocity_mps();
    let speed0 = v0[0].hypot(v0[1]);
    let reach = speed0 + p.max_accel_mps2 * crate::evaluate::start_to_slot_middle_s(p, t0);
    let v_min = p.min_speed_mps();
    if reach < v_min - crate::evaluate::FEASIBILITY_TOL {
        return Err(Infeasibility {
            slot: t0,
            t_s: t0 as f64 * p.slot_s,
            reason: format!(
                "the first landmark's slot needs the azimuth speed {v_min:.3} m/s, but from \
                 start_velocity_mps = ({}, {}) m/s at max_accel_mps2 = {:.3} m/s² the UAV \
                 reaches at most {reach:.3} m/s on average in that slot, ending at t = {} s (state a start velocity, a larger \
                 max_accel_mps2, or plan with the paper's dynamics)",
                v0[0],
                v0[1],
                p.max_accel_mps2,
                t0 as f64 * p.slot_s
            ),
        });
    }
    Ok(())
}

/// Checks necessary conditions: the azimuth requirement within the speed limit, the range
/// requirement attainable, each landmark reachable from the start and from the previous landmark
/// slot at the maximum speed. Passing does not prove feasibility; failing proves infeasibility.
pub fn precheck(mission: &Mission) -> Result<(), Infeasibility> {
    let p = mission.params();
    let offset = p.centre_offset_m();
    let r = p.sensing_radius_m;
    let fail = |slot: usize, reason: String| Infeasibility {
        slot,
        t_s: slot as f64 * p.slot_s,
        reason,
    };
    let landmark_slots: Vec<(usize, [f64; 2])> = (1..=mission.slots())
        .filter_map(|t| mission.target_m(t).map(|g| (t, g)))
        .collect();
    let Some(&(first, _)) = landmark_slots.first() else {
        return Ok(());
    };
    let v_min = p.min_speed_mps();
    if v_min > p.max_speed_mps {
        return Err(fail(
            first,
            format!(
                "the azimuth requirement needs a speed of at least {v_min:.3} m/s \
                 (λ_c H / (T_d d_min cos η)), above max_speed_mps = {}",
                p.max_speed_mps
            ),
        ));
    }
    match p.range_keepout_m() {
        Some(k) if k.is_infinite() => {
            return Err(fail(
                first,
                format!(
                    "the range requirement c/(B (sin η + sin θ)) <= d_min cannot hold anywhere: \
                     c/(B d_min) − sin η = {:.4} >= 1",
                    p.range_sin_threshold()
                ),
            ))
        }
        Some(k) => {
            for &(t, g) in &landmark_slots {
                if distance(&Point2::from(g), &Point2::from(p.bs_m)) + r < k {
                    return Err(fail(
                        t,
                        format!(
                            "landmark ({}, {}) m: the whole sensing disc lies within {k:.1} m of \
                             the BS, where the paper's range resolution exceeds d_min",
                            g[0], g[1]
                        ),
                    ));
                }
            }
        }
        None => {}
    }
    // reachability from the start
    let (t0, g0) = landmark_slots[0];
    if earliest_in_view_slot(p, g0, t0, t0).is_none() {
        let travel = (t0 - 1) as f64 * p.slot_s * p.max_speed_mps;
        let far = travel + (p.slot_s * p.max_speed_mps).hypot(offset) + r;
        let near = (offset - travel - r).max(0.0);
        return Err(fail(
            t0,
            format!(
                "landmark ({}, {}) m is out of reach in time: it lies {:.1} m from the start, \
                 but by t = {} s at max_speed_mps = {} the sensing disc can only cover points \
                 between {near:.1} and {far:.1} m from it",
                g0[0],
                g0[1],
                distance(&Point2::from(p.start_m), &Point2::from(g0)),
                t0 as f64 * p.slot_s,
                p.max_speed_mps
            ),
        ));
    }
    for w in landmark_slots.windows(2) {
        let ((t1, g1), (t2, g2)) = (w[0], w[1]);
        if !reachable_between(p, g1, g2, t2 - t1) {
            let reach = (t2 - t1 - 1) as f64 * p.slot_s * p.max_speed_mps
                + (p.slot_s * p.max_speed_mps).hypot(offset)
                + offset
                + 2.0 * r;
            return Err(fail(
                t2,
                format!(
                    "landmark ({}, {}) m is out of reach in time from the landmark ({}, {}) m of \
                     slot {t1}: they lie {:.1} m apart, but in {} s at max_speed_mps = {} the \
                     sensing centre can move at most {reach:.1} m from one sensing disc to the \
                     other",
                    g2[0],
                    g2[1],
                    g1[0],
                    g1[1],
                    distance(&Point2::from(g1), &Point2::from(g2)),
                    (t2 - t1) as f64 * p.slot_s,
                    p.max_speed_mps
                ),
            ));
        }
    }
    Ok(())
}

/// The reference point of slot t: it glides along the polyline of landmark positions, reaching
/// each landmark in the middle of its window and the midpoint between two landmarks at their
/// switch; in slots without a landmark it is the next landmark (or the last one).
fn reference_m(mission: &Mission, t: usize) -> Option<(Point2<f64>, Option<Point2<f64>>)> {
    let sched = mission.schedule();
    let n = mission.slots();
    let idx = |t: usize| {
        sched
            .slot_landmark
            .get(t.wrapping_sub(1))
            .copied()
            .flatten()
    };
    match idx(t) {
        Some(k) => {
            let g = Point2::from(sched.landmarks[k].pos_m());
            // window extent in slots
            let mut a = t;
            while a > 1 && idx(a - 1) == Some(k) {
                a -= 1;
            }
            let mut z = t;
            while z < n && idx(z + 1) == Some(k) {
                z += 1;
            }
            let len = (z - a + 1) as f64;
            let f = (t - a) as f64 / len + 0.5 / len; // fraction of the window at slot centre
            let prev = (a > 1).then(|| idx(a - 1)).flatten();
            let next = (z < n).then(|| idx(z + 1)).flatten();
            // towards the neighbouring landmark by `share` of the way
            let towards =
                |j: usize, share: f64| g + (Point2::from(sched.landmarks[j].pos_m()) - g) * share;
            let r = if f < 0.5 {
                prev.map_or(g, |j| towards(j, 0.5 - f))
            } else {
                next.map_or(g, |j| towards(j, f - 0.5))
            };
            Some((r, Some(g)))
        }
        None => {
            let upcoming = (t + 1..=n).find_map(|s| mission.target_m(s));
            let past = (1..t).rev().find_map(|s| mission.target_m(s));
            upcoming.or(past).map(|g| (Point2::from(g), None))
        }
    }
}

/// A start trajectory from a guidance law: each slot picks the heading and speed that keep the
/// sensing centre near the slot's landmark (well inside the sensing radius when possible), hold
/// the UAV at distance H tan η from the gliding reference point, and prefer efficient speeds.
/// It is usually feasible; the planner repairs it (phase I) when it is not.
pub fn guidance_start(mission: &Mission, resolution: ResolutionMode) -> Trajectory {
    guidance_start_with(mission, resolution, Dynamics::Paper)
}

/// [`guidance_start`] for a vehicle model: under [`Dynamics::Vehicle`] each slot's velocity is
/// the guidance law's choice moved into the disc of radius a_max δ around the previous one (of
/// radius a_max δ/2 around the mission's start velocity for the first slot,
/// [`crate::evaluate::accel_window_s`]), so the start meets the acceleration limit in every slot.
pub fn guidance_start_with(
    mission: &Mission,
    resolution: ResolutionMode,
    dynamics: Dynamics,
) -> Trajectory {
    let p = mission.params();
    let max_change_in = |t: usize| {
        p.max_accel_mps2 * crate::evaluate::accel_window_s(p, t) * (1.0 - 2.0 * ACCEL_MARGIN_REL)
    };
    let mut velocity = Vector2::from(mission.start_velocity_mps());
    let limit = |t: usize, q: Point2<f64>, qn: Point2<f64>, velocity: &mut Vector2<f64>| {
        if dynamics == Dynamics::Paper {
            return qn;
        }
        let max_change = max_change_in(t);
        let wanted = (qn - q) / p.slot_s;
        let change = wanted - *velocity;
        let norm = change.norm();
        *velocity = if norm > max_change {
            *velocity + change * (max_change / norm)
        } else {
            wanted
        };
        q + *velocity * p.slot_s
    };
    let model = PowerModel::new(p);
    let delta = p.slot_s;
    let offset = p.centre_offset_m();
    let radius = p.sensing_radius_m;
    let v_lo = (p.min_speed_mps() * 1.02 + 1e-3).min(p.max_speed_mps);
    let v_hi = p.max_speed_mps * 0.98;
    let (v_star, p_star) = model.min_power_in(v_lo, v_hi.max(v_lo));
    let mut speeds: Vec<f64> = (0..=10)
        .map(|i| v_lo + (v_hi - v_lo).max(0.0) * i as f64 / 10.0)
        .collect();
    speeds.push(v_star);
    let headings: Vec<Vector2<f64>> = (0..360)
        .map(|i| heading_unit(i as f64 * std::f64::consts::TAU / 360.0))
        .collect();
    let mut q = Point2::from(p.start_m);
    let mut pos = Vec::with_capacity(mission.slots());
    for t in 1..=mission.slots() {
        let Some((reference, landmark)) = reference_m(mission, t) else {
            // no landmark at all: cruise east at the least-power speed
            q = limit(t, q, q + Vector2::x() * (delta * v_star), &mut velocity);
            pos.push(q.into());
            continue;
        };
        // While sensing, the radius to the reference only has to stay in a comfortable band
        // (the heading can always swing the centre onto the landmark); the least-power speed is
        // preferred. While approaching, the radius error is what matters.
        let band = if landmark.is_some() {
            0.25 * radius
        } else {
            0.0
        };
        let power_weight = if landmark.is_some() { 20.0 } else { 0.5 };
        let mut best = (f64::INFINITY, q);
        for &v in &speeds {
            let power_pen = power_weight * (model.power_w(v) - p_star);
            for &e in &headings {
                let qn = q + e * (delta * v);
                let radial = ((distance(&qn, &reference) - offset).abs() - band).max(0.0);
                let mut cost = radial * radial + power_pen;
                if let Some(g) = landmark {
                    let c = qn + RIGHT_TURN * e * offset;
                    let err2 = (c - g).norm_squared();
                    let over = (err2.sqrt() - 0.6 * radius).max(0.0);
                    // the least error any heading could give from the new position: being at
                    // the right distance from the landmark matters more than this step's error
                    let reach = ((distance(&qn, &g) - offset).abs() - 0.5 * radius).max(0.0);
                    cost += 1e3 * over * over + 1e4 * reach * reach + 1e-2 * err2;
                    if resolution == ResolutionMode::General {
                        let cell = ResolutionCell::new(p, qn.into(), (e * v).into(), g.into());
                        let excess = (cell.worst_width_m.min(1e4) - 0.9 * p.d_min_m).max(0.0);
                        cost += 1e3 * excess * excess;
                    }
                }
                if cost < best.0 {
                    best = (cost, qn);
                }
            }
        }
        q = limit(t, q, best.1, &mut velocity);
        pos.push(q.into());
    }
    Trajectory {
        slot_s: delta,
        start_m: p.start_m,
        pos_m: pos,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::sensing_centre_m;
    use crate::landmarks::{LandmarkWindow, LandmarksSpec, Preset};
    use crate::{evaluate, Params};

    /// The guidance start flies within the speed limits and meets the azimuth speed in every
    /// landmark slot (the phase-I repair relies on it), and keeps most landmarks in view.
    #[test]
    fn guidance_start_respects_speeds() {
        for (preset, s) in [
            (Preset::Default, 30.0),
            (Preset::Default, 200.0),
            (Preset::Square, 100.0),
        ] {
            let m = Mission::preset(preset, s).unwrap();
            let tr = guidance_start(&m, ResolutionMode::Paper);
            let e = evaluate(&m, &tr);
            assert_eq!(e.violations.min_speed_mps, 0.0, "{preset:?} {s}");
            assert_eq!(e.violations.max_speed_mps, 0.0, "{preset:?} {s}");
            assert!(
                e.slots_out_of_view < m.slots() / 2,
                "{preset:?} {s}: {} slots out of view",
                e.slots_out_of_view
            );
        }
    }

    #[test]
    fn unreachable_landmark_names_slot() {
        let p = Params::default();
        let spec = LandmarksSpec {
            points: Some(vec![LandmarkWindow {
                x_m: 50_000.0,
                y_m: 0.0,
                from_s: 0.0,
                to_s: 10.0,
            }]),
            ..Default::default()
        };
        let m = Mission::new("far", p, &spec).unwrap();
        let e = precheck(&m).unwrap_err();
        assert_eq!(e.slot, 1);
        assert!(e.reason.contains("out of reach"), "{e}");
    }

    #[test]
    fn azimuth_above_max_speed_is_infeasible() {
        let mut p = Params::default();
        p.max_speed_mps = 5.0;
        let m = Mission::new(
            "slow",
            p,
            &LandmarksSpec {
                preset: Some(Preset::Default),
                ..Default::default()
            },
        )
        .unwrap();
        let e = precheck(&m).unwrap_err();
        assert!(e.reason.contains("azimuth"), "{e}");
    }

    #[test]
    fn jump_between_landmarks_too_far() {
        let p = Params::default();
        let spec = LandmarksSpec {
            points: Some(vec![
                LandmarkWindow {
                    x_m: 0.0,
                    y_m: 0.0,
                    from_s: 0.0,
                    to_s: 10.0,
                },
                LandmarkWindow {
                    x_m: 10_000.0,
                    y_m: 0.0,
                    from_s: 10.0,
                    to_s: 20.0,
                },
            ]),
            ..Default::default()
        };
        let m = Mission::new("jump", p, &spec).unwrap();
        let e = precheck(&m).unwrap_err();
        assert_eq!(e.slot, 21);
    }

    /// A path from the start whose step t has length `f` V_m δ and heading `a` (rad).
    fn flown(p: &Params, steps: &[(f64, f64)]) -> Trajectory {
        let v_step = p.max_speed_mps * p.slot_s;
        let mut q = p.start_m;
        let pos_m = steps
            .iter()
            .map(|(f, a)| {
                q = [q[0] + f * v_step * a.cos(), q[1] + f * v_step * a.sin()];
                q
            })
            .collect();
        Trajectory {
            slot_s: p.slot_s,
            start_m: p.start_m,
            pos_m,
        }
    }

    /// A point at `radius` × r_s and `angle` from the sensing centre of slot t, and the centre.
    fn in_view(
        p: &Params,
        traj: &Trajectory,
        t: usize,
        angle: f64,
        radius: f64,
    ) -> ([f64; 2], [f64; 2]) {
        let heading = traj.headings_rad()[t - 1];
        let c = sensing_centre_m(traj.q(t), heading, p.centre_offset_m());
        let r = radius * p.sensing_radius_m;
        ([c[0] + r * angle.cos(), c[1] + r * angle.sin()], c)
    }

    proptest::proptest! {
        /// The reach bound is a necessary condition: wherever a trajectory within the speed
        /// limit has a point in view at the end of slot t, the bound allows slot t (or earlier).
        #[test]
        fn earliest_in_view_slot_never_rules_out_a_reachable_slot(
            steps in proptest::collection::vec((0.0f64..1.0, -3.2f64..3.2), 1..30),
            pick in 0.0f64..1.0,
            angle in -3.2f64..3.2,
            radius in 0.0f64..1.0,
        ) {
            let p = Params::default();
            let traj = flown(&p, &steps);
            let t = 1 + ((pick * steps.len() as f64) as usize).min(steps.len() - 1);
            let (g, centre) = in_view(&p, &traj, t, angle, radius);
            proptest::prop_assert!(
                distance(&Point2::from(g), &Point2::from(centre)) <= p.sensing_radius_m + 1e-9
            );
            let earliest = earliest_in_view_slot(&p, g, 1, t);
            proptest::prop_assert!(earliest.is_some_and(|e| e <= t), "slot {t}: {earliest:?}");
        }
    }

    proptest::proptest! {
        /// The bound between landmarks is a necessary condition: any two points in view of a
        /// trajectory within the speed limit, at the ends of slots t1 < t2, pass it.
        #[test]
        fn reachable_between_never_rules_out_a_flown_pair(
            steps in proptest::collection::vec((0.0f64..1.0, -3.2f64..3.2), 2..30),
            picks in (0.0f64..1.0, 0.0f64..1.0),
            angles in (-3.2f64..3.2, -3.2f64..3.2),
            radii in (0.0f64..1.0, 0.0f64..1.0),
        ) {
            let p = Params::default();
            let traj = flown(&p, &steps);
            let n = steps.len();
            let t1 = 1 + ((picks.0 * (n - 1) as f64) as usize).min(n - 2);
            let t2 = t1 + 1 + ((picks.1 * (n - t1) as f64) as usize).min(n - t1 - 1);
            let (g1, _) = in_view(&p, &traj, t1, angles.0, radii.0);
            let (g2, _) = in_view(&p, &traj, t2, angles.1, radii.1);
            proptest::prop_assert!(reachable_between(&p, g1, g2, t2 - t1), "{t1} -> {t2}");
        }
    }

    /// The bound is attained: at the first slot the UAV heads −y with its centre between it and
    /// g1 (r from g1), then flies +x at V_m, and the last step turns so that the centre lands on
    /// the x axis, r before g2; a landmark 1 m beyond that fails.
    #[test]
    fn reachable_between_is_tight() {
        let p = Params::default();
        let offset = p.centre_offset_m();
        let v_step = p.max_speed_mps * p.slot_s;
        let r = p.sensing_radius_m;
        for slots in [1usize, 2, 7] {
            let reach = 2.0 * r + offset + v_step.hypot(offset) + v_step * (slots - 1) as f64;
            let g1 = [0.0, 0.0];
            assert!(reachable_between(&p, g1, [reach - 0.05, 0.0], slots));
            assert!(!reachable_between(&p, g1, [reach + 1.0, 0.0], slots));
            // realised: UAV at distance offset + r from g1 (heading −y, centre between them)
            let q1 = [r + offset, 0.0];
            let q_before = [q1[0] + v_step * (slots - 1) as f64, 0.0];
            // last step of length v_step at heading φ puts the centre at q_before +
            // v_step (cos φ, sin φ) + offset (sin φ, −cos φ); choose φ with its y = 0
            let phi = (offset / v_step).atan();
            let c = [
                q_before[0] + v_step * phi.cos() + offset * phi.sin(),
                q_before[1] + v_step * phi.sin() - offset * phi.cos(),
            ];
            assert!(c[1].abs() < 1e-9);
            let g2 = [c[0] + r, 0.0];
            assert!((g2[0] - reach).abs() < 1e-6, "{} vs {reach}", g2[0]);
        }
    }

    #[test]
    fn earliest_in_view_slot_is_tight_for_the_next_slot() {
        let p = Params::default();
        let v_step = p.max_speed_mps * p.slot_s;
        let hop = v_step.hypot(p.centre_offset_m());
        let d = hop + p.sensing_radius_m;
        let at = |d: f64| [p.start_m[0] + d, p.start_m[1]];
        // just within reach of the next slot's centre, and just beyond it
        assert_eq!(earliest_in_view_slot(&p, at(d - 0.01), 1, 10), Some(1));
        assert_eq!(earliest_in_view_slot(&p, at(d + 0.01), 1, 10), Some(2));
        assert_eq!(
            earliest_in_view_slot(&p, at(d + 1.5 * v_step), 1, 10),
            Some(3)
        );
        assert_eq!(
            earliest_in_view_slot(&p, at(d + 20.0 * v_step), 1, 10),
            None
        );
        // too close: the centre lies H tan(eta) from the UAV
        assert_eq!(earliest_in_view_slot(&p, p.start_m, 1, 10), None);
        assert_eq!(earliest_in_view_slot(&p, at(d - 0.01), 4, 10), Some(4));
    }
}
