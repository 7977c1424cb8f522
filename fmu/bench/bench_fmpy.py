"""Benchmarks of the CellsarPlanner FMU through fmpy (see fmu/BENCHMARKS.md).

    cargo run --release -p fmu --bin package-fmu
    python3 fmu/bench/bench_fmpy.py [--fmu-dir target/fmu] [--repeat 3]

1. a 300 s co-simulation of the default mission at 0.5 s steps with fmpy.simulate_fmu
   (total wall time) against the planning time alone (the FMU's plan_solve_time_s);
2. the cost of one doStep without re-planning (plus reading the 13 outputs);
3. the time of a receding-horizon re-plan (a landmark moved mid-window), which must fit in
   one 0.5 s communication step.
"""

import argparse
import os
import pathlib
import platform
import statistics
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "python-tests"))

parser = argparse.ArgumentParser()
parser.add_argument("--fmu-dir", default=None)
parser.add_argument("--repeat", type=int, default=3)
args = parser.parse_args()
if args.fmu_dir:
    os.environ["CELLSAR_FMU_DIR"] = str(pathlib.Path(args.fmu_dir).resolve())

import conftest  # noqa: E402
from conftest import Fmu, OUTPUTS, fmu_path  # noqa: E402
from fmpy import simulate_fmu  # noqa: E402


def cpu():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


print(f"# machine: {cpu()}, {os.cpu_count()} cores, Python {platform.python_version()}")
print()
print("## 1. 300 s co-simulation of the default mission, 0.5 s steps (fmpy.simulate_fmu)")
print("| FMI | total [s] | planning alone [s] | total - planning [s] |")
print("|---|---|---|---|")
for version in ["fmi2", "fmi3"]:
    totals, plans = [], []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        res = simulate_fmu(str(fmu_path(version)), stop_time=300.0, output_interval=0.5,
                           output=OUTPUTS + ["plan_solve_time_s"])
        totals.append(time.perf_counter() - t0)
        plans.append(float(res["plan_solve_time_s"][-1]))
    t, p = statistics.median(totals), statistics.median(plans)
    print(f"| {version[-1]}.0 | {t:.3f} | {p:.3f} | {t - p:.3f} |")

print()
print("## 2. one doStep without re-planning (default mission, 600 steps of 0.5 s)")
print("| FMI | doStep [us] | doStep + 13 outputs [us] |")
print("|---|---|---|")
for version in ["fmi2", "fmi3"]:
    f = Fmu(version, name="bench")
    f.instantiate()
    f.init(stop=300.0)
    state = f.fmu.getFMUstate() if version == "fmi2" else f.fmu.getFMUState()
    do = f.fmu.fmi2DoStep if version == "fmi2" else f.fmu.fmi3DoStep
    comp = f.fmu.component
    step_only, with_outputs = [], []
    for rep in range(args.repeat):
        f.fmu.setFMUstate(state) if version == "fmi2" else f.fmu.setFMUState(state)
        if version == "fmi2":
            t0 = time.perf_counter()
            for k in range(600):
                do(comp, k * 0.5, 0.5, 1)
            step_only.append((time.perf_counter() - t0) / 600)
        else:
            import ctypes
            b = ctypes.c_bool()
            d = ctypes.c_double()
            t0 = time.perf_counter()
            for k in range(600):
                do(comp, k * 0.5, 0.5, True, ctypes.byref(b), ctypes.byref(b), ctypes.byref(b),
                   ctypes.byref(d))
            step_only.append((time.perf_counter() - t0) / 600)
        f.fmu.setFMUstate(state) if version == "fmi2" else f.fmu.setFMUState(state)
        t0 = time.perf_counter()
        for k in range(600):
            f.step(0.5, t=k * 0.5)
            f.outputs()
        with_outputs.append((time.perf_counter() - t0) / 600)
    print(f"| {version[-1]}.0 | {statistics.median(step_only) * 1e6:.1f} | "
          f"{statistics.median(with_outputs) * 1e6:.1f} |")
    f.unload()

print()
print("## 3. receding-horizon re-plan (landmark moved by (40, 20) m mid-window)")
print("| FMI | move at t [s] | slots re-planned | doStep wall [s] | solve [s] | fits in 0.5 s |")
print("|---|---|---|---|---|---|")
for version in ["fmi2", "fmi3"]:
    for t_move in [5.0, 65.0, 125.0, 185.0, 245.0, 295.0]:
        f = Fmu(version, name="bench")
        f.instantiate()
        f.init(stop=300.0)
        k = 0
        while k * 0.5 < t_move - 1e-9:
            f.step(0.5, t=k * 0.5)
            k += 1
        x, y = f.get("landmark_x_m"), f.get("landmark_y_m")
        f.set(landmark_x_in_m=x + 40.0, landmark_y_in_m=y + 20.0)
        t0 = time.perf_counter()
        f.step(0.5, t=t_move)
        wall = time.perf_counter() - t0
        solve = f.get("plan_solve_time_s")
        assert f.get("replan_count") == 1
        slots = int(round((300.0 - t_move) / 0.5))
        print(f"| {version[-1]}.0 | {t_move:.0f} | {slots} | {wall:.3f} | {solve:.3f} | "
              f"{'yes' if wall < 0.5 else 'NO'} |")
        f.unload()
