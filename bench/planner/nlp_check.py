#!/usr/bin/env python3
"""Independent check of a planned energy: the same mission as a direct-shooting NLP (SciPy SLSQP).

`cellsar-planner plan` finds its trajectory by sequential convex programming (SCA), which can
stop in a local optimum. This script solves the mission again with nothing from the planner but
the mission itself: the controls are the heading and the speed at knots every `--knot-s`
seconds (linear between knots, sampled at the mid-point of each slot), the track is integrated
from the start, and SLSQP minimises the true energy sum_t delta P(V_t) subject to the exact
sensing constraint ||q_t + D (sin a_t, -cos a_t) - landmark_t|| <= r_s in every landmark slot and
V_min <= V_t <= V_max. Coarser knots restrict the controls, so its optimum is at or above the
planner's if both find the same basin; a markedly lower value would show that the planner
stopped in a worse local optimum.

Reads `PLAN/mission.toml` (the resolved mission that `plan` writes: parameters and landmark
windows) and `PLAN/trajectory.csv` (for `--start plan`). Only the paper's resolution model with
a vacuous range constraint is handled (the defaults); anything else is refused.

    VENV=/tmp/venv-cvx bench/planner/compare.sh --help   # creates the venv with SciPy (via CVXPY)
    cellsar-planner plan missions/default-200m.toml --resolution paper --out /tmp/p200
    /tmp/venv-cvx/bin/python bench/planner/nlp_check.py /tmp/p200 --knot-s 5 --start turn

Starts: `plan` (the planner's own trajectory, sampled at the knots), `turn` (a constant-rate
clockwise turn from the start heading allowed by landmark 1 to `--end-heading-deg` at constant
`--speed-mps`: a smooth path that spreads the turn over the whole mission).
"""
import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

