//! The energy–resolution trade-off of a mission: from the least-energy plan to the
//! best-resolved plan, the best-effort plan under a rising cap on the extra energy.

use crate::driver::{
    best_effort_from, BestEffortBasis, NoObserver, Observer, PlanError, PlanOptions,
};
use crate::evaluate::ResolutionMode;
use crate::shortfall::ResolutionShortfall;
use crate::{Mission, PlanResult};

/// The caps of the default trade-off curve, % of extra energy over the least-energy plan; the
/// curve adds the least-energy plan (0 %) before and the uncapped best effort after them.
pub const DEFAULT_CAPS_PCT: [f64; 5] = [1.0, 2.0, 5.0, 10.0, 20.0];

/// A point whose plan stays this far (% of the least energy) below its cap did not use the
/// cap: the best effort stopped on its own, and every larger cap gets the same plan (each
/// would only repeat the stopping rule's last steps from it).
pub const UNUSED_CAP_PCT: f64 = 0.5;

/// One point of the curve.
#[derive(Debug, Clone)]
pub struct TradeoffPoint {
    /// Its cap, % (`Some(0.0)` for the least-energy plan, `None` for the uncapped best effort).
    pub cap_pct: Option<f64>,
    /// The plan.
    pub plan: PlanResult,
    /// Its shortfall on the exact geometry.
    pub shortfall: ResolutionShortfall,
    /// Its energy above the least-energy plan's, %.
    pub extra_energy_pct: f64,
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

/// [`tradeoff`], telling `observer` each iteration of each point's plan and each phase as
/// `"point K/N (cap C %): PHASE"` (the least-energy plan first).
pub fn tradeoff_with_observer(
    mission: &Mission,
    options: &PlanOptions,
    caps_pct: &[f64],
    observer: &mut dyn Observer,
) -> Result<Vec<TradeoffPoint>, PlanError> {
    let total = caps_pct.len() + 2;
    let options = PlanOptions {
        resolution: ResolutionMode::General,
        strict_resolution: false,
        max_extra_energy_pct: None,
        ..options.clone()
    };
    options.validate()?;
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
        let label = format!(
            "point {}/{total} ({})",
            points.len() + 1,
            cap.map_or("no cap".to_string(), |c| format!("cap {c} %"))
        );
        let mut named = PointObserver {
            inner: &mut *observer,
            point: label,
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
