//! Coarse-to-fine levels: the start solved on coarser slot grids first.

use crate::evaluate::{Dynamics, ResolutionMode};
use crate::geometry::Vector2;
use crate::init::guidance_start_with;
use crate::schemes::exact::{ExactObjective, ExactTuning};
use crate::shortfall::total_deficit_m;
use crate::socp::SocpSolver;
use crate::{Mission, Trajectory};

use super::iterate::{run_exact, Means};
use super::options::Deadline;
use super::phase_one::make_feasible;
use super::{NoObserver, PlanOptions};

/// Slot lengths of the coarse levels, finest first, s: the mission is first solved on slots of
/// about 10 s (one per landmark window of the paper's missions), that solution starts a solve on
/// slots of about 5 s, that one a solve on slots of about 2.5 s, which starts the mission's own
/// grid. (All divide the paper's 10 s landmark windows.) The 10 s level finds the shape of the
/// track (the orbit of the 30 m mission) in a few cheap iterations: the default 30 m mission
/// plans 2.3x faster with it (BENCHMARKS.md, "Planner"). The `exact` scheme starts one level
/// earlier, on 20 s slots ([`EXACT_COARSE_LEVELS_S`]).
const COARSE_LEVELS_S: [f64; 3] = [2.5, 5.0, 10.0];

/// The coarse levels of the `exact` scheme's built-in start: [`COARSE_LEVELS_S`] and a first
/// solve on slots of about 20 s. A 20 s slot senses only the landmark of its end time (the 10 s
/// level then repairs the others), but it finds the orbit of compact missions that the 10 s level
/// can miss: random-9 and random-18 of Fig. 11 plan in 0.2 s instead of 6–16 s, at the floor
/// instead of 5–6 J above it, and the staircase in 0.65 s instead of 1.3 s (BENCHMARKS.md).
/// The comparison schemes keep [`COARSE_LEVELS_S`], so that their starts do not change.
const EXACT_COARSE_LEVELS_S: [f64; 4] = [2.5, 5.0, 10.0, 20.0];

/// The coarse levels for a scheme and purpose (optimising `exact`, or anything else).
pub(super) fn coarse_levels(options: &PlanOptions, optimise: bool) -> &'static [f64] {
    if optimise && options.scheme.spec().own_rules {
        &EXACT_COARSE_LEVELS_S
    } else {
        &COARSE_LEVELS_S
    }
}

/// The factor k (n divisible by k, at least 12 coarse slots) whose slot length k δ is closest to
/// `target_s`, within a factor 1.5 of it.
pub(super) fn coarse_factor(n: usize, delta: f64, target_s: f64) -> Option<usize> {
    (2..=n / 12)
        .filter(|&k| n.is_multiple_of(k))
        .map(|k| (k, ((k as f64 * delta) / target_s).ln().abs()))
        .filter(|(_, d)| *d <= 1.5f64.ln())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k)
}

/// Solves the mission on coarser grids ([`coarse_levels`]) and interpolates the result to the
/// mission's slots. `None` when no suitable coarse grid exists or it fails (a stalled finest
/// level included: see [`LevelStart::solved`]).
pub(super) fn coarse_start(
    mission: &Mission,
    objective: ExactObjective,
    optimise: bool,
    options: &PlanOptions,
    deadline: Deadline,
) -> Option<Trajectory> {
    coarse_start_from(mission, objective, optimise, options, deadline, None, 0)
        .and_then(LevelStart::solved)
}

/// What a coarse level hands to the next finer one, interpolated to that one's slots.
pub(super) enum LevelStart {
    /// Feasible at its level (and optimised there when asked).
    Solved(Trajectory),
    /// The last accepted (least-merit) iterate of a phase I that stalled (only for `exact`):
    /// the level's windows cannot all be held over its whole slots, but the track has the right
    /// shape.
    Stalled(Trajectory),
}

impl LevelStart {
    /// The track when it is feasible at its level. The finest coarse level hands only such a
    /// track to the fine grid (a stalled one there would replace the guidance start or a given
    /// `--init` path, which the fine phase I repairs itself).
    pub(super) fn solved(self) -> Option<Trajectory> {
        match self {
            LevelStart::Solved(t) => Some(t),
            LevelStart::Stalled(_) => None,
        }
    }
}

