//! The energy–resolution trade-off of a mission: from the least-energy plan to the
//! best-resolved plan, the best-effort plan under a rising cap on the extra energy.
//!
//! A mission with `altitude = "free"`, with [`PlanOptions::altitude_profile`] set, gets a curve
//! of free-altitude plans (an altitude per slot in [`PlanResult::altitudes_m`]): the free
//! least-energy plan, then under each cap the better, by the best effort's merit (energy plus
//! [`PlanOptions::resolution_weight_j_per_m`] × the resolution deficit), of the free best
//! effort ([`crate::plan`]) and the fixed-altitude curve's point (the same mission at its one
//! altitude `altitude_m`, each capped plan started from the previous one), flown at
//! `altitude_m`. A free best effort measures its cap against the least-energy plan at the fixed
//! altitude (its [`crate::driver::BestEffort::least_energy_j`]; its altitude steps never add
//! energy to the fixed plan they start from), so the curve's percentages are of that plan too:
//! the first point's is at most 0 (what the free altitude saves), and every capped point meets
//! its cap.
//! Without the option a free mission is refused ([`PlanError::AltitudeConflict`]), as by
//! [`crate::plan`].

use crate::altitude::AltitudeMode;
use crate::driver::{
    best_effort_from, plan_with_observer, BestEffortBasis, NoObserver, Observer, PlanError,
    PlanOptions,
};
use crate::evaluate::{evaluate_with_altitudes, ResolutionMode};
use crate::shortfall::ResolutionShortfall;
use crate::{Mission, PlanResult};

/// The caps of the default trade-off curve, % of extra energy over the least-energy plan; the
/// curve adds the least-energy plan (0 %) before and the uncapped best effort after them.
pub const DEFAULT_CAPS_PCT: [f64; 5] = [1.0, 2.0, 5.0, 10.0, 20.0];

/// A point whose plan stays this far (% of the least energy) below its cap did not use the
/// cap: the best effort stopped on its own, and every larger cap gets the same plan (each
/// would only repeat the stopping rule's last steps from it).
pub const UNUSED_CAP_PCT: f64 = 0.5;

/// What a curve's percentages are of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EnergyBasis {
    /// The curve's first point, its least-energy plan (a mission at one altitude).
    LeastEnergy,
    /// The least-energy plan of the mission at one fixed altitude (a free-altitude curve, whose
    /// first point is the free least-energy plan, no dearer): at `altitude_m`, or at
    /// `min_altitude_m` where the mission cannot be planned at `altitude_m` and its free plans
    /// start from its plan at the lowest altitude.
    FixedAltitude {
        /// That altitude, m.
        altitude_m: f64,
    },
}

/// One point of the curve.
#[derive(Debug, Clone)]
pub struct TradeoffPoint {
    /// Its cap, % (`Some(0.0)` for the least-energy plan, `None` for the uncapped best effort).
    pub cap_pct: Option<f64>,
    /// The plan.
    pub plan: PlanResult,
    /// Its shortfall on the exact geometry.
    pub shortfall: ResolutionShortfall,
    /// Its energy above the least-energy plan's, % (of a free mission: of the least-energy
    /// plan at the fixed altitude, see the module documentation).
    pub extra_energy_pct: f64,
    /// What `extra_energy_pct` is of (the same for every point of a curve).
    pub basis: EnergyBasis,
    /// The energy of that plan, J.
    pub basis_energy_j: f64,
}

/// The title of the curve's plot for `mission_name`: its first point's plan and energy (for a
/// free-altitude curve, the free least-energy plan).
pub fn plot_title(mission_name: &str, points: &[TradeoffPoint]) -> String {
    let Some(first) = points.first() else {
        return format!("{mission_name}: resolution against energy (no plan)");
    };
    let e0 = first.plan.evaluation.energy_j;
    match first.basis {
        EnergyBasis::LeastEnergy => {
            format!("{mission_name}: resolution against energy (least-energy plan {e0:.0} J)")
        }
        // the plan the percentages are of is on the energy axis ([`energy_axis_label`]): the
        // title stays within the plot's width
        EnergyBasis::FixedAltitude { .. } => {
            format!("{mission_name}: free altitude (free least-energy plan {e0:.0} J)")
        }
    }
}

