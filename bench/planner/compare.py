#!/usr/bin/env python3
"""Rust planner vs a CVXPY + Clarabel implementation of the same exact scheme, in one run.

For each mission (every `plan` with `--resolution paper`, the problem the CVXPY side solves):
  1. `cellsar-planner plan M --no-coarse --plain-sca --max-iterations 0 --out D0` writes a
     feasible start (D0/trajectory.csv) and the resolved mission (D0/mission.toml);
  2. `cellsar-planner plan M --no-coarse --plain-sca --init D0/trajectory.csv --out D1` runs the
     plain SCA from it (D1/summary.json: iterations, solve_seconds, energy_j, objective_history);
  3. `cvxpy_exact.py --mission D0/mission.toml --init D0/trajectory.csv` runs the same SCA in
     CVXPY (modes `rebuild`: a new problem each iteration; `dpp`: one parametrised problem);
  4. `cellsar-planner plan M` (the full default pipeline: coarse start + over-relaxation).
Checks that the first iteration's subproblem objective agrees (same convex program, same start:
relative difference <= 1e-5) and prints the time per iteration, the totals and the speed-ups.

Run with the Python of a venv that has cvxpy, clarabel and numpy:
  python3 -m venv /tmp/venv-cvx && /tmp/venv-cvx/bin/pip install cvxpy clarabel numpy
  /tmp/venv-cvx/bin/python bench/planner/compare.py
Exit status: 0 when every check passed, 1 when a check failed, 2 on a setup error.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
FIRST_OBJECTIVE_RTOL = 1e-5


def sh(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.stderr.write(r.stdout + r.stderr)
        raise SystemExit(f"command failed ({r.returncode}): {' '.join(map(str, cmd))}")
    return r


def rust_plan(binary: Path, mission: Path, out: Path, *extra: str) -> dict:
    # the paper's resolution: the problem the CVXPY side implements (the CLI's default for
    # `exact` is the best effort under the general resolution)
    sh([str(binary), "plan", str(mission), "--resolution", "paper", "--out", str(out), *extra])
    return json.loads((out / "summary.json").read_text())


def main() -> int:
    ap = argparse.ArgumentParser(description="Rust planner vs CVXPY + Clarabel (same exact scheme)")
    ap.add_argument(
        "--missions",
        nargs="+",
        type=Path,
        default=[ROOT / "missions/default-30m.toml", ROOT / "missions/default-200m.toml"],
    )
    ap.add_argument(
        "--cvxpy-runs",
        default="rebuild:mirror,dpp:mirror,rebuild:scaled",
        help="CVXPY runs as MODE:FORMULATION (modes rebuild, dpp; formulations mirror = the Rust "
        "cone program, scaled = the same program in better units, the reference optimum)",
    )
    ap.add_argument("--repeat", type=int, default=3, help="runs of each Rust command (median taken)")
    ap.add_argument("--out", type=Path, default=ROOT / "target/pbench-compare")
    ap.add_argument("--skip-build", action="store_true")
    ap.add_argument("--max-iterations", type=int, default=200)
    args = ap.parse_args()

    if not args.skip_build:
        print("building: cargo build --release -p pipeline --bin cellsar-planner", flush=True)
        sh(["cargo", "build", "--release", "-p", "pipeline", "--bin", "cellsar-planner"], cwd=ROOT)
    binary = ROOT / "target/release/cellsar-planner"
    if not binary.exists():
        raise SystemExit(f"{binary} is missing (build it or drop --skip-build)")
    py_env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    runs = [tuple(r.split(":")) for r in args.cvxpy_runs.split(",") if r]

    machine = {
        "cpus": os.cpu_count(),
        "load_avg_at_start": os.getloadavg(),
        "python": platform.python_version(),
        "binary": str(binary),
    }
    try:
        import cvxpy, clarabel  # noqa: F401

        machine["cvxpy"] = cvxpy.__version__
        machine["clarabel_py"] = clarabel.__version__
    except ImportError as e:
        raise SystemExit(f"run this script with a Python that has cvxpy and clarabel: {e}")

    results = []
    ok_all = True
    for mission in args.missions:
        name = mission.stem
        base = args.out / name
        d0 = base / "D0"
        print(f"\n== {name}: feasible start", flush=True)
        s0 = rust_plan(binary, mission, d0, "--no-coarse", "--plain-sca", "--max-iterations", "0")
        extra = ["--no-coarse", "--plain-sca", "--init", str(d0 / "trajectory.csv"),
                 "--max-iterations", str(args.max_iterations)]
        rust_runs = []
        print(f"   rust plain SCA (run 1/{args.repeat})", flush=True)
        rust_runs.append(rust_plan(binary, mission, base / "D1", *extra))
        cv = {}
        for mode, formulation in runs:
            label = f"{mode}, {formulation}"
            print(f"   cvxpy ({label})", flush=True)
            out_json = base / f"cvxpy-{mode}-{formulation}.json"
            sh(
                [sys.executable, str(HERE / "cvxpy_exact.py"), "--mission", str(d0 / "mission.toml"),
                 "--init", str(d0 / "trajectory.csv"), "--mode", mode, "--formulation", formulation,
                 "--out", str(out_json), "--max-iterations", str(args.max_iterations)],
                env=py_env,
            )
            cv[label] = json.loads(out_json.read_text())
        for k in range(1, args.repeat):
            print(f"   rust plain SCA (run {k + 1}/{args.repeat})", flush=True)
            rust_runs.append(rust_plan(binary, mission, base / f"D1-{k}", *extra))
        full_runs = []
        for k in range(args.repeat):
            print(f"   rust full default pipeline (run {k + 1}/{args.repeat})", flush=True)
            full_runs.append(rust_plan(binary, mission, base / f"full-{k}"))

        rust = sorted(rust_runs, key=lambda s: s["solve_seconds"])[len(rust_runs) // 2]
        full = sorted(full_runs, key=lambda s: s["solve_seconds"])[len(full_runs) // 2]
        r_first = rust["objective_history"][0] if rust["objective_history"] else float("nan")
        entry = {
            "mission": name,
            "slots": rust["slots"],
            "start_energy_j": s0["energy_j"],
            "rust_plain": {
                "iterations": rust["iterations"],
                "solve_seconds": rust["solve_seconds"],
                "solve_seconds_all_runs": [s["solve_seconds"] for s in rust_runs],
                "energy_j": rust["energy_j"],
                "first_objective_j": r_first,
                "termination": rust["termination"],
                "feasible": rust["feasible"],
            },
            "rust_full": {
                "iterations": full["iterations"],
                "solve_seconds": full["solve_seconds"],
                "solve_seconds_all_runs": [s["solve_seconds"] for s in full_runs],
                "energy_j": full["energy_j"],
                "feasible": full["feasible"],
            },
            "cvxpy": {},
        }
        reference = next(
            (c["objectives"][0] for c in cv.values() if c["formulation"] == "scaled" and c["first_status"] == "optimal"),
            None,
        )
        entry["reference_first_objective_j"] = reference
        entry["rust_plain"]["first_objective_rel_diff_to_reference"] = (
            None if reference is None else abs(r_first - reference) / reference
        )
        for mode, c in cv.items():
            first = c["objectives"][0] if c["objectives"] else float("nan")
            rel = abs(first - r_first) / abs(r_first)
            passed = rel <= FIRST_OBJECTIVE_RTOL
            if c["formulation"] == "mirror":
                ok_all &= passed
            entry["cvxpy"][mode] = {
                "formulation": c["formulation"],
                "first_status": c["first_status"],
                "statuses": sorted(set(c["statuses"])),
                "iterations": c["iterations"],
                "solve_seconds": c["solve_seconds"],
                "first_iteration_seconds": c["iteration_seconds"][0],
                "median_iteration_seconds": statistics.median(c["iteration_seconds"]),
                "median_clarabel_seconds": statistics.median(c["clarabel_seconds"]),
                "ipm_iterations": c["ipm_iterations"],
                "energy_j": c["energy_j"],
                "feasible": c["feasible"],
                "termination": c["termination"],
                "first_objective_j": first,
                "first_objective_rel_diff": rel,
                "first_objective_check": ("pass" if passed else "FAIL") if c["formulation"] == "mirror" else "n/a (reference)",
                "first_objective_rel_diff_to_reference": None if reference is None else abs(first - reference) / reference,
                "energy_rel_diff_vs_rust": abs(c["energy_j"] - rust["energy_j"]) / rust["energy_j"],
            }
        results.append(entry)

    machine["load_avg_at_end"] = os.getloadavg()
    report = {"machine": machine, "results": results}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "compare.json").write_text(json.dumps(report, indent=1))

    # ---- the table
    print("\n| mission | implementation | SCA iterations | total s | s / iteration | true energy J | feasible | speed-up of Rust plain SCA (total; per iteration) |")
    print("|---|---|---|---|---|---|---|---|")
    for e in results:
        r = e["rust_plain"]
        r_it = r["solve_seconds"] / max(r["iterations"], 1)
        print(f"| {e['mission']} | Rust plain SCA | {r['iterations']} | {r['solve_seconds']:.3f} | {r_it:.4f} | {r['energy_j']:.1f} | {r['feasible']} | 1 |")
        for mode, c in e["cvxpy"].items():
            c_it = c["solve_seconds"] / max(c["iterations"], 1)
            print(
                f"| {e['mission']} | CVXPY + Clarabel ({mode}) | {c['iterations']} | {c['solve_seconds']:.3f} | {c_it:.4f} "
                f"| {c['energy_j']:.1f} | {c['feasible']} | {c['solve_seconds'] / r['solve_seconds']:.1f}x; {c_it / r_it:.1f}x |"
            )
        f = e["rust_full"]
        # the planner a user runs, against the same CVXPY runs (not the same algorithm)
        full_vs = "; ".join(
            f"{c['solve_seconds'] / f['solve_seconds']:.1f}x vs CVXPY {mode}" for mode, c in e["cvxpy"].items()
        )
        print(f"| {e['mission']} | Rust full default (coarse start + over-relaxation) | {f['iterations']} (fine grid) | {f['solve_seconds']:.3f} | | {f['energy_j']:.1f} | {f['feasible']} | {full_vs} |")
    print("\nFirst-iteration objective (the same convex program from the same start), J:")
    print("| mission | run | status of the first solve | first objective J | rel. diff to Rust | check (<= 1e-5, mirror only) | rel. diff to the reference optimum | final true energy rel. diff to Rust |")
    print("|---|---|---|---|---|---|---|---|")
    for e in results:
        ref = e["reference_first_objective_j"]
        rr = e["rust_plain"]["first_objective_rel_diff_to_reference"]
        print(f"| {e['mission']} | Rust plain SCA | (not reported) | {e['rust_plain']['first_objective_j']:.6f} | 0 | | {'' if rr is None else f'{rr:.1e}'} | 0 |")
        for mode, c in e["cvxpy"].items():
            rd = c["first_objective_rel_diff_to_reference"]
            print(
                f"| {e['mission']} | CVXPY ({mode}) | {c['first_status']} | {c['first_objective_j']:.6f} | {c['first_objective_rel_diff']:.1e} "
                f"| {c['first_objective_check']} | {'' if rd is None else f'{rd:.1e}'} | {c['energy_rel_diff_vs_rust']:.1e} |"
            )
        if ref is None:
            print(f"| {e['mission']} | (no reference: the scaled run did not reach status optimal) | | | | | | |")
    print(f"\nload average at start {machine['load_avg_at_start']}, at end {machine['load_avg_at_end']} ({machine['cpus']} CPUs)")
    print(f"wrote {args.out / 'compare.json'}")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
