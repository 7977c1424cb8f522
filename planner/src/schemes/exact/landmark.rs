//! The rows of a landmark slot of the `exact` subproblem: the speed floor along the previous
//! heading, the sensing cone around the linearised centre with its error budget, the range
//! keep-out and the resolution cell (at the slot's altitude when it is free).

use crate::geometry::{Length, Matrix2, Point2, Vector2, RIGHT_TURN};
use crate::socp::{Lin, ProblemBuilder};
use crate::Mission;

use super::altitude::{error_coefficients, shift_rows, AltitudeVars};
use super::cell::{resolution_cell_constraints, ResolutionSlot};
use super::{
    ExactTuning, SlotLin, SlotVars, CENTRE_CURVATURE_BOUND, KEEP_CAP_OF_LIMIT, SENSING_MARGIN_M,
    SPEED_MARGIN_MPS,
};

/// One landmark slot, as the subproblem sees it.
pub(super) struct LandmarkSlot {
    pub(super) sv: SlotVars,
    pub(super) lin: SlotLin,
    /// Previous position q_t^(ℓ).
    pub(super) q0: Point2<f64>,
    pub(super) landmark_m: [f64; 2],
    /// The centre-error budget e_t.
    pub(super) e: usize,
    /// Free altitude: the slot's altitude variables and previous altitude H_t^(ℓ).
    pub(super) alt: Option<(AltitudeVars, f64)>,
}

/// The rows of landmark slot `ls` with step `(vx, vy)` (see the module documentation).
pub(super) fn landmark_rows(
    b: &mut ProblemBuilder,
    mission: &Mission,
    tuning: &ExactTuning,
    ls: LandmarkSlot,
    (vx, vy): (&Lin, &Lin),
) {
    let p = mission.params();
    let delta = p.slot_s;
    let offset = p.centre_offset_m();
    let radius = p.sensing_radius_m - SENSING_MARGIN_M;
    let v_min = p.min_speed_mps() + SPEED_MARGIN_MPS;
    let v_max = p.max_speed_mps - SPEED_MARGIN_MPS;
    let keepout = p.range_keepout_m();
    let LandmarkSlot {
        sv,
        lin: l,
        q0,
        landmark_m: g,
        e,
        alt,
    } = ls;
    let (vx, vy) = (vx.clone(), vy.clone());
    // speed floor along the previous heading, ĥ·v ≥ s_t: keeps every velocity of the
    // segment [u_t, v_t] at least s_t long (the centre-error bound needs it) and carries
    // the azimuth requirement ‖v‖ ≥ δ V_min conservatively. In elastic mode the azimuth
    // part may be violated (slack σ_t); the bound's part stays hard.
    let u_norm = l.step_m.length();
    let h = l.dir;
    let along = vx.clone().scaled(h.x).plus_lin(&vy.clone().scaled(h.y));
    let keep = (tuning.speed_keep_fraction * u_norm).min(KEEP_CAP_OF_LIMIT * delta * v_max);
    // free altitude: the floor of the error bound at the lowest altitude's V_min, and
    // ĥ·v ≥ δ V_min(H_t) (linear in H_t) on top
    let floor_v_min = match alt {
        None => v_min,
        Some(_) => {
            let lowest = crate::altitude::bounds_m(p).0;
            p.min_speed_mps() * lowest / p.altitude_m + SPEED_MARGIN_MPS
        }
    };
    let v_min_at = |av: AltitudeVars| {
        Lin::var(av.h, -delta * p.min_speed_mps() / p.altitude_m)
            .plus_const(-delta * SPEED_MARGIN_MPS)
    };
    let s_min = match sv.sigma {
        None => (delta * floor_v_min).max(keep),
        Some(sig) => {
            let floor = match alt {
                None => Lin::constant_only(-delta * v_min),
                Some((av, _)) => v_min_at(av),
            };
            b.nonneg(along.clone().plus(sig, delta).plus_lin(&floor));
            keep.max(delta * floor_v_min).min(u_norm).max(1e-3)
        }
    };
    if let (Some((av, _)), None) = (alt, sv.sigma) {
        b.nonneg(along.clone().plus_lin(&v_min_at(av)));
    }
    b.nonneg(along.plus_const(-s_min));

    // the centre and radius at H_t: offset D^(ℓ) in the heading term, H_t tan η in the
    // constant one; radius r_s H_t / H
    let tan = p.observation_angle_rad.tan();
    let slot_offset = alt.map_or(offset, |(_, z0)| z0 * tan);
    let (mut cx, mut cy) = linear_centre(sv, (&vx, &vy), h, u_norm, slot_offset);
    let mut head = Lin::var(e, -1.0).plus_const(radius);
    if let Some((av, z0)) = alt {
        let jh = RIGHT_TURN * h;
        cx = cx.plus(av.h, tan * jh.x).plus_const(-tan * jh.x * z0);
        cy = cy.plus(av.h, tan * jh.y).plus_const(-tan * jh.y * z0);
        head = Lin::var(e, -1.0)
            .plus(av.h, p.sensing_radius_m / p.altitude_m)
            .plus_const(-SENSING_MARGIN_M);
    }
    if let Some(sig) = sv.sigma {
        head = head.plus(sig, 1.0);
    }
    if tuning.whole_slot_sensing {
        // the centre at the start of the slot: c̃ − v (same heading, one step back)
        b.soc(
            head.clone(),
            &[
                cx.clone().minus_lin(&vx).plus_const(-g[0]),
                cy.clone().minus_lin(&vy).plus_const(-g[1]),
            ],
        );
    }
    b.soc(
        head,
        &[cx.clone().plus_const(-g[0]), cy.clone().plus_const(-g[1])],
    );
    // κ‖v − u‖² ≤ e (free altitude: A‖v − u‖² + B (H_t − H_t^(ℓ))² ≤ e)
    let kappa = tuning.kappa_scale * slot_offset * CENTRE_CURVATURE_BOUND / (s_min * s_min);
    error_budget(b, tuning, (e, kappa, s_min), alt, p, (&vx, &vy), l.step_m);
    // range requirement (only when it is not vacuous): the true centre stays outside
    // the keep-out disc around the BS; linearised along the previous centre's direction.
    if let Some(rk) = keepout {
        let bs = Point2::from(p.bs_m);
        let nrm = (l.centre_m - bs).direction().unwrap_or_else(Vector2::x);
        let mut expr = cx
            .scaled(nrm.x)
            .plus_lin(&cy.scaled(nrm.y))
            .plus_const(-nrm.dot(&bs.coords) - rk - SENSING_MARGIN_M)
            .plus(e, -1.0);
        if let Some(sig) = sv.sigma {
            expr = expr.plus(sig, 1.0);
        }
        b.nonneg(expr);
    }
    if sv.shift.is_some() || sv.rho.is_some() {
        let at_z;
        let ps = match alt {
            Some((_, z0)) if z0 != p.altitude_m => {
                at_z = crate::altitude::params_at(p, z0);
                &at_z
            }
            _ => p,
        };
        let altitude_shift =
            alt.and_then(|(av, z0)| av.cell_shift.inspect(|&m| shift_rows(b, m, av.h, z0)));
        resolution_cell_constraints(
            b,
            ps,
            altitude_shift,
            ResolutionSlot {
                q0,
                step0: l.step_m,
                landmark: Point2::from(g),
                x: sv.x,
                y: sv.y,
                shift: sv.shift,
                sigma: sv.sigma,
                rho: sv.rho,
            },
            &vx,
            &vy,
        );
    }
    if let Some(sig) = sv.sigma {
        b.nonneg(Lin::var(sig, 1.0));
    }
}