/// The label of the plot's energy axis: the extra energy over the plan the percentages are of
/// (for a free-altitude curve, the least-energy plan at the fixed altitude, with its energy).
pub fn energy_axis_label(points: &[TradeoffPoint]) -> String {
    match points.first().map(|p| p.basis) {
        Some(EnergyBasis::FixedAltitude { altitude_m }) => format!(
            "extra energy over the least-energy plan at {altitude_m:.0} m ({:.0} J) / %",
            points.first().map_or(f64::NAN, |p| p.basis_energy_j)
        ),
        _ => "extra energy over the least-energy plan / %".to_string(),
    }
}

/// The curve for `caps_pct` (ascending, each ≥ 0): the least-energy plan, the best effort
/// under each cap, and the uncapped best effort. Each capped plan starts from the previous
/// point's, which meets the larger cap, so the shortfall never rises along the curve; once a
/// cap is not reached (by [`UNUSED_CAP_PCT`]), the larger caps repeat its plan.
pub fn tradeoff(
    mission: &Mission,
    options: &PlanOptions,
    caps_pct: &[f64],
) -> Result<Vec<TradeoffPoint>, PlanError> {
    tradeoff_with_observer(mission, options, caps_pct, &mut NoObserver)
}

/// Passes a point's phases and iterations on, each phase named with the point.
struct PointObserver<'a> {
    inner: &'a mut dyn Observer,
    point: String,
}

impl Observer for PointObserver<'_> {
    fn on_iteration(&mut self, record: &crate::driver::IterationRecord) {
        self.inner.on_iteration(record);
    }
    fn on_phase(&mut self, phase: &str) {
        self.inner.on_phase(&format!("{}: {phase}", self.point));
    }
}

/// The label of point `k` (1-based) of `total` with cap `cap`.
fn label(k: usize, total: usize, cap: Option<f64>) -> String {
    format!(
        "point {k}/{total} ({})",
        cap.map_or("no cap".to_string(), |c| format!("cap {c} %"))
    )
}

/// [`tradeoff`], telling `observer` each iteration of each point's plan and each phase as
/// `"point K/N (cap C %): PHASE"` (the least-energy plan first). A mission with margins is
/// planned with them and every point judged on its own limits, as [`crate::plan`] does
/// ([`crate::margins`]).
pub fn tradeoff_with_observer(
    mission: &Mission,
    options: &PlanOptions,
    caps_pct: &[f64],
    observer: &mut dyn Observer,
) -> Result<Vec<TradeoffPoint>, PlanError> {
    if mission.params().has_margins() {
        // every point planned with the margins, judged on the mission's own limits
        let points = tradeoff_with_observer(&mission.planned(), options, caps_pct, observer)
            .map_err(|e| crate::margins::judge_error(mission, e))?;
        return Ok(points
            .into_iter()
            .map(|mut point| {
                crate::margins::judge(mission, &mut point.plan);
                point.shortfall = ResolutionShortfall::new(mission, &point.plan.evaluation);
                point
            })
            .collect());
    }
    let total = caps_pct.len() + 2;
    let options = PlanOptions {
        resolution: ResolutionMode::General,
        strict_resolution: false,
        max_extra_energy_pct: None,
        ..options.clone()
    };
    options.validate()?;
    if mission.params().altitude == AltitudeMode::Free && options.altitude_profile {
        return free_tradeoff(mission, &options, caps_pct, observer);
    }
    crate::driver::check_altitude(mission, &options)?;
    let basis = BestEffortBasis::new(
        mission,
        &options,
        &mut PointObserver {
            inner: &mut *observer,
            point: format!("point 1/{total} (least energy)"),
        },
    )?;
    let least_j = basis.least_energy_j();
    let point = |cap_pct, plan: PlanResult| TradeoffPoint {
        cap_pct,
        shortfall: ResolutionShortfall::new(mission, &plan.evaluation),
        extra_energy_pct: 100.0 * (plan.evaluation.energy_j / least_j - 1.0),
        basis: EnergyBasis::LeastEnergy,
        basis_energy_j: least_j,
        plan,
    };
    let mut points = vec![point(Some(0.0), basis.least_energy.clone())];
    let mut start = basis.least_energy.trajectory.clone();
    let caps = caps_pct.iter().copied().map(Some).chain([None]);
    let mut slack_pct = 0.0;
    for cap in caps {
        if slack_pct > UNUSED_CAP_PCT {
            // the previous cap was not reached: its plan is the best effort under this one
            if let Some(last) = points.last() {
                let mut plan = last.plan.clone();
                if let Some(info) = plan.best_effort.as_mut() {
                    info.max_extra_energy_pct = cap;
                }
                points.push(point(cap, plan));
                continue;
            }
        }
        let capped = PlanOptions {
            max_extra_energy_pct: cap,
            ..options.clone()
        };
        let mut named = PointObserver {
            inner: &mut *observer,
            point: label(points.len() + 1, total, cap),
        };
        let plan = best_effort_from(mission, &capped, &basis, Some(&start), &mut named)?;
        // the next cap starts from this plan (within the larger cap too)
        start = plan.trajectory.clone();
        let p = point(cap, plan);
        slack_pct = cap.map_or(0.0, |c| c - p.extra_energy_pct);
        points.push(p);
    }
    Ok(points)
}

