//! A lower bound on the energy of every trajectory that meets a mission's constraints, and the
//! infeasibility certificates that come with it.
//!
//! Every feasible trajectory (within the tolerances of [`crate::evaluate`]) flies each slot t at a
//! slot-average speed V_t = ‖q_t − q_{t−1}‖/δ in a range [lo_t, hi_t] that the constraints imply:
//! - lo_t = V_min (the azimuth requirement, at the lowest altitude allowed) in a landmark slot,
//!   0 elsewhere;
//! - hi_t = V_m, and under [`Dynamics::Vehicle`] also ‖v₀‖ + a_max δ (t − ½): the vehicle model
//!   changes the velocity by at most a_max δ/2 from the instantaneous start velocity v₀ into the
//!   first slot's average and by a_max δ from slot to slot after it.
//!
//! It also covers distance: at a landmark slot the UAV lies within R = r_s + H tan η of the
//! landmark (its sensing centre within r_s, the centre H tan η from it; at the highest altitude
//! allowed), and at t = 0 at the start. Between two such anchors (t_i, c_i, R_i) and
//! (t_j, c_j, R_j) it flies at least d_ij = (‖c_i − c_j‖ − R_i − R_j)⁺, so
//! Σ_{t_i < t ≤ t_j} V_t δ ≥ d_ij.
//!
//! The energy Σ_t δ P(V_t) of the slots between two anchors is then at least the value of
//! min Σ δ P̆(V_t) s.t. lo_t ≤ V_t ≤ hi_t, Σ V_t δ ≥ d_ij, with P̆ ≤ P the lower convex envelope of
//! the power curve (P itself is concave near hover). By weak duality, for every λ ≥ 0 this is at
//! least Σ_t δ min_{[lo_t, hi_t]} (P̆(V) − λV) + λ d_ij; the bound takes the best λ (a
//! golden-section search on this concave function of λ; any λ is valid). The slots of a
//! partition of 1..T into such intervals add up: the bound is the best partition (dynamic
//! programming over the anchors), and at λ = 0 it is the per-slot floor Σ_t δ min P̆ over
//! [lo_t, hi_t]. Climbing only adds energy ([`PowerModel::power_3d_w`]).
//!
//! When a range is empty (lo_t > hi_t) or an interval is longer than Σ hi_t δ, no trajectory
//! meets the constraints: [`energy_bound`] returns that as an [`Infeasibility`] naming the slot.
//!
//! Derivation and tests: docs/paper-notes.md, "A lower bound on the energy".

use serde::{Deserialize, Serialize};

use crate::altitude::{bounds_m, params_at};
use crate::evaluate::{Dynamics, ACCEL_TOL_REL, FEASIBILITY_TOL};
use crate::geometry::{distance, Point2};
use crate::init::Infeasibility;
use crate::power::PowerModel;
use crate::Mission;

/// Samples of the power curve over [0, V_m] for its convex envelope: the envelope of the samples
/// lies above P by at most h² max P''/8 between them (h = V_m / this; about 1e-5 W at the
/// defaults), which [`ENVELOPE_MARGIN_W`] covers.
const ENVELOPE_SAMPLES: usize = 20_000;

/// Subtracted from the sampled envelope so that it stays below P between its samples, W.
const ENVELOPE_MARGIN_W: f64 = 1e-3;

/// The farthest back the dynamic programme looks for an anchor that starts an interval (the
/// start anchor is always tried); fewer candidates only loosen the bound.
const LOOKBACK_ANCHORS: usize = 24;

/// A lower bound on the true energy of every trajectory that meets the mission's constraints
/// (sensing, the speed limits and the azimuth requirement, the acceleration limit under
/// [`Dynamics::Vehicle`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EnergyBound {
    /// The bound, J.
    pub energy_j: f64,
    /// Its per-slot part, Σ_t δ min P over slot t's admissible speeds, J (the bound without the
    /// distances between anchors).
    pub slot_floor_j: f64,
}

impl EnergyBound {
    /// How far `energy_j` lies above the bound, J.
    pub fn gap_j(&self, energy_j: f64) -> f64 {
        energy_j - self.energy_j
    }

    /// [`EnergyBound::gap_j`] relative to `energy_j`, %: the plan is at most this much above the
    /// least energy any feasible trajectory can have.
    pub fn gap_pct(&self, energy_j: f64) -> f64 {
        100.0 * self.gap_j(energy_j) / energy_j
    }
}

