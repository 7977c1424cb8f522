#!/usr/bin/env python3
"""CVXPY + Clarabel implementation of the planner's `exact` scheme (plain SCA), for the speed and
correctness comparison of issue 2 ("Performance").

It mirrors, term by term, `planner/src/schemes/exact.rs` (`ExactSubproblem::build` with the
default `ExactTuning`, energy objective) and the plain SCA loop of `planner/src/driver.rs`
(`run_exact` with over-relaxation off and the proven centre-error bound, kappa_scale = 1: what
`cellsar-planner plan --no-coarse --plain-sca` runs):

per slot t = 1..T_w, with v_t = q_t - q_{t-1} (q_0 the fixed start) and u_t the previous step:
  variables x_t, y_t, V_t, a_t, s_t, w_t, z_t, and e_t in landmark slots;
  minimise (1/T_w) sum_t [3P0/U^2 V_t^2 + P1 a_t + c_p z_t]   (= mean power minus P0)
  s.t.  ||v_t|| <= delta V_t,  V_t <= V_m - 1e-4,
        s_t a_t >= 1,  s_t^2 <= L_t,  L_t = 2 a0 a_t - a0^2 + (2 u.v_t - ||u||^2)/(delta^2 v0^2)
        V_t^2 <= w_t,  w_t^2 <= z_t V_t,
  and in landmark slots (landmark g_t, h = u_t/||u_t||, D = H tan(eta)):
        h.v_t >= s_min = max(delta (V_min + 1e-4), 0.85 ||u_t||),
        ||c~_t - g_t|| <= r_s - 1e-3 - e_t,  c~_t = q_t + D J h + (D/||u_t||) J P v_t,
        kappa ||v_t - u_t||^2 <= e_t,  kappa = D / (sqrt(3) s_min^2),
        (+ ||v_t - u_t|| <= trust radius after a rejected step; + the linearised range keep-out
         when the bandwidth makes it non-vacuous).
A step is accepted when the new path is feasible on the exact geometry (true speed, true heading,
true sensing centre, within 1e-4) and its true energy does not increase; the loop stops when the
relative change of the true energy is below the tolerance.

The mission parameters come from the `mission.toml` that `cellsar-planner plan --out DIR` writes
(explicit landmark windows, [params] overrides of the the default parameters); the start and the per-slot
landmarks from its `trajectory.csv` (both are cross-checked against each other).

Modes: `dpp` (default) builds one parametrised CVXPY problem (DPP) and only updates parameter
values between iterations, so CVXPY compiles once and Clarabel's solver is updated in place
(CVXPY's warm_start path): the fastest way to use CVXPY for this loop. `rebuild` constructs a
fresh problem with numeric constants each iteration (the naive way).

Writes a JSON summary to --out (iterations, seconds, objective history, true energy, ...).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import cvxpy as cp

# Clarabel's AlmostSolved comes back as "optimal_inaccurate" with a warning per solve; the status
# is recorded per iteration instead.
warnings.filterwarnings("ignore", message="Solution may be inaccurate")

# the default parameters (planner::Params::default()).
DEFAULTS = {
    "bandwidth_hz": 150e6,
    "wavelength_m": 0.1,
    "integration_time_s": 1.0,
    "observation_angle_rad": math.pi / 4,
    "d_min_m": 20.0,
    "altitude_m": 1000.0,
    "max_speed_mps": 50.0,
    "slot_s": 0.5,
    "horizon_s": 300.0,
    "start_m": [-1000.0, -500.0],
    "bs_m": [1000.0, -1000.0],
    "bs_height_m": 50.0,
    "sensing_radius_m": 200.0,
    "blade_power_w": 3.4,
    "tip_speed_mps": 60.0,
    "induced_power_w": 118.0,
    "induced_velocity_mps": 5.4,
    "rotor_solidity": 0.02,
    "rotor_disc_area_m2": 0.5,
    "air_density_kgpm3": 1.225,
    "fuselage_drag_ratio": 0.3,
    "uav_mass_kg": 2.0,
}
SPEED_OF_LIGHT_MPS = 299_792_458.0
# planner::schemes::exact constants and the default ExactTuning.
CENTRE_CURVATURE_BOUND = 0.5773502691896258
SENSING_MARGIN_M = 1e-3
SPEED_MARGIN_MPS = 1e-4
SPEED_KEEP_FRACTION = 0.85
# planner::evaluate::FEASIBILITY_TOL
FEASIBILITY_TOL = 1e-4
# The tolerances of planner::socp::SocpSettings, with Clarabel's default iterative refinement.
# (The Rust side turns refinement off for these programs, SocpSettings::exact_geometry(); through
# CVXPY's canonicalisation the 'mirror' programs then come out 7.6e-5 off the reference optimum at
# 200 m, so CVXPY keeps the refinement that makes it accurate.)
CLARABEL_OPTS = {
    "max_iter": 200,
    "tol_feas": 1e-8,
    "tol_gap_rel": 1e-8,
    "tol_gap_abs": 1e-8,
    "iterative_refinement_max_iter": 10,
    "iterative_refinement_reltol": 1e-13,
    "presolve_enable": False,
}


class InputError(Exception):
    """Bad input file; the message names the file and the field."""


# ----------------------------------------------------------------------------- mission, model


@dataclass
class Mission:
    p: dict
    slots: int
    landmark: np.ndarray  # (T_w, 2), NaN where a slot has no landmark
    lm_idx: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  # landmark slots (0-based)

    @property
    def delta(self) -> float:
        return self.p["slot_s"]

    @property
    def offset(self) -> float:
        return self.p["altitude_m"] * math.tan(self.p["observation_angle_rad"])

    @property
    def v_min(self) -> float:
        p = self.p
        return (
            p["wavelength_m"]
            * p["altitude_m"]
            / (p["integration_time_s"] * p["d_min_m"] * math.cos(p["observation_angle_rad"]))
        )

    @property
    def keepout(self):
        p = self.p
        k = SPEED_OF_LIGHT_MPS / (p["bandwidth_hz"] * p["d_min_m"]) - math.sin(
            p["observation_angle_rad"]
        )
        if k <= 0.0:
            return None
        if k >= 1.0:
            return math.inf
        return p["bs_height_m"] * k / math.sqrt(1.0 - k * k)

    @property
    def parasite_coeff(self) -> float:
        p = self.p
        return (
            0.5
            * p["fuselage_drag_ratio"]
            * p["air_density_kgpm3"]
            * p["rotor_solidity"]
            * p["rotor_disc_area_m2"]
        )

    @property
    def blade_quadratic_coeff(self) -> float:
        return 3.0 * self.p["blade_power_w"] / self.p["tip_speed_mps"] ** 2


def load_mission(path: Path) -> tuple[dict, list]:
    try:
        doc = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise InputError(f"{path}: {e}") from e
    p = dict(DEFAULTS)
    for k, v in doc.get("params", {}).items():
        if k not in DEFAULTS:
            raise InputError(f"{path}: [params].{k} is not a known parameter")
        p[k] = v
    lm = doc.get("landmarks", {})
    points = lm.get("points")
    if points is None:
        raise InputError(
            f"{path}: [landmarks] needs explicit points (use the mission.toml that "
            "`cellsar-planner plan --out DIR` writes)"
        )
    return p, points


def schedule(p: dict, points: list, slots: int) -> np.ndarray:
    """Per-slot landmark, the rule of planner::landmarks::Schedule::from_windows."""
    delta = p["slot_s"]
    eps = 1e-9 * max(slots * delta, 1.0)
    out = np.full((slots, 2), np.nan)
    for t0 in range(slots):
        t_s = (t0 + 1) * delta
        for w in points:
            if w["from_s"] < t_s - eps and t_s <= w["to_s"] + eps:
                out[t0] = (w["x_m"], w["y_m"])
    return out


def read_csv(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(start, positions (T_w, 2), landmark columns (T_w, 2) or NaN) of a trajectory.csv."""
    try:
        lines = [l for l in path.read_text().splitlines() if l.strip() and not l.startswith("#")]
    except OSError as e:
        raise InputError(f"{path}: {e}") from e
    cols = [c.strip() for c in lines[0].split(",")]
    for need in ("t_s", "x_m", "y_m"):
        if need not in cols:
            raise InputError(f"{path}: header: missing column `{need}`")
    it, ix, iy = cols.index("t_s"), cols.index("x_m"), cols.index("y_m")
    il = (cols.index("landmark_x_m"), cols.index("landmark_y_m")) if "landmark_x_m" in cols else None
    start = None
    pos, lms = [], []
    for n, line in enumerate(lines[1:], start=2):
        f = line.split(",")
        try:
            t = float(f[it])
            q = (float(f[ix]), float(f[iy]))
        except (ValueError, IndexError) as e:
            raise InputError(f"{path}, line {n}: {e}") from e
        if t == 0.0:
            start = q
            continue
        pos.append(q)
        lms.append((float(f[il[0]]), float(f[il[1]])) if il else (math.nan, math.nan))
    return (
        None if start is None else np.array(start),
        np.array(pos, dtype=float),
        np.array(lms, dtype=float),
    )