/// [`coarse_start`] at coarse level `level`, from a given fine-grid trajectory (sampled at the
/// coarse slot ends) or else from the next coarser level (or the guidance law).
///
/// For `exact`, when the next coarser level stalled, this level is solved from both its
/// stalled track and the guidance law and keeps the cheaper result (when both stall here too,
/// the track that came from the coarser level is handed on): the stalled track is the
/// better start on Fig. 11's random realisations (19: 149 fine iterations to 7 J above the
/// floor from the guidance law, 1 iteration to the floor from the stalled 20 s track), the
/// guidance law on the square of Fig. 9 (H = 1000 m: 35 440 J against 39 380 J).
pub(super) fn coarse_start_from(
    mission: &Mission,
    objective: ExactObjective,
    optimise: bool,
    options: &PlanOptions,
    deadline: Deadline,
    warm: Option<&Trajectory>,
    level: usize,
) -> Option<LevelStart> {
    if deadline.passed() {
        return None;
    }
    let n = mission.slots();
    let delta = mission.params().slot_s;
    let target = coarse_levels(options, optimise).get(level)?;
    let factor = coarse_factor(n, delta, *target)?;
    let coarse = mission.coarsened(factor)?;
    let exact_rules = optimise && options.scheme.spec().own_rules;
    // best effort: phase I repairs all but the cell, the solve minimises its deficit too
    let best_effort =
        exact_rules && options.resolution == ResolutionMode::General && !options.strict_resolution;
    let tuning = ExactTuning {
        whole_slot_sensing: true,
        dynamics: options.dynamics,
        // the first coarse slot's velocity, placed at its middle, is interpolated from the start
        // velocity at its instant (where the finer grid's constraint puts it too)
        first_accel_window_s: Some(
            0.5 * coarse.params().slot_s + crate::evaluate::start_velocity_lead_s(mission.params()),
        ),
        resolution: if best_effort {
            ResolutionMode::Paper
        } else {
            options.resolution
        },
        ..ExactTuning::default()
    };
    let solve_tuning = if best_effort {
        ExactTuning {
            resolution: ResolutionMode::General,
            cell_slack_weight: Some(options.resolution_weight_j_per_m),
            ..tuning
        }
    } else {
        tuning
    };
    let starts: Vec<Trajectory> = match warm {
        Some(w) => vec![Trajectory {
            slot_s: coarse.params().slot_s,
            start_m: w.start_m,
            pos_m: (1..=coarse.slots()).map(|k| w.q(k * factor)).collect(),
        }],
        None => match coarse_start_from(
            &coarse,
            objective,
            optimise,
            options,
            deadline,
            None,
            level + 1,
        ) {
            Some(LevelStart::Solved(t)) => vec![t],
            Some(LevelStart::Stalled(t)) => vec![
                t,
                guidance_start_with(&coarse, options.resolution, options.dynamics),
            ],
            None => vec![guidance_start_with(
                &coarse,
                options.resolution,
                options.dynamics,
            )],
        },
    };
    let mut best: Option<(f64, Trajectory)> = None;
    let mut stalled: Option<Trajectory> = None;
    for start in starts {
        let mut solver = SocpSolver::new(options.scheme_socp());
        let feasible = make_feasible(
            &coarse,
            start,
            objective,
            &tuning,
            exact_rules,
            Means {
                solver: &mut solver,
                observer: &mut NoObserver,
                deadline,
            },
        );
        let start = match feasible {
            Ok((start, _)) => start,
            Err(f) => {
                tracing::debug!(factor, error = %f.error, "coarse level: no feasible track");
                if exact_rules && stalled.is_none() {
                    stalled = f.stalled;
                }
                continue;
            }
        };
        let tr: (f64, Trajectory) = if optimise {
            let sub_options = PlanOptions {
                init: None,
                coarse: false,
                ..options.clone()
            };
            let mut solver = SocpSolver::new(options.scheme_socp());
            let feasible_start = start.clone();
            let solved = match run_exact(
                &coarse,
                start,
                objective,
                &solve_tuning,
                &sub_options,
                Means {
                    solver: &mut solver,
                    observer: &mut NoObserver,
                    deadline,
                },
            ) {
                Ok(solved) => solved,
                Err(e) => {
                    // the level's feasible track still has the shape found so far: hand it on
                    // rather than drop every level for the guidance law (which led the 80 m
                    // and 130 m missions to optima 15 % and 33 % above their neighbours')
                    tracing::debug!(factor, error = %e, "coarse level: optimisation failed; its feasible start is handed on");
                    let ev = crate::evaluate(&coarse, &feasible_start);
                    let deficit_j = if best_effort {
                        options.resolution_weight_j_per_m * total_deficit_m(&coarse, &ev)
                    } else {
                        0.0
                    };
                    let tr = (objective.true_value(&ev) + deficit_j, feasible_start);
                    if best.as_ref().is_none_or(|(b, _)| tr.0 < *b) {
                        best = Some(tr);
                    }
                    continue;
                }
            };
            let (track, end) = solved;
            let ev = crate::evaluate(&coarse, &track);
            tracing::debug!(
                factor,
                iterations = end.records.len(),
                energy_j = ev.energy_j,
                "coarse solve"
            );
            let deficit_j = if best_effort {
                options.resolution_weight_j_per_m * total_deficit_m(&coarse, &ev)
            } else {
                0.0
            };
            (objective.true_value(&ev) + deficit_j, track)
        } else {
            // not optimised: the comparison schemes, which always have one start (two starts
            // come only after a stalled level, which needs the exact scheme's optimisation)
            (0.0, start)
        };
        if best.as_ref().is_none_or(|(b, _)| tr.0 < *b) {
            best = Some(tr);
        }
    }
    let to_fine = |tr: Trajectory| match options.dynamics {
        Dynamics::Paper => Trajectory {
            slot_s: delta,
            start_m: tr.start_m,
            pos_m: (1..=n).map(|t| tr.position_at(t as f64 * delta)).collect(),
        },
        Dynamics::Vehicle => smooth_to_fine(
            &tr,
            (
                -crate::evaluate::start_velocity_lead_s(mission.params()),
                mission.start_velocity_mps(),
            ),
            delta,
            n,
        ),
    };
    match (best, stalled) {
        (Some((_, tr)), _) => Some(LevelStart::Solved(to_fine(tr))),
        (None, Some(tr)) => Some(LevelStart::Stalled(to_fine(tr))),
        (None, None) => None,
    }
}