/// The lower convex envelope of P over [0, top], sampled, less [`ENVELOPE_MARGIN_W`].
struct Envelope {
    /// Breakpoints (speed m/s, power W), speeds increasing.
    points: Vec<(f64, f64)>,
    /// The slope of each segment (between breakpoints i and i + 1), W s/m, increasing.
    slopes: Vec<f64>,
}

impl Envelope {
    fn new(model: &PowerModel, top_mps: f64) -> Self {
        let mut points: Vec<(f64, f64)> = Vec::with_capacity(64);
        for i in 0..=ENVELOPE_SAMPLES {
            let v = top_mps * i as f64 / ENVELOPE_SAMPLES as f64;
            let p = (v, model.power_w(v) - ENVELOPE_MARGIN_W);
            // monotone chain: drop points that would make the chain non-convex
            while points.len() >= 2 {
                let (a, b) = (points[points.len() - 2], points[points.len() - 1]);
                let cross = (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0);
                if cross <= 0.0 {
                    points.pop();
                } else {
                    break;
                }
            }
            points.push(p);
        }
        let slopes = points
            .windows(2)
            .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
            .collect();
        Self { points, slopes }
    }

    /// The envelope at `v` (clamped to its domain).
    fn at(&self, v: f64) -> f64 {
        let pts = &self.points;
        let i = pts.partition_point(|p| p.0 <= v);
        if i == 0 {
            return pts[0].1;
        }
        if i >= pts.len() {
            return pts[pts.len() - 1].1;
        }
        let (a, b) = (pts[i - 1], pts[i]);
        a.1 + (b.1 - a.1) * (v - a.0) / (b.0 - a.0)
    }

    /// min over [lo, hi] of envelope(V) − λV: the envelope is convex, so the minimiser is the
    /// breakpoint where the slope passes λ, clamped to [lo, hi].
    fn min_tilted(&self, lambda: f64, lo: f64, hi: f64) -> f64 {
        // the first segment whose slope exceeds λ: its left end minimises envelope − λV
        let k = self.slopes.partition_point(|s| *s <= lambda);
        let v = self.points[k].0.clamp(lo, hi);
        self.at(v) - lambda * v
    }
}

/// The admissible slot-average speed range of every slot and the anchors of a mission.
struct Ranges {
    /// (lo, hi) per slot, m/s (index t − 1).
    speed_mps: Vec<(f64, f64)>,
    /// (slot, point, radius m): the start (slot 0, radius 0) and the first and last slot of every
    /// run of one landmark.
    anchors: Vec<(usize, [f64; 2], f64)>,
}

impl Ranges {
    fn new(mission: &Mission, dynamics: Dynamics) -> Self {
        let p = mission.params();
        let (lowest_m, highest_m) = bounds_m(p);
        let low = params_at(p, lowest_m - FEASIBILITY_TOL);
        let high = params_at(p, highest_m + FEASIBILITY_TOL);
        let v_min = low.min_speed_mps() - FEASIBILITY_TOL;
        let radius = high.sensing_radius_m + high.centre_offset_m() + FEASIBILITY_TOL;
        let v0 = mission.start_velocity_mps();
        let speed0 = v0[0].hypot(v0[1]);
        let a_max = p.max_accel_mps2 * (1.0 + ACCEL_TOL_REL);
        let n = mission.slots();
        let speed_mps = (1..=n)
            .map(|t| {
                let mut hi = p.max_speed_mps + FEASIBILITY_TOL;
                if dynamics == Dynamics::Vehicle {
                    // slot t's average velocity is that of its middle
                    hi = hi.min(speed0 + a_max * crate::evaluate::start_to_slot_middle_s(p, t));
                }
                let lo = if mission.target_m(t).is_some() {
                    v_min.max(0.0)
                } else {
                    0.0
                };
                (lo, hi)
            })
            .collect();
        let mut anchors = vec![(0, p.start_m, 0.0)];
        for t in 1..=n {
            let Some(g) = mission.target_m(t) else {
                continue;
            };
            let first = t == 1 || mission.target_m(t - 1) != Some(g);
            let last = t == n || mission.target_m(t + 1) != Some(g);
            if first || last {
                anchors.push((t, g, radius));
            }
        }
        Self { speed_mps, anchors }
    }
}