def induced_factor(speed, v0):
    a = speed * speed / (2.0 * v0 * v0)
    return np.sqrt(1.0 / (np.sqrt(1.0 + a * a) + a))


def power_w(m: Mission, speed):
    p = m.p
    return (
        p["blade_power_w"]
        + m.blade_quadratic_coeff * speed**2
        + p["induced_power_w"] * induced_factor(speed, p["induced_velocity_mps"])
        + m.parasite_coeff * speed**3
    )


def steps(start: np.ndarray, pos: np.ndarray) -> np.ndarray:
    prev = np.vstack([start[None, :], pos[:-1]])
    return pos - prev


def headings(step: np.ndarray) -> np.ndarray:
    """True headings with the hover rule of Trajectory::headings_rad."""
    norms = np.hypot(step[:, 0], step[:, 1])
    raw = [math.atan2(s[1], s[0]) if n > 1e-12 else None for s, n in zip(step, norms)]
    first = next((h for h in raw if h is not None), 0.0)
    out, last = [], first
    for h in raw:
        if h is not None:
            last = h
        out.append(last)
    return np.array(out)


@dataclass
class Evaluation:
    energy_j: float
    sensing_m: float
    min_speed_mps: float
    max_speed_mps: float
    range_paper_m: float

    @property
    def feasible(self) -> bool:
        return max(self.sensing_m, self.min_speed_mps, self.max_speed_mps, self.range_paper_m) <= FEASIBILITY_TOL


