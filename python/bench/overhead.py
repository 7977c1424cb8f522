"""Benchmarks of the Python package against the CLI (BENCHMARKS.md, "Python package").

1. Calling overhead: the wall time of `cellsar.plan(mission)` minus the planner's own
   `solve_seconds` (measured inside the Rust call), for the default mission.
2. A sweep of 20 missions (spacings 30-200 m) through the package against 20 runs of
   `cellsar-planner plan` on the same missions, alternating the two sides for `--rounds`.

    python python/bench/overhead.py --cli target/release/cellsar-planner

Use a package and a CLI built in the same profile (pip install ./python builds release).
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time

import numpy as np

import cellsar


def overhead(repeats):
    mission = cellsar.Mission.default(30.0)
    cellsar.plan(mission)  # warm up
    extra, walls = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        plan = cellsar.plan(mission)
        wall = time.perf_counter() - start
        walls.append(wall)
        extra.append(wall - plan.summary["solve_seconds"])
    return statistics.median(walls), statistics.median(extra), min(extra), max(extra)


def sweep_package(missions):
    """Wall time of the sweep, and the planner's own time (sum of solve_seconds)."""
    start = time.perf_counter()
    solve = sum(cellsar.plan(m).summary["solve_seconds"] for m in missions)
    return time.perf_counter() - start, solve


def sweep_cli(cli, files, workdir):
    """Wall time of the sweep, and the planner's own time (sum of solve_seconds)."""
    start = time.perf_counter()
    outs = []
    for k, path in enumerate(files):
        out = os.path.join(workdir, f"out{k}")
        # the package's default resolution (the CLI's default for `exact` is `general`)
        subprocess.run([cli, "plan", path, "--resolution", "paper", "--out", out], check=True,
                       capture_output=True)
        outs.append(out)
    wall = time.perf_counter() - start
    solve = 0.0
    for out in outs:
        with open(os.path.join(out, "summary.json")) as f:
            solve += json.load(f)["solve_seconds"]
    return wall, solve


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", required=True, help="the cellsar-planner binary")
    parser.add_argument("--repeats", type=int, default=15, help="plans for the overhead")
    parser.add_argument("--rounds", type=int, default=3, help="alternating sweep rounds")
    parser.add_argument("--count", type=int, default=20, help="missions per sweep")
    parser.add_argument("--max-spacing-m", type=float, default=200.0, help="largest spacing")
    args = parser.parse_args()

    wall, extra, lo, hi = overhead(args.repeats)
    print(f"default mission: plan() {wall * 1e3:.1f} ms wall (median of {args.repeats}); "
          f"beyond solve_seconds: median {extra * 1e3:.3f} ms ({lo * 1e3:.3f}..{hi * 1e3:.3f})")

    spacings = np.linspace(30.0, args.max_spacing_m, args.count)
    missions = [cellsar.Mission.default(float(s)) for s in spacings]
    with tempfile.TemporaryDirectory() as workdir:
        files = []
        for k, m in enumerate(missions):
            path = os.path.join(workdir, f"m{k}.toml")
            with open(path, "w") as f:
                f.write(m.to_toml())
            files.append(path)
        package, cli = [], []
        for _ in range(args.rounds):
            package.append(sweep_package(missions))
            cli.append(sweep_cli(args.cli, files, workdir))
    for name, runs in [("package", package), ("CLI", cli)]:
        walls = [w for w, _ in runs]
        beyond = [w - s for w, s in runs]
        print(f"sweep of {args.count} missions, {name}: wall {statistics.median(walls):.2f} s, "
              f"beyond the planner's own time {statistics.median(beyond):.3f} s "
              f"(medians of {args.rounds} alternating rounds; walls {[round(w, 2) for w in walls]})")
    print(f"load average: {os.getloadavg()}")


if __name__ == "__main__":
    main()