# the mission file, schedule and power model of the CVXPY comparison (same venv)
from cvxpy_exact import InputError, Mission, load_mission, power_w, schedule


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("plan_dir", help="output directory of `cellsar-planner plan`")
    ap.add_argument("--knot-s", type=float, default=5.0, help="control knot spacing, s")
    ap.add_argument("--start", choices=["plan", "turn"], default="plan")
    ap.add_argument("--speed-mps", type=float, default=22.0, help="speed of the `turn` start")
    ap.add_argument("--end-heading-deg", type=float, default=10.0, help="final heading of the `turn` start")
    ap.add_argument("--max-iter", type=int, default=500)
    ap.add_argument("--restarts", type=int, default=10, help="SLSQP restarts after a failed line search or LSQ step")
    ap.add_argument("--write-init", help="write the NLP's track as a `plan --init` CSV here")
    a = ap.parse_args()

    try:
        p, points = load_mission(Path(a.plan_dir) / "mission.toml")
    except InputError as e:
        sys.exit(f"nlp_check: {e}")
    n = int(round(p["horizon_s"] / p["slot_s"]))
    lm = schedule(p, points, n)
    m = Mission(p=p, slots=n, landmark=lm, lm_idx=np.flatnonzero(~np.isnan(lm[:, 0])))
    if m.keepout is not None:
        sys.exit("nlp_check: the range-resolution constraint is not vacuous for this mission; not handled")
    offset_m, v_min, dt = m.offset, m.v_min, m.delta
    sensed = ~np.isnan(lm[:, 0])
    start = np.array(p["start_m"], dtype=float)
    rs = p["sensing_radius_m"]

    k = int(round(p["horizon_s"] / a.knot_s)) + 1
    tk = np.linspace(0.0, p["horizon_s"], k)
    ts = (np.arange(1, n + 1) - 0.5) * dt

    def track(x):
        al = np.interp(ts, tk, x[:k])
        v = np.interp(ts, tk, x[k:])
        q = start + np.cumsum(np.stack([np.cos(al), np.sin(al)], 1) * (v * dt)[:, None], 0)
        c = q + offset_m * np.stack([np.sin(al), -np.cos(al)], 1)
        return al, v, q, c

    def energy(x):
        return float(np.sum(power_w(m, track(x)[1])) * dt)

    def margin(x):
        c = track(x)[3]
        return rs**2 - np.sum((c[sensed] - lm[sensed]) ** 2, 1)

    if a.start == "plan":
        rows = list(csv.DictReader(open(f"{a.plan_dir}/trajectory.csv")))[1:]
        al0 = np.unwrap([float(r["heading_rad"]) for r in rows])
        v0 = np.array([float(r["speed_mps"]) for r in rows])
        x0 = np.concatenate([np.interp(tk, ts, al0), np.interp(tk, ts, v0)])
    else:
        # heading at slot 1 that points the centre at landmark 1 as closely as possible
        first = lm[np.argmax(sensed)] - start
        a_first = math.atan2(first[1], first[0]) + math.pi / 2
        x0 = np.concatenate([np.linspace(a_first, math.radians(a.end_heading_deg), k), np.full(k, a.speed_mps)])

    t0 = time.perf_counter()
    x, nit = x0, 0
    if margin(x).min() < 0:
        # phase I: from an infeasible start, first minimise the squared excess distance (SLSQP
        # tends to stall far outside the discs otherwise)
        def excess(y):
            e = np.minimum(margin(y), 0.0) / rs**2
            return float(np.sum(e * e))

        ph1 = minimize(
            excess, x, method="L-BFGS-B",
            bounds=[(None, None)] * k + [(v_min, p["max_speed_mps"])] * k,
            options={"maxiter": 5000},
        )
        x = ph1.x
        print(f"phase I (L-BFGS-B): worst centre distance "
              f"{float(np.sqrt(np.max(rs**2 - margin(x)))):.1f} m after {ph1.nit} iterations")
    for _ in range(a.restarts + 1):
        # SLSQP's inner least-squares solver gives up now and then far from the optimum;
        # restarting from where it stopped rebuilds its quasi-Newton matrix and goes on.
        res = minimize(
            energy, x, method="SLSQP",
            constraints=[{"type": "ineq", "fun": margin}],
            bounds=[(None, None)] * k + [(v_min, p["max_speed_mps"])] * k,
            options={"maxiter": a.max_iter, "ftol": 1e-10},
        )
        x, nit = res.x, nit + res.nit
        if res.success or res.status == 9:  # converged, or out of iterations
            break
    res.nit = nit
    secs = time.perf_counter() - t0
    al, v, q, c = track(res.x)
    worst = float(np.sqrt(np.sum((c[sensed] - lm[sensed]) ** 2, 1)).max())
    floor = p["horizon_s"] * float(np.min(power_w(m, np.linspace(v_min, p["max_speed_mps"], 20001))))
    print(f"start {a.start}: energy {energy(x0):.1f} J, worst centre distance "
          f"{float(np.sqrt(np.sum((track(x0)[3][sensed] - lm[sensed]) ** 2, 1)).max()):.1f} m")
    print(f"SLSQP ({k} knots every {a.knot_s:g} s): {res.message} after {res.nit} iterations, {secs:.1f} s")
    print(f"energy {energy(res.x):.1f} J (floor {floor:.1f} J, +{100 * (energy(res.x) / floor - 1):.1f} %), "
          f"worst centre distance {worst:.3f} m (r_s {rs:g} m), speeds {v.min():.2f}..{v.max():.2f} m/s")
    if a.write_init:
        with open(a.write_init, "w") as f:
            f.write(f"t_s,x_m,y_m\n0,{start[0]!r},{start[1]!r}\n")
            for i in range(n):
                f.write(f"{(i + 1) * dt!r},{q[i, 0]!r},{q[i, 1]!r}\n")
    return 0 if res.success or worst <= rs + 1e-3 else 1


if __name__ == "__main__":
    sys.exit(main())