def evaluate(m: Mission, start: np.ndarray, pos: np.ndarray) -> Evaluation:
    """Exact-geometry evaluation (planner::evaluate, the quantities that decide feasibility)."""
    p = m.p
    st = steps(start, pos)
    speed = np.hypot(st[:, 0], st[:, 1]) / m.delta
    h = headings(st)
    centre = pos + m.offset * np.stack([np.sin(h), -np.cos(h)], axis=1)
    energy = float(np.sum(power_w(m, speed) * m.delta))
    lm = ~np.isnan(m.landmark[:, 0])
    err = np.hypot(*(centre[lm] - m.landmark[lm]).T)
    d = np.hypot(*(centre[lm] - np.array(p["bs_m"])).T)
    sin_t = d / np.sqrt(d * d + p["bs_height_m"] ** 2)
    range_paper = SPEED_OF_LIGHT_MPS / (
        p["bandwidth_hz"] * (math.sin(p["observation_angle_rad"]) + sin_t)
    )
    z = np.zeros(1)
    return Evaluation(
        energy_j=energy,
        sensing_m=float(np.max(np.concatenate([z, err - p["sensing_radius_m"]]))),
        min_speed_mps=float(np.max(np.concatenate([z, m.v_min - speed[lm]]))),
        max_speed_mps=float(np.max(np.concatenate([z, speed - p["max_speed_mps"]]))),
        range_paper_m=float(np.max(np.concatenate([z, range_paper - p["d_min_m"]]))),
    )


# ----------------------------------------------------------------------------- subproblem