/// The curve of the free-altitude mission `mission` (`options` as [`tradeoff_with_observer`]
/// set them, with the altitude profile; see the module documentation). Each cap's candidates
/// are its own free best effort (its fixed stage started from the previous point's track,
/// [`PlanOptions::init`], where that track fits the fixed altitude and the cap; the free stage
/// refines the fixed plan) and the fixed curve's point (when the mission can be flown at
/// `altitude_m`); of those that leave no larger resolution deficit than the previous point
/// the one of least merit is taken, and the previous point's plan (which meets the larger cap
/// too) when neither does: the deficit never rises along the curve, and no point is worse than
/// the fixed curve's in both energy and deficit. A cap not reached (by [`UNUSED_CAP_PCT`]) is
/// repeated as on a fixed curve.
fn free_tradeoff(
    mission: &Mission,
    options: &PlanOptions,
    caps_pct: &[f64],
    observer: &mut dyn Observer,
) -> Result<Vec<TradeoffPoint>, PlanError> {
    let total = caps_pct.len() + 2;
    let fixed_curve = at_fixed_altitude(mission).and_then(|fixed| {
        let mut named = PointObserver {
            inner: &mut *observer,
            point: "fixed altitude".into(),
        };
        tradeoff_with_observer(&fixed, options, caps_pct, &mut named)
    });
    let fixed_curve = match fixed_curve {
        Ok(points) => points,
        Err(error) => {
            tracing::info!(%error, "no fixed-altitude curve: the free plans alone");
            Vec::new()
        }
    };
    let least = plan_with_observer(
        mission,
        &PlanOptions {
            resolution: ResolutionMode::Paper,
            ..options.clone()
        },
        &mut PointObserver {
            inner: &mut *observer,
            point: format!("point 1/{total} (least energy)"),
        },
    )?;
    let merit = |plan: &PlanResult| {
        plan.evaluation.energy_j + options.resolution_weight_j_per_m * total_deficit(mission, plan)
    };
    let mut plans: Vec<(Option<f64>, PlanResult)> = vec![(Some(0.0), least)];
    // the basis of the percentages: the fixed-altitude least-energy plan that every free best
    // effort measures its cap against (at the lowest altitude where the fixed curve fails)
    let mut least_j = fixed_curve.first().map(|p| p.plan.evaluation.energy_j);
    let basis_altitude_m = if fixed_curve.is_empty() {
        crate::altitude::bounds_m(mission.params()).0
    } else {
        mission.params().altitude_m
    };
    let caps = caps_pct.iter().copied().map(Some).chain([None]);
    let mut slack_pct = 0.0;
    for (k, cap) in caps.enumerate() {
        let Some((_, previous)) = plans.last() else {
            break;
        };
        let free = if slack_pct > UNUSED_CAP_PCT {
            // the previous cap was not reached: its plan is the free best effort under this one
            with_cap(previous.clone(), cap)
        } else {
            // chained: the fixed stage's best effort starts from the previous point's track,
            // which meets this cap too (the default start where it does not fit the fixed
            // altitude)
            let capped = PlanOptions {
                max_extra_energy_pct: cap,
                init: Some(previous.trajectory.clone()),
                ..options.clone()
            };
            let mut named = PointObserver {
                inner: &mut *observer,
                point: label(plans.len() + 1, total, cap),
            };
            plan_with_observer(mission, &capped, &mut named)?
        };
        let fixed = match fixed_curve.get(k + 1) {
            Some(p) => Some(at_altitude_m(mission, p.plan.clone())?),
            None => None,
        };
        let limit = total_deficit(mission, previous) * (1.0 + 1e-9);
        let plan = match [Some(free), fixed]
            .into_iter()
            .flatten()
            .filter(|p| total_deficit(mission, p) <= limit)
            .min_by(|a, b| merit(a).total_cmp(&merit(b)))
        {
            Some(best) => best,
            None => {
                tracing::info!(
                    point = plans.len() + 1,
                    "both plans leave a larger resolution deficit than the previous point's, \
                     which meets this cap too: that plan is kept"
                );
                with_cap(previous.clone(), cap)
            }
        };
        if let Some(b) = plan.best_effort.as_ref() {
            least_j.get_or_insert(b.least_energy_j);
        }
        slack_pct = match (cap, least_j) {
            (Some(c), Some(j)) => c - 100.0 * (plan.evaluation.energy_j / j - 1.0),
            _ => 0.0,
        };
        plans.push((cap, plan));
    }
    let (basis, least_j) = match least_j {
        Some(j) => (
            EnergyBasis::FixedAltitude {
                altitude_m: basis_altitude_m,
            },
            j,
        ),
        None => (
            EnergyBasis::LeastEnergy,
            plans
                .first()
                .map_or(f64::NAN, |(_, p)| p.evaluation.energy_j),
        ),
    };
    Ok(plans
        .into_iter()
        .map(|(cap_pct, plan)| TradeoffPoint {
            cap_pct,
            shortfall: ResolutionShortfall::new(mission, &plan.evaluation),
            extra_energy_pct: 100.0 * (plan.evaluation.energy_j / least_j - 1.0),
            basis,
            basis_energy_j: least_j,
            plan,
        })
        .collect())
}

