"""Benchmarks of the Python package against the CLI (BENCHMARKS.md, "Python package").

1. Calling overhead: the wall time of `cellsar.plan(mission)` minus the planner's own
   `solve_seconds` (measured inside the Rust call), for the default mission.
2. A sweep of 20 missions (spacings 30-200 m) through the package against 20 runs of
   `cellsar-planner plan` on the same missions, alternating the two sides for `--rounds`.

    python python/bench/overhead.py --cli target/release/cellsar-planner

Use a package and a CLI built in the same profile (pip install ./python builds release).
"""

import argparse
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
    start = time.perf_counter()
    energies = [cellsar.plan(m).summary["energy_j"] for m in missions]
    return time.perf_counter() - start, energies


def sweep_cli(cli, files, workdir):
    start = time.perf_counter()
    for k, path in enumerate(files):
        out = os.path.join(workdir, f"out{k}")
        subprocess.run([cli, "plan", path, "--out", out], check=True, capture_output=True)
    return time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", required=True, help="the cellsar-planner binary")
    parser.add_argument("--repeats", type=int, default=15, help="plans for the overhead")
    parser.add_argument("--rounds", type=int, default=3, help="alternating sweep rounds")
    parser.add_argument("--count", type=int, default=20, help="missions per sweep")
    args = parser.parse_args()

    wall, extra, lo, hi = overhead(args.repeats)
    print(f"default mission: plan() {wall * 1e3:.1f} ms wall (median of {args.repeats}); "
          f"beyond solve_seconds: median {extra * 1e3:.3f} ms ({lo * 1e3:.3f}..{hi * 1e3:.3f})")

    spacings = np.linspace(30.0, 200.0, args.count)
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
            t, _ = sweep_package(missions)
            package.append(t)
            cli.append(sweep_cli(args.cli, files, workdir))
    print(f"sweep of {args.count} missions: package {statistics.median(package):.2f} s, "
          f"CLI {statistics.median(cli):.2f} s (medians of {args.rounds} alternating rounds; "
          f"package {[round(t, 2) for t in package]}, CLI {[round(t, 2) for t in cli]})")
    print(f"load average: {os.getloadavg()}")


if __name__ == "__main__":
    main()