def linearise(m: Mission, start: np.ndarray, pos: np.ndarray) -> dict:
    """The data of ExactSubproblem::build that depends on the previous iterate."""
    p = m.p
    delta, offset = m.delta, m.offset
    v0 = p["induced_velocity_mps"]
    k = 1.0 / (delta * delta * v0 * v0)
    u = steps(start, pos)
    un = np.hypot(u[:, 0], u[:, 1])
    hd = headings(u)
    safe = np.where(un > 0.0, un, 1.0)
    dirv = np.where(
        (un > 0.0)[:, None], u / safe[:, None], np.stack([np.cos(hd), np.sin(hd)], axis=1)
    )
    a0 = induced_factor(un / delta, v0)
    d = {
        # L_t = lin_a * a + lin_c + lin_x * vx + lin_y * vy
        "lin_a": 2.0 * a0,
        "lin_c": -a0 * a0 - k * (u[:, 0] ** 2 + u[:, 1] ** 2),
        "lin_x": 2.0 * k * u[:, 0],
        "lin_y": 2.0 * k * u[:, 1],
    }
    I = m.lm_idx
    h = dirv[I]
    uI = u[I]
    unI = un[I]
    v_min = m.v_min + SPEED_MARGIN_MPS
    s_min = np.maximum(delta * v_min, SPEED_KEEP_FRACTION * unI)
    scale = np.where(unI > 0.0, offset / np.where(unI > 0.0, unI, 1.0), 0.0)
    p00 = 1.0 - h[:, 0] * h[:, 0]
    p01 = -h[:, 0] * h[:, 1]
    p11 = 1.0 - h[:, 1] * h[:, 1]
    g = m.landmark[I]
    # c~x = x + D h_y + scale (P v)_y ; c~y = y - D h_x - scale (P v)_x
    d.update(
        hx=h[:, 0],
        hy=h[:, 1],
        s_min=s_min,
        ux=uI[:, 0],
        uy=uI[:, 1],
        cx_c=offset * h[:, 1],
        cx_vx=scale * p01,
        cx_vy=scale * p11,
        cy_c=-offset * h[:, 0],
        cy_vx=-scale * p00,
        cy_vy=-scale * p01,
        gx=g[:, 0],
        gy=g[:, 1],
        inv_kappa=s_min * s_min / (offset * CENTRE_CURVATURE_BOUND),
    )
    rk = m.keepout
    if rk is not None:
        prev_centre = pos[I] + offset * np.stack([h[:, 1], -h[:, 0]], axis=1)
        rel = prev_centre - np.array(p["bs_m"])
        rn = np.hypot(rel[:, 0], rel[:, 1])
        nrm = np.where((rn > 0.0)[:, None], rel / np.where(rn > 0, rn, 1.0)[:, None], [1.0, 0.0])
        nx, ny = nrm[:, 0], nrm[:, 1]
        d.update(
            ko_x=nx,
            ko_y=ny,
            ko_vx=nx * d["cx_vx"] + ny * d["cy_vx"],
            ko_vy=nx * d["cx_vy"] + ny * d["cy_vy"],
            ko_c=nx * d["cx_c"] + ny * d["cy_c"] - (nx * p["bs_m"][0] + ny * p["bs_m"][1]) - rk - SENSING_MARGIN_M,
        )
    return d


