//! Plans the paper's default mission with a chosen scheme and prints the headline numbers.
use planner::{plan, Mission, PlanOptions, Preset, Scheme};

fn main() -> anyhow::Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    let args: Vec<String> = std::env::args().collect();
    let scheme = args
        .get(1)
        .and_then(|s| Scheme::from_name(s))
        .unwrap_or(Scheme::Exact);
    let spacing: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(30.0);
    let m = Mission::preset(Preset::Default, spacing)?;
    let opts = PlanOptions {
        scheme,
        ..Default::default()
    };
    let r = plan(&m, &opts)?;
    println!(
        "{scheme} s={spacing}: true energy {:.1} J (start {:.1}), own objective {:.1}, iterations {}, {:?}, {:.3} s, feasible {}, viol {:?}",
        r.evaluation.energy_j, r.start_energy_j, r.objective, r.iterations, r.termination, r.solve_seconds,
        r.evaluation.is_feasible(), r.evaluation.violations
    );
    println!(
        "history: {:?}",
        r.objective_history
            .iter()
            .map(|v| format!("{v:.1}"))
            .collect::<Vec<_>>()
    );
    for rec in r.records.iter().take(5) {
        println!(
            "it {} ipm {} {:.1} ms",
            rec.iteration,
            rec.ipm_iterations,
            rec.seconds * 1e3
        );
    }
    let dir = std::path::PathBuf::from(format!("/tmp/quick-{scheme}-{spacing}"));
    planner::report::write_plan_dir(&dir, &m, &r)?;
    let start = planner::init::guidance_start(&m);
    let sr = planner::PlanResult {
        trajectory: start.clone(),
        evaluation: planner::evaluate(&m, &start),
        ..r.clone()
    };
    planner::report::write_plan_dir(&dir.join("start"), &m, &sr)?;
    Ok(())
}