/// A coarse track on `n` slots of `delta` with the velocity interpolated linearly between the
/// coarse slots' middles (the start velocity `v0_mps` at its time `t0_s` ≤ 0, where it holds)
/// and the positions integrated from the start: where the coarse track changes its velocity by
/// at most a_max Δ per slot Δ (and its first slot by a_max (Δ/2 − t0) from `v0_mps`), the fine
/// track changes it by at most a_max δ per slot δ (and its first slot by a_max (δ/2 − t0)).
/// The positions depart from the coarse track by about Δ/8 of a slot's velocity change (phase I
/// repairs what that costs the sensing).
fn smooth_to_fine(
    coarse: &Trajectory,
    (t0_s, v0_mps): (f64, [f64; 2]),
    delta: f64,
    n: usize,
) -> Trajectory {
    let big = coarse.slot_s;
    let knots: Vec<(f64, Vector2<f64>)> = std::iter::once((t0_s, Vector2::from(v0_mps)))
        .chain((1..=coarse.slots()).map(|k| {
            (
                (k as f64 - 0.5) * big,
                Vector2::from(coarse.velocity_mps(k)),
            )
        }))
        .collect();
    let velocity_at = |time: f64| -> Vector2<f64> {
        let i = knots.partition_point(|(tk, _)| *tk <= time);
        match (i.checked_sub(1).and_then(|j| knots.get(j)), knots.get(i)) {
            (Some(&(ta, va)), Some(&(tb, vb))) => va + (vb - va) * ((time - ta) / (tb - ta)),
            (Some(&(_, va)), None) => va,
            (None, Some(&(_, vb))) => vb,
            (None, None) => Vector2::zeros(),
        }
    };
    let mut q = Vector2::from(coarse.start_m);
    let pos_m = (1..=n)
        .map(|j| {
            q += velocity_at((j as f64 - 0.5) * delta) * delta;
            [q.x, q.y]
        })
        .collect();
    Trajectory {
        slot_s: delta,
        start_m: coarse.start_m,
        pos_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A coarse track that changes its velocity by a_max Δ per slot (and its first slot by
    /// a_max (Δ/2 + lead) from a start velocity held `lead` before the start) becomes a fine track
    /// that changes it by at most a_max δ per slot (and its first slot by a_max (δ/2 + lead)):
    /// for an instantaneous start velocity (lead 0) and a previous slot's average (lead δ/2).
    #[test]
    fn smooth_interpolation_keeps_the_acceleration_limit() {
        let (a, big, delta, k) = (5.0, 2.5, 0.5, 5usize);
        for lead in [0.0, 0.5 * delta] {
            let v0 = Vector2::new(10.0, 0.0);
            let mut v = v0 + Vector2::new(0.0, a * (0.5 * big + lead));
            let mut q = Vector2::new(0.0, 0.0);
            let mut pos_m = Vec::new();
            for i in 0..8 {
                q += v * big;
                pos_m.push([q.x, q.y]);
                let turn = if i % 2 == 0 { 1.0 } else { -1.0 };
                v += Vector2::new(turn * a * big * 0.6, -a * big * 0.8);
            }
            let coarse = Trajectory {
                slot_s: big,
                start_m: [0.0, 0.0],
                pos_m,
            };
            let fine = smooth_to_fine(&coarse, (-lead, [v0.x, v0.y]), delta, 8 * k);
            let mut prev = v0;
            let mut first = 0.0;
            for t in 1..=fine.slots() {
                let vt = Vector2::from(fine.velocity_mps(t));
                let window = if t == 1 { 0.5 * delta + lead } else { delta };
                assert!(
                    (vt - prev).norm() <= a * window * (1.0 + 1e-9),
                    "lead {lead}: slot {t}"
                );
                if t == 1 {
                    first = (vt - prev).norm() / window;
                }
                prev = vt;
            }
            // the first slot uses the room it has (not a trivially small change)
            assert!(first > 0.5 * a, "lead {lead}: {first}");
        }
    }
}