class Subproblem:
    """The cone program of one SCA iteration. With `parametric`, the linearisation data are
    cp.Parameters (DPP: compiled once, values updated); otherwise numeric constants."""

    def __init__(
        self,
        m: Mission,
        start: np.ndarray,
        data: dict,
        trust: bool,
        parametric: bool,
        speed_scale_mps: float | None = None,
    ):
        n = m.slots
        delta = m.delta
        self.m = m
        self.parametric = parametric
        self.params: dict[str, cp.Parameter] = {}

        def P(name):
            if not parametric:
                return data[name]
            par = cp.Parameter(data[name].shape, name=name)
            par.value = data[name]
            self.params[name] = par
            return par

        x = cp.Variable(n, name="x")
        y = cp.Variable(n, name="y")
        a = cp.Variable(n, name="a")
        s = cp.Variable(n, name="s")
        if speed_scale_mps is None:
            # the Rust formulation: V (m/s), w >= V^2, z >= V^3 as they are
            V = cp.Variable(n, name="V")
            w = cp.Variable(n, name="w")
            z = cp.Variable(n, name="z")
            Vs, ws, zs = V, w, z
            self.V_val = lambda: V.value
            self.z_val = lambda: z.value
        else:
            # the same program in units of a reference speed r: V = r V', w = r^2 w', z = r^3 z'
            # (V^2 <= w <=> V'^2 <= w', w^2 <= z V <=> w'^2 <= z' V'), so z ~ 1e4 becomes ~1
            r = float(speed_scale_mps)
            Vs = cp.Variable(n, name="V_scaled")
            ws = cp.Variable(n, name="w_scaled")
            zs = cp.Variable(n, name="z_scaled")
            V = r * Vs
            self.V_val = lambda: r * Vs.value
            self.z_val = lambda: r**3 * zs.value
        self.x, self.y, self.a = x, y, a
        # v_t = q_t - q_{t-1}: a sparse difference operator and the start as a constant
        D = sp.eye(n, format="csr") - sp.eye(n, k=-1, format="csr")
        c0x = np.zeros(n)
        c0y = np.zeros(n)
        c0x[0], c0y[0] = -start[0], -start[1]
        vx = D @ x + c0x
        vy = D @ y + c0y
        v_max = m.p["max_speed_mps"] - SPEED_MARGIN_MPS
        one = np.ones(n)
        cons = [
            # speed epigraph delta V >= ||v|| ; V <= V_m
            cp.SOC(delta * V, cp.vstack([vx, vy]), axis=0),
            V <= v_max,
            # s a >= 1 : (s + a, s - a, 2)
            cp.SOC(s + a, cp.vstack([s - a, 2.0 * one]), axis=0),
        ]
        L = cp.multiply(P("lin_a"), a) + P("lin_c") + cp.multiply(P("lin_x"), vx) + cp.multiply(P("lin_y"), vy)
        cons += [
            # s^2 <= L * 1
            cp.SOC(L + 1.0, cp.vstack([L - 1.0, 2.0 * s]), axis=0),
            # V^2 <= w * 1
            cp.SOC(ws + 1.0, cp.vstack([ws - 1.0, 2.0 * Vs]), axis=0),
            # w^2 <= z V
            cp.SOC(zs + Vs, cp.vstack([zs - Vs, 2.0 * ws]), axis=0),
        ]
        I = m.lm_idx
        if len(I):
            e = cp.Variable(len(I), name="e")
            vxI, vyI = vx[I], vy[I]
            radius = m.p["sensing_radius_m"] - SENSING_MARGIN_M
            cons.append(cp.multiply(P("hx"), vxI) + cp.multiply(P("hy"), vyI) - P("s_min") >= 0)
            cx = x[I] + P("cx_c") + cp.multiply(P("cx_vx"), vxI) + cp.multiply(P("cx_vy"), vyI)
            cy = y[I] + P("cy_c") + cp.multiply(P("cy_vx"), vxI) + cp.multiply(P("cy_vy"), vyI)
            gx, gy = data["gx"], data["gy"]  # landmarks do not change between iterations
            cons.append(cp.SOC(radius - e, cp.vstack([cx - gx, cy - gy]), axis=0))
            ux, uy = P("ux"), P("uy")
            dvx, dvy = vxI - ux, vyI - uy
            ek = cp.multiply(P("inv_kappa"), e)
            cons.append(cp.SOC(ek + 1.0, cp.vstack([ek - 1.0, 2.0 * dvx, 2.0 * dvy]), axis=0))
            if trust:
                if parametric:
                    self.trust = cp.Parameter(nonneg=True, name="trust", value=data["trust"])
                    tr = self.trust
                else:
                    tr = data["trust"]
                cons.append(cp.SOC(tr * np.ones(len(I)), cp.vstack([dvx, dvy]), axis=0))
            if m.keepout is not None:
                cons.append(
                    cp.multiply(P("ko_x"), x[I]) + cp.multiply(P("ko_y"), y[I])
                    + cp.multiply(P("ko_vx"), vxI) + cp.multiply(P("ko_vy"), vyI)
                    + P("ko_c") - e >= 0
                )
        c = 1.0 / n  # delta * objective_scale, objective_scale = 1 / (T_w delta)
        self.c = c
        r2, r3 = (1.0, 1.0) if speed_scale_mps is None else (speed_scale_mps**2, speed_scale_mps**3)
        obj = (
            c * m.blade_quadratic_coeff * r2 * cp.sum_squares(Vs)
            + c * m.p["induced_power_w"] * cp.sum(a)
            + c * m.parasite_coeff * r3 * cp.sum(zs)
        )
        self.problem = cp.Problem(cp.Minimize(obj), cons)
        if parametric and not self.problem.is_dpp():
            raise RuntimeError("the parametrised subproblem is not DPP")

    def update(self, data: dict) -> None:
        for name, par in self.params.items():
            par.value = data[name]
        if hasattr(self, "trust") and "trust" in data:
            self.trust.value = data["trust"]

    def solve(self):
        self.problem.solve(solver=cp.CLARABEL, warm_start=True, **CLARABEL_OPTS)
        return self.problem.status

    def physical_objective(self) -> float:
        """ExactSubproblem::physical_objective of the solution, evaluated at x like the Rust
        side (ProblemBuilder::objective): objective / objective_scale + T_w delta P0."""
        m = self.m
        V, a, z = self.V_val(), self.a.value, self.z_val()
        own = self.c * (
            m.blade_quadratic_coeff * float(V @ V)
            + m.p["induced_power_w"] * float(np.sum(a))
            + m.parasite_coeff * float(np.sum(z))
        )
        n = m.slots
        return own * n * m.delta + n * m.delta * m.p["blade_power_w"]