/// The centre-error budget of a landmark slot: κ‖v − u‖² ≤ e at a fixed altitude,
/// A‖v − u‖² + B (H_t − H_t^(ℓ))² ≤ e with a free one ([`error_coefficients`]), and the trust
/// region on the same step when one is set.
fn error_budget(
    b: &mut ProblemBuilder,
    tuning: &ExactTuning,
    (e, kappa, s_min): (usize, f64, f64),
    alt: Option<(AltitudeVars, f64)>,
    p: &crate::Params,
    (vx, vy): (&Lin, &Lin),
    step_m: Vector2<f64>,
) {
    let dvx = vx.clone().plus_const(-step_m.x);
    let dvy = vy.clone().plus_const(-step_m.y);
    match alt {
        None => {
            b.rotated_soc(
                Lin::var(e, 1.0 / kappa),
                Lin::constant_only(1.0),
                &[dvx.clone(), dvy.clone()],
            );
            if let Some(tr) = tuning.trust_radius_m {
                b.soc(Lin::constant_only(tr), &[dvx, dvy]);
            }
        }
        Some((av, z0)) => {
            let (ca, cb) = error_coefficients(p, kappa, s_min);
            let dz = Lin::var(av.h, 1.0).plus_const(-z0);
            b.rotated_soc(
                Lin::var(e, 1.0),
                Lin::constant_only(1.0),
                &[
                    dvx.clone().scaled(ca.sqrt()),
                    dvy.clone().scaled(ca.sqrt()),
                    dz.clone().scaled(cb.sqrt()),
                ],
            );
            if let Some(tr) = tuning.trust_radius_m {
                b.soc(Lin::constant_only(tr), &[dvx, dvy, dz]);
            }
        }
    }
}

/// The first-order expansion of the sensing centre of a slot with variables `sv` and step
/// `(vx, vy)` around a previous step of length `u_norm` and heading `h`:
/// c̃ = q_t + D J ĥ + (D/‖u‖) J P v, P = I − ĥĥᵀ (D = `offset`).
fn linear_centre(
    sv: SlotVars,
    (vx, vy): (&Lin, &Lin),
    h: Vector2<f64>,
    u_norm: f64,
    offset: f64,
) -> (Lin, Lin) {
    let scale = if u_norm > 0.0 { offset / u_norm } else { 0.0 };
    let pm = Matrix2::identity() - h * h.transpose();
    // J P v = ((P v)_y, −(P v)_x)
    let pvx = vx
        .clone()
        .scaled(pm[(0, 0)])
        .plus_lin(&vy.clone().scaled(pm[(0, 1)]));
    let pvy = vx
        .clone()
        .scaled(pm[(1, 0)])
        .plus_lin(&vy.clone().scaled(pm[(1, 1)]));
    let jh = RIGHT_TURN * h;
    let cx = Lin::var(sv.x, 1.0)
        .plus_const(offset * jh.x)
        .plus_lin(&pvy.clone().scaled(scale));
    let cy = Lin::var(sv.y, 1.0)
        .plus_const(offset * jh.y)
        .plus_lin(&pvx.clone().scaled(-scale));
    (cx, cy)
}