/// The free-altitude `mission` at its one altitude `altitude_m` (its bounds dropped).
fn at_fixed_altitude(mission: &Mission) -> Result<Mission, PlanError> {
    let mut p = mission.params().clone();
    p.altitude = AltitudeMode::Fixed;
    p.min_altitude_m = None;
    p.max_altitude_m = None;
    mission
        .with_params(p)
        .map_err(|e| PlanError::InvalidInit(format!("the mission at its fixed altitude: {e}")))
}

/// A plan of the mission at its fixed altitude as a plan of the free-altitude `mission`: flown
/// at `altitude_m` in every slot, evaluated so.
fn at_altitude_m(mission: &Mission, mut plan: PlanResult) -> Result<PlanResult, PlanError> {
    let z = vec![mission.params().altitude_m; mission.slots()];
    plan.evaluation = evaluate_with_altitudes(mission, &plan.trajectory, &z)
        .map_err(|e| PlanError::InvalidInit(e.to_string()))?;
    plan.altitudes_m = Some(z);
    Ok(plan)
}

/// `plan` taken for the point of cap `cap` (its best-effort record says so).
fn with_cap(mut plan: PlanResult, cap: Option<f64>) -> PlanResult {
    if let Some(info) = plan.best_effort.as_mut() {
        info.max_extra_energy_pct = cap;
    }
    plan
}

/// The resolution deficit of `plan` on the exact geometry at its altitudes, m.
fn total_deficit(mission: &Mission, plan: &PlanResult) -> f64 {
    crate::shortfall::total_deficit_m(mission, &plan.evaluation)
}