# ----------------------------------------------------------------------------- the SCA loop


@dataclass
class Record:
    iteration: int
    objective: float
    true_energy_j: float
    accepted: bool
    seconds: float
    solve_seconds: float
    clarabel_seconds: float
    ipm_iterations: int
    status: str


@dataclass
class Result:
    records: list = field(default_factory=list)
    objective_history: list = field(default_factory=list)
    true_energy_history: list = field(default_factory=list)
    termination: str = "max_iterations"
    first_status: str = ""


def run(
    m: Mission,
    start: np.ndarray,
    pos: np.ndarray,
    max_iterations: int,
    tolerance: float,
    mode: str,
    speed_scale_mps: float | None = None,
):
    ev = evaluate(m, start, pos)
    if not ev.feasible:
        raise InputError(
            f"the start is not feasible on the exact geometry ({ev}); start from the trajectory "
            "that `cellsar-planner plan --no-coarse --plain-sca --max-iterations 0` writes"
        )
    value = ev.energy_j
    current = pos
    trust = None
    rejects = 0
    res = Result()
    cache: dict[bool, Subproblem] = {}
    compile_seconds = 0.0
    for it in range(1, max_iterations + 1):
        t0 = time.perf_counter()
        data = linearise(m, start, current)
        if trust is not None:
            data["trust"] = np.float64(trust)
        key = trust is not None
        tb = time.perf_counter()
        if mode == "dpp":
            sub = cache.get(key)
            if sub is None:
                sub = Subproblem(m, start, data, key, True, speed_scale_mps)
                cache[key] = sub
            else:
                sub.update(data)
        else:
            sub = Subproblem(m, start, data, key, False, speed_scale_mps)
        ts = time.perf_counter()
        try:
            status = sub.solve()
        except cp.error.SolverError as err:
            status = f"solver error: {err}"
        if it == 1:
            res.first_status = str(status)
        te = time.perf_counter()
        stats = sub.problem.solver_stats
        clarabel_s = float(stats.solve_time or 0.0) if stats is not None else 0.0
        ipm = int(stats.num_iters or 0) if stats is not None else 0
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or sub.x.value is None:
            rejects += 1
            trust = 2.0 if trust is None else trust * 0.5
            res.records.append(
                Record(it, math.nan, value, False, time.perf_counter() - t0, te - tb, clarabel_s, ipm, str(status))
            )
            if rejects > 8:
                res.termination = f"subproblem_failed: {status}"
                break
            continue
        cand = np.stack([sub.x.value, sub.y.value], axis=1)
        cand_ev = evaluate(m, start, cand)
        own = sub.physical_objective()
        ok = cand_ev.feasible and cand_ev.energy_j <= value * (1.0 + 1e-9) + 1e-9
        res.records.append(
            Record(it, own, cand_ev.energy_j, ok, time.perf_counter() - t0, te - tb, clarabel_s, ipm, str(status))
        )
        if not ok:
            rejects += 1
            trust = 2.0 if trust is None else trust * 0.5
            if rejects > 8:
                res.termination = "no_progress"
                break
            continue
        rejects = 0
        rel = abs(value - cand_ev.energy_j) / max(abs(value), 1e-12)
        current, value, ev = cand, cand_ev.energy_j, cand_ev
        res.objective_history.append(own)
        res.true_energy_history.append(value)
        if rel < tolerance:
            res.termination = "converged"
            break
        if trust is not None:
            trust = trust * 4.0
            if trust >= 50.0:
                trust = None
    return current, ev, res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mission", type=Path, required=True, help="mission.toml written by `cellsar-planner plan --out DIR`")
    ap.add_argument("--init", type=Path, required=True, help="trajectory.csv of a feasible start")
    ap.add_argument("--max-iterations", type=int, default=200)
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--mode", choices=["dpp", "rebuild"], default="dpp")
    ap.add_argument(
        "--formulation",
        choices=["mirror", "scaled"],
        default="mirror",
        help="mirror: exactly the Rust cone program; scaled: the same program with V, w, z in units "
        "of --speed-scale-mps (better conditioned; gives the subproblem's accurate optimum)",
    )
    ap.add_argument("--speed-scale-mps", type=float, default=20.0)
    ap.add_argument("--out", type=Path, help="write the JSON summary here")
    args = ap.parse_args(argv)
    t_all = time.perf_counter()
    try:
        p, points = load_mission(args.mission)
        start_csv, pos, lm_csv = read_csv(args.init)
        slots = int(round(p["horizon_s"] / p["slot_s"]))
        if len(pos) != slots:
            raise InputError(f"{args.init}: {len(pos)} slots, but the mission has {slots}")
        start = np.array(p["start_m"], dtype=float) if start_csv is None else start_csv
        if np.max(np.abs(start - np.array(p["start_m"]))) > 1e-9:
            raise InputError(f"{args.init}: the t = 0 row {start} is not the mission's start_m {p['start_m']}")
        lms = schedule(p, points, slots)
        both_nan = np.isnan(lms) & np.isnan(lm_csv)
        if not np.all(both_nan | (np.abs(lms - lm_csv) <= 1e-9)):
            bad = int(np.argmax(~np.all(both_nan | (np.abs(lms - lm_csv) <= 1e-9), axis=1))) + 1
            raise InputError(f"{args.init}: slot {bad}: its landmark differs from the mission's schedule")
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    m = Mission(p=p, slots=slots, landmark=lms, lm_idx=np.flatnonzero(~np.isnan(lms[:, 0])))
    t0 = time.perf_counter()
    try:
        scale = args.speed_scale_mps if args.formulation == "scaled" else None
        traj, ev, res = run(m, start, pos, args.max_iterations, args.tolerance, args.mode, scale)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    seconds = time.perf_counter() - t0
    accepted = [r for r in res.records if r.accepted]
    summary = {
        "implementation": f"cvxpy {cp.__version__} + clarabel ({args.mode}, {args.formulation})",
        "formulation": args.formulation,
        "first_status": res.first_status,
        "slots": slots,
        "iterations": len(res.records),
        "accepted": len(accepted),
        "termination": res.termination,
        "solve_seconds": seconds,
        "wall_seconds_with_imports": time.perf_counter() - t_all,
        "energy_j": ev.energy_j,
        "feasible": ev.feasible,
        "objective_history": res.objective_history,
        "true_energy_history": res.true_energy_history,
        "iteration_seconds": [r.seconds for r in res.records],
        "cvxpy_solve_seconds": [r.solve_seconds for r in res.records],
        "clarabel_seconds": [r.clarabel_seconds for r in res.records],
        "ipm_iterations": [r.ipm_iterations for r in res.records],
        "statuses": [r.status for r in res.records],
        "objectives": [r.objective for r in res.records],
    }
    if args.out:
        args.out.write_text(json.dumps(summary, indent=1))
    print(
        f"cvxpy ({args.mode}, {args.formulation}): {slots} slots, {len(res.records)} iterations ({res.termination}), "
        f"true energy {ev.energy_j:.1f} J, feasible {ev.feasible}, {seconds:.3f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