/// A lower bound on the energy of every trajectory of `mission` that meets its constraints under
/// `dynamics` (see the module documentation), or the proof that none does.
pub fn energy_bound(mission: &Mission, dynamics: Dynamics) -> Result<EnergyBound, Infeasibility> {
    let p = mission.params();
    let delta = p.slot_s;
    let ranges = Ranges::new(mission, dynamics);
    let top = ranges
        .speed_mps
        .iter()
        .map(|r| r.1)
        .fold(0.0f64, f64::max)
        .max(1e-6);
    let env = Envelope::new(&PowerModel::new(p), top);
    for (i, &(lo, hi)) in ranges.speed_mps.iter().enumerate() {
        if lo > hi {
            let t = i + 1;
            return Err(Infeasibility {
                slot: t,
                t_s: t as f64 * delta,
                reason: format!(
                    "the azimuth requirement needs at least {lo:.3} m/s in this landmark slot, \
                     but the UAV can fly at most {hi:.3} m/s there (max_speed_mps, and under \
                     vehicle dynamics the speed reachable from start_velocity_mps at \
                     max_accel_mps2)"
                ),
            });
        }
    }
    // per-slot floors and their prefix sums
    let floors: Vec<f64> = ranges
        .speed_mps
        .iter()
        .map(|&(lo, hi)| delta * env.min_tilted(0.0, lo, hi))
        .collect();
    let mut prefix = vec![0.0; floors.len() + 1];
    for (i, f) in floors.iter().enumerate() {
        prefix[i + 1] = prefix[i] + f;
    }
    let floor_between = |a: usize, b: usize| prefix[b] - prefix[a];
    let anchors = &ranges.anchors;
    let mut best = vec![0.0; anchors.len()];
    for j in 1..anchors.len() {
        let (tj, cj, rj) = anchors[j];
        let mut value = best[j - 1] + floor_between(anchors[j - 1].0, tj);
        let from = j.saturating_sub(LOOKBACK_ANCHORS).max(1);
        for i in std::iter::once(0).chain(from..j) {
            let (ti, ci, ri) = anchors[i];
            let d = distance(&Point2::from(ci), &Point2::from(cj)) - ri - rj;
            if d <= 0.0 || ti >= tj {
                continue;
            }
            let slots = &ranges.speed_mps[ti..tj];
            let reach = slots.iter().map(|r| r.1 * delta).sum::<f64>();
            if reach < d {
                return Err(Infeasibility {
                    slot: tj,
                    t_s: tj as f64 * delta,
                    reason: format!(
                        "landmark ({:.1}, {:.1}) m cannot be in view: the UAV must fly at least \
                         {d:.1} m from {} by then, but the speed limits{} allow at most \
                         {reach:.1} m",
                        cj[0],
                        cj[1],
                        if ti == 0 {
                            "the start".to_string()
                        } else {
                            format!("the landmark ({:.1}, {:.1}) m of slot {ti}", ci[0], ci[1])
                        },
                        if dynamics == Dynamics::Vehicle {
                            " and the acceleration limit from the start velocity"
                        } else {
                            ""
                        }
                    ),
                });
            }
            value = value.max(best[i] + interval_bound(&env, slots, delta, d));
        }
        best[j] = value;
    }
    let last = anchors.last().map_or(0, |a| a.0);
    let energy_j = best[anchors.len() - 1] + floor_between(last, floors.len());
    Ok(EnergyBound {
        energy_j,
        slot_floor_j: prefix[floors.len()],
    })
}

/// The dual bound of one interval: max over λ ≥ 0 of Σ δ min (P̆ − λV) + λ d.
fn interval_bound(env: &Envelope, slots: &[(f64, f64)], delta: f64, d: f64) -> f64 {
    // distinct ranges with their counts (the ranges differ only in the first slots and between
    // landmark and free slots)
    let mut classes: Vec<((f64, f64), f64)> = Vec::new();
    for &r in slots {
        match classes.iter_mut().find(|(c, _)| *c == r) {
            Some((_, n)) => *n += 1.0,
            None => classes.push((r, 1.0)),
        }
    }
    let dual = |lambda: f64| {
        classes
            .iter()
            .map(|&((lo, hi), n)| n * delta * env.min_tilted(lambda, lo, hi))
            .sum::<f64>()
            + lambda * d
    };
    // the dual is concave; its maximiser is at most the envelope's steepest slope
    let steepest = env.slopes.iter().copied().fold(0.0f64, f64::max);
    let (mut a, mut b) = (0.0, steepest.max(1.0) * 2.0);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (dual(x1), dual(x2));
    for _ in 0..80 {
        if f1 < f2 {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = dual(x2);
        } else {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = dual(x1);
        }
    }
    f1.max(f2).max(dual(0.0))
}
