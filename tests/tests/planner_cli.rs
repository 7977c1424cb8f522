#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]
//! The `cellsar-planner` binary end to end: files written, exit codes, messages.

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(harness::bin("cellsar-planner"))
}

fn repo() -> PathBuf {
    harness::root()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cellsar-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn plan_writes_the_plan_directory() {
    let out = tmp("plan");
    let o = bin()
        .args(["plan"])
        .arg(repo().join("missions/explicit.toml"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "trajectory.csv",
        "summary.json",
        "mission.toml",
        "trajectory.svg",
        "energy.svg",
        "convergence.svg",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "t_s",
        "x_m",
        "y_m",
        "speed_mps",
        "heading_rad",
        "xc_m",
        "yc_m",
        "landmark_x_m",
        "landmark_y_m",
        "power_w",
        "energy_j",
    ] {
        assert!(header.split(',').any(|c| c == col), "column {col}");
    }
    assert_eq!(csv.lines().count(), 1 + 1 + 120); // header, start, 120 slots
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for key in [
        "scheme",
        "energy_j",
        "objective_j",
        "iterations",
        "converged",
        "solve_seconds",
        "objective_history",
        "max_sensing_violation_m",
        "min_speed_mps",
        "max_speed_mps",
    ] {
        assert!(summary.get(key).is_some(), "summary lacks {key}");
    }
    assert_eq!(summary["scheme"], "exact");
    assert_eq!(summary["feasible"], true);
    // the default of `exact` is the general resolution (the best effort, with its shortfall)
    assert_eq!(summary["resolution"], "general");
    assert!(summary["resolution_shortfall"].is_object(), "{summary}");
    // the library's default plans the same (one plan for one request, whichever door)
    let m = planner::Mission::from_path(&repo().join("missions/explicit.toml")).unwrap();
    let lib = planner::plan(&m, &planner::PlanOptions::default()).unwrap();
    let lib_j = lib.evaluation.energy_j;
    let cli_j = summary["energy_j"].as_f64().unwrap();
    assert!((lib_j - cli_j).abs() <= 1e-9 * cli_j, "{lib_j} vs {cli_j}");
    // stdout names the termination as summary.json does, and says what the best effort's own
    // objective adds to the energy
    let stdout = String::from_utf8_lossy(&o.stdout);
    let reason = summary["termination"]["reason"].as_str().unwrap();
    assert!(
        stdout.contains(&format!("iterations ({reason})")),
        "{stdout}"
    );
    assert!(
        stdout.contains("J (energy model + 100 J/m × resolution deficit)"),
        "{stdout}"
    );
    // blind (ψ < 5°) and unbounded cells are counted under names that say which
    let shortfall = &summary["resolution_shortfall"];
    assert!(
        shortfall.get("infinite_width_slots").is_some(),
        "{shortfall}"
    );
    assert!(shortfall.get("blind_slots").is_none(), "{shortfall}");
    assert!(summary["slots_blind"].is_u64(), "{summary}");
    // the plan directory reads back, and its trajectory re-plans as --init
    let (m, tr) = pipeline::report::read_plan_dir(&out).unwrap();
    assert_eq!(tr.slots(), m.slots());
    let out2 = tmp("plan-init");
    let o = bin()
        .args(["plan"])
        .arg(out.join("mission.toml"))
        .args(["--scheme", "paper", "--max-iterations", "2", "--init"])
        .arg(out.join("trajectory.csv"))
        .arg("--out")
        .arg(&out2)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // the comparison schemes keep the paper's resolution by default
    let summary2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out2.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary2["resolution"], "paper");
}

#[test]
fn bad_parameter_exits_2_and_names_the_field() {
    let d = tmp("bad");
    let f = d.join("m.toml");
    std::fs::write(
        &f,
        "[params]\nd_min_m = -5\n[landmarks]\npreset = \"default\"\n",
    )
    .unwrap();
    let o = bin()
        .arg("plan")
        .arg(&f)
        .arg("--out")
        .arg(d.join("o"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("d_min_m"));

    std::fs::write(
        &f,
        "[params]\nbandwith_hz = 1\n[landmarks]\npreset = \"default\"\n",
    )
    .unwrap();
    let o = bin()
        .arg("plan")
        .arg(&f)
        .arg("--out")
        .arg(d.join("o"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bandwith_hz"));

    let o = bin()
        .arg("plan")
        .arg(d.join("missing.toml"))
        .arg("--out")
        .arg(d.join("o"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.toml"));
}

#[test]
fn infeasible_mission_exits_3_and_names_the_slot() {
    let d = tmp("infeasible");
    let f = d.join("m.toml");
    std::fs::write(
        &f,
        "[params]\nhorizon_s = 30\n[landmarks]\npoints = [{ x_m = 0, y_m = 0, from_s = 0, to_s = 10 }, { x_m = 9000, y_m = 0, from_s = 10, to_s = 30 }]\n",
    )
    .unwrap();
    let o = bin()
        .arg("plan")
        .arg(&f)
        .arg("--out")
        .arg(d.join("o"))
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("slot 21"), "{err}");
}

#[test]
fn best_effort_flags_with_the_paper_resolution_exit_2_and_name_the_flag() {
    let out = tmp("paper-cap");
    // the paper's resolution asked for, and a comparison scheme's default
    for paper in [["--resolution", "paper"], ["--scheme", "baseline"]] {
        let o = bin()
            .arg("plan")
            .arg(repo().join("missions/explicit.toml"))
            .args(paper)
            .args(["--max-extra-energy-pct", "5", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{paper:?}: {err}");
        assert!(
            err.contains("--max-extra-energy-pct applies to --resolution general only"),
            "{paper:?}: {err}"
        );
        assert!(!out.join("summary.json").exists());
    }
    // the general resolution asked for with a comparison scheme, which ignores the best effort:
    // the library's rule (planner::PlanOptions::check_best_effort), in the flags' names
    let o = bin()
        .arg("plan")
        .arg(repo().join("missions/explicit.toml"))
        .args(["--scheme", "baseline-exact", "--resolution", "general"])
        .args(["--strict-resolution", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--strict-resolution applies to --scheme exact only, not to baseline-exact"),
        "{err}"
    );
    assert!(!out.join("summary.json").exists());
}

#[test]
fn bad_init_csv_exits_2_and_names_the_line() {
    let d = tmp("badinit");
    let init = d.join("init.csv");
    std::fs::write(&init, "t_s,x_m,y_m\n0.5,1,zz\n").unwrap();
    let o = bin()
        .arg("plan")
        .arg(repo().join("missions/explicit.toml"))
        .arg("--init")
        .arg(&init)
        .arg("--out")
        .arg(d.join("o"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("line 2, column y_m"));
}

#[test]
fn out_that_is_a_file_exits_2_before_planning() {
    let d = tmp("outfile");
    let file = d.join("afile");
    std::fs::write(&file, "x").unwrap();
    let o = bin()
        .arg("plan")
        .arg(repo().join("missions/explicit.toml"))
        .arg("--out")
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("is not a directory"));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
}

#[test]
fn bad_time_limit_exits_2_and_names_the_option() {
    let out = tmp("timelimit");
    for (value, needle) in [("0", "time_limit_s"), ("nan", "time_limit_s")] {
        let o = bin()
            .arg("plan")
            .arg(repo().join("missions/explicit.toml"))
            .args(["--time-limit-s", value, "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{value}: {err}");
        assert!(err.contains(needle), "{value}: {err}");
        assert!(!out.join("summary.json").exists());
    }
    // a tolerance that is not a number > 0 is named the same way
    let o = bin()
        .arg("plan")
        .arg(repo().join("missions/explicit.toml"))
        .args(["--tolerance=-1", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("tolerance"));
}

#[test]
fn dmin_prints_the_three_values() {
    let o = bin()
        .args([
            "dmin",
            "--radius-m",
            "5000",
            "--objects",
            "1000",
            "--trials",
            "300",
        ])
        .output()
        .unwrap();
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains("correct formula") && s.contains("as printed") && s.contains("Monte Carlo"));
    // N where the as-printed quadrature cannot converge: reported, not a hang or a failure
    let o = bin()
        .args([
            "dmin",
            "--radius-m",
            "5000",
            "--objects",
            "100000",
            "--trials",
            "1",
        ])
        .output()
        .unwrap();
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains("not computed") && s.contains("1 trial"), "{s}");
    let o = bin()
        .args(["dmin", "--radius-m=-1", "--objects", "10"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("radius_m"));
}

#[test]
fn reproduce_writes_figures_and_report() {
    let out = tmp("repro");
    let o = bin()
        .args(["reproduce", "--quick", "--only", "4a,4c,t3", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "REPORT.md",
        "fig4a/dmin.svg",
        "fig4a/dmin.csv",
        "fig4c/power.svg",
        "table3/table3.csv",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(report.contains("| 50 | 3.81 |"), "{report}");
    let o = bin()
        .args(["reproduce", "--only", "99", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn every_example_mission_loads() {
    for e in std::fs::read_dir(repo().join("missions")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml" || x == "json") {
            planner::Mission::from_path(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        }
    }
}

/// A plan's trajectory.csv carries its altitude (`z_m`): evaluating it as a track of a mission
/// at another altitude is refused (exit 2, naming the column and the mission's altitude_m)
/// rather than flying the track at the wrong height; at the plan's own altitude it evaluates.
#[test]
fn a_trajectory_made_for_another_altitude_exits_2() {
    let d = tmp("altitude");
    let mission = repo().join("missions/explicit.toml");
    let o = bin()
        .arg("plan")
        .arg(&mission)
        .arg("--out")
        .arg(d.join("plan"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let trajectory = d.join("plan/trajectory.csv");
    let evaluate = |mission: &std::path::Path| {
        bin()
            .arg("evaluate")
            .arg(mission)
            .arg("--trajectory")
            .arg(&trajectory)
            .output()
            .unwrap()
    };
    let o = evaluate(&mission);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let higher = d.join("higher.toml");
    let text = std::fs::read_to_string(&mission).unwrap();
    std::fs::write(
        &higher,
        text.replacen("[params]\n", "[params]\naltitude_m = 1200.0\n", 1),
    )
    .unwrap();
    let o = evaluate(&higher);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("column z_m") && stderr.contains("altitude_m = 1200 m"),
        "{stderr}"
    );
}
