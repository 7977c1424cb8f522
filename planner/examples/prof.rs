//! Times the parts of one exact-scheme iteration on the default mission.
use planner::schemes::exact::{ExactObjective, ExactSubproblem, ExactTuning};
use planner::socp::{SocpSettings, SocpSolver};
use planner::{Mission, Preset};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let m = Mission::preset(Preset::Default, 30.0)?;
    let t = Instant::now();
    let start = planner::init::guidance_start(&m);
    println!("start {:.2} ms", t.elapsed().as_secs_f64() * 1e3);
    let t = Instant::now();
    let sub = ExactSubproblem::build(&m, &start, ExactObjective::Energy, &ExactTuning::default());
    println!(
        "build {:.2} ms, vars {}, rows {}",
        t.elapsed().as_secs_f64() * 1e3,
        sub.builder.num_vars(),
        sub.builder.num_rows()
    );
    for (tol, rmax, rtol) in [
        (1e-8, 10, 1e-13),
        (1e-8, 3, 1e-10),
        (1e-7, 3, 1e-10),
        (1e-6, 2, 1e-9),
        (1e-8, 0, 1e-13),
    ] {
        let mut s = SocpSolver::new(SocpSettings {
            tol_feas: tol,
            tol_gap_rel: tol,
            refine_max_iter: rmax,
            refine_reltol: rtol,
            ..Default::default()
        });
        let t = Instant::now();
        let sol = s.solve(&sub.builder).map_err(|e| anyhow::anyhow!("{e}"))?;
        println!("tol {tol:e} refine {rmax} {rtol:e}: solve {:.2} ms ipm {} status {:?} obj {:.6} viol {:.2e}", t.elapsed().as_secs_f64() * 1e3, sol.iterations, sol.status, sub.physical_objective(sol.objective), sol.violation);
    }
    Ok(())
}
