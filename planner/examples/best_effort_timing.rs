//! Times the least-energy plan, the best-effort plan and the trade-off curve of a mission, one
//! after the other in the same run (BENCHMARKS.md, "Best-effort resolution").
//!
//! `cargo run --release -p planner --example best_effort_timing -- MISSION.toml [--tradeoff]
//! [--cap PCT] [--phases]`
//!
//! `--cap PCT` plans the best effort within PCT % more energy than the least-energy plan;
//! `--phases` prints each phase's time (and each iteration with `TRACE_ITER` set). Each plan is
//! made under the paper's dynamics and the vehicle's acceleration limit, one after the other,
//! with its peak acceleration and the slots above the limit (to 1e-6 relative) on the exact
//! geometry.

use std::path::Path;
use std::time::Instant;

use planner::evaluate::{Dynamics, ResolutionMode};
use planner::shortfall::ResolutionShortfall;
use planner::tradeoff::{tradeoff, DEFAULT_CAPS_PCT};
use planner::{plan_with_observer, IterationRecord, Mission, Observer, PlanOptions};

/// Prints each phase's wall time and iteration count (with `--phases`).
struct Phases {
    verbose: bool,
    name: String,
    since: Instant,
    iterations: usize,
}

impl Phases {
    fn close(&mut self) {
        if self.verbose && !self.name.is_empty() {
            println!(
                "  phase {:<12} {:>7.2} s, {} iterations",
                self.name,
                self.since.elapsed().as_secs_f64(),
                self.iterations
            );
        }
    }
}

impl Observer for Phases {
    fn on_phase(&mut self, phase: &str) {
        self.close();
        self.name = phase.to_string();
        self.since = Instant::now();
        self.iterations = 0;
    }
    fn on_iteration(&mut self, r: &IterationRecord) {
        self.iterations += 1;
        if std::env::var_os("TRACE_ITER").is_some() {
            println!(
                "    it {} {} obj {:.1} energy {:.1} {:.3} s",
                r.iteration, r.accepted, r.objective, r.true_energy_j, r.seconds
            );
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: best_effort_timing MISSION.toml [--tradeoff]")?;
    let mission = Mission::from_path(Path::new(path))?;
    let with_curve = args.iter().any(|a| a == "--tradeoff");
    let cap_pct = match args.iter().position(|a| a == "--cap") {
        Some(i) => Some(
            args.get(i + 1)
                .ok_or("--cap needs a percentage")?
                .parse::<f64>()
                .map_err(|e| format!("--cap: {e}"))?,
        ),
        None => None,
    };
    let mut least_s = f64::NAN;
    let runs = Dynamics::ALL
        .into_iter()
        .flat_map(|d| [(d, ResolutionMode::Paper), (d, ResolutionMode::General)]);
    for (dynamics, resolution) in runs {
        let options = PlanOptions {
            resolution,
            dynamics,
            max_extra_energy_pct: cap_pct.filter(|_| resolution == ResolutionMode::General),
            ..PlanOptions::default()
        };
        let t0 = Instant::now();
        let mut phases = Phases {
            verbose: args.iter().any(|a| a == "--phases"),
            name: "start".to_string(),
            since: Instant::now(),
            iterations: 0,
        };
        let p = plan_with_observer(&mission, &options, &mut phases)?;
        phases.close();
        let s = t0.elapsed().as_secs_f64();
        if resolution == ResolutionMode::Paper {
            least_s = s;
        }
        let sf = ResolutionShortfall::new(&mission, &p.evaluation);
        let limit = mission.params().max_accel_mps2;
        let over = p
            .evaluation
            .slots
            .iter()
            .filter(|s| s.accel_mps2 > limit * (1.0 + 1e-6))
            .count();
        println!(
            "{dynamics:?} {resolution:?}: {:.6} J, {} / {} unresolved windows / slots, excess \
             {:.0} m, peak {:.4} m/s² ({over} slots > {limit:.4}), feasible {}, {:.2} s \
             ({:.1}x least-energy), {} iterations, {} cone programs",
            p.evaluation.energy_j,
            sf.unresolved_windows,
            sf.unresolved_slots,
            sf.total_excess_width_m,
            p.evaluation.max_accel_mps2,
            p.is_feasible(),
            s,
            s / least_s,
            p.iterations,
            p.cone_programs
        );
    }
    if with_curve {
        let t0 = Instant::now();
        let points = tradeoff(&mission, &PlanOptions::default(), &DEFAULT_CAPS_PCT)?;
        let s = t0.elapsed().as_secs_f64();
        for pt in &points {
            println!(
                "cap {:?}: {:.1} J (+{:.2} %), {} / {} windows / slots, excess {:.0} m, {} iterations, {:.2} s",
                pt.cap_pct,
                pt.plan.evaluation.energy_j,
                pt.extra_energy_pct,
                pt.shortfall.unresolved_windows,
                pt.shortfall.unresolved_slots,
                pt.shortfall.total_excess_width_m,
                pt.plan.iterations,
                pt.plan.solve_seconds
            );
        }
        println!("trade-off: {} points in {s:.1} s", points.len());
    }
    Ok(())
}
