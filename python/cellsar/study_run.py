"""One run of a study, on a worker: plan the mission (and in closed-loop mode simulate and
process the radar's recording) and return its result row.

A run whose mission, plan or radar step fails for a reason of its own (an infeasible mission,
a bad value, a solver failure) returns a row with the error: that is the run's result, and
running it again would fail again. Anything else (out of memory, a lost worker) is raised, so
that Dask retries the run.
"""

from __future__ import annotations

import math
import os
import socket
import time
from typing import Any, Dict, Optional

from .study_spec import Run

#: Environment variables that pin a worker's native threads to one (Rayon in the radar chain,
#: the BLAS libraries under NumPy).
THREAD_ENV = (
    "RAYON_NUM_THREADS",
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
)

#: The result columns of a row, after the run's identity and parameters, with their types.
RESULT_COLUMNS = (
    ("status", "string"),
    ("error", "string"),
    ("energy_j", "float64"),
    ("feasible", "bool"),
    ("unresolved_windows", "float64"),
    ("pd", "float64"),
    ("pd_all", "float64"),
    ("strong_objects", "float64"),
    ("detected_objects", "float64"),
    ("false_alarms", "float64"),
    ("position_error_m", "float64"),
    ("plan_s", "float64"),
    ("radar_s", "float64"),
    ("run_s", "float64"),
    ("worker", "string"),
)


def pin_threads() -> None:
    """Pins this process's native thread pools to one thread, unless the user set them."""
    for k in THREAD_ENV:
        os.environ.setdefault(k, "1")


def _number(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and v is not None else math.nan


def _unresolved_windows(summary: Dict[str, Any]) -> float:
    shortfall = summary.get("resolution_shortfall") or {}
    return _number(shortfall.get("unresolved_windows"))


def empty_result() -> Dict[str, Any]:
    """A row's result columns before the run: every number NaN."""
    row: Dict[str, Any] = {k: math.nan for k, t in RESULT_COLUMNS if t == "float64"}
    row.update(status="ok", error="", feasible=False, worker=socket.gethostname())
    return row


def execute(run: Run) -> Dict[str, Any]:
    """Runs ``run`` and returns its result columns (see :data:`RESULT_COLUMNS`)."""
    pin_threads()
    import cellsar
    from cellsar import radar

    expected = (cellsar.MissionError, cellsar.PlanError, cellsar.RadarError, ValueError)
    row = empty_result()
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    t0 = time.perf_counter()
    plan: Optional[Any] = None
    try:
        mission = cellsar.Mission.from_dict(run.mission)
        plan = cellsar.plan(mission, **run.options)
        row["plan_s"] = time.perf_counter() - t0
        summary = plan.summary
        row["energy_j"] = float(plan.total_energy_j)
        row["feasible"] = bool(plan.feasible)
        row["unresolved_windows"] = _unresolved_windows(summary)
        if run.mode == "closed-loop":
            t1 = time.perf_counter()
            recording = radar.simulate(mission, plan, run.scene)
            result = radar.process(recording)
            row["radar_s"] = time.perf_counter() - t1
            m = result.metrics
            row["pd"] = _number(m.get("pd"))
            row["pd_all"] = _number(m.get("pd_all"))
            strong = _number(m.get("strong_objects"))
            row["strong_objects"] = strong
            row["detected_objects"] = (
                round(row["pd"] * strong) if math.isfinite(row["pd"] * strong) else math.nan
            )
            row["false_alarms"] = _number(m.get("false_alarms"))
            row["position_error_m"] = _number(m.get("mean_position_error_m"))
    except expected as e:
        if row["plan_s"] != row["plan_s"]:  # NaN: failed before the plan was made
            row["plan_s"] = time.perf_counter() - t0
        row["status"] = "failed"
        row["error"] = f"{type(e).__name__}: {e}"
    row["run_s"] = time.perf_counter() - t0
    return row
