"""cellsar: least-energy UAV trajectories for cellular-assisted bistatic SAR, from Python.

The planner, the exact-geometry evaluator and the radar chain of the Rust libraries
``planner`` and ``radar-sim``, with NumPy arrays and Python exceptions::

    import cellsar
    mission = cellsar.Mission.default(spacing_m=30.0)
    plan = cellsar.plan(mission)              # the `exact` scheme
    print(plan.summary["energy_j"], plan.x_m[:5])

Long calls release the GIL; Ctrl-C stops a plan (``KeyboardInterrupt``).
"""

from __future__ import annotations

from typing import Any, Callable, Optional, Union

from . import _cellsar
from ._cellsar import (
    InfeasibleMission,
    Mission,
    MissionError,
    Plan,
    PlanError,
    RadarError,
    dmin,
    evaluate,
    power_w,
)

__all__ = [
    "Mission",
    "Plan",
    "plan",
    "evaluate",
    "dmin",
    "power_w",
    "MissionError",
    "PlanError",
    "InfeasibleMission",
    "RadarError",
    "radar",
]

__version__ = "0.1.0"


def plan(
    mission: Mission,
    scheme: str = "exact",
    resolution: str = "paper",
    init: Optional[Union[Plan, str, "os.PathLike[str]", tuple]] = None,
    max_iterations: Optional[int] = None,
    time_limit_s: Optional[float] = None,
    progress: Optional[Callable[[dict], Any]] = None,
    tolerance: Optional[float] = None,
) -> Plan:
    """Plans ``mission`` and returns the :class:`Plan`.

    Args:
        mission: the mission.
        scheme: ``"exact"`` (the default: SCA on the exact geometry, every iterate feasible),
            ``"paper"`` (Algorithm 1 as printed), ``"baseline"`` or ``"baseline-exact"``.
        resolution: ``"paper"`` (the default: the least-energy plan, as ``cellsar-planner plan
            --resolution paper``) or ``"general"`` (the 2-D resolution cell, as a best effort:
            the default of the command-line tools).
        init: a start: a :class:`Plan`, a trajectory CSV path (as ``cellsar-planner plan
            --init``) or a pair ``(x_m, y_m)`` of arrays (``slots`` or ``slots + 1`` points).
        max_iterations: largest number of SCA/BCD iterations (200).
        time_limit_s: wall-time limit; the last accepted iterate is returned when it passes.
        progress: called with a dict for every phase (``{"phase": ...}``) and iteration
            (``iteration``, ``objective``, ``true_energy_j``, ...); an exception raised in it
            stops the plan and is re-raised.
        tolerance: relative change of the objective that stops the iterations (1e-4).

    Raises:
        InfeasibleMission: the mission cannot be flown (``slot``, ``t_s``, ``reason``).
        PlanError: the solver failed, or the time limit passed before a feasible start.
        ValueError: a bad option or start.
        KeyboardInterrupt: Ctrl-C while planning.

    The planner runs with the GIL released, so other Python threads run meanwhile.
    """
    import os  # noqa: F401  (for the annotation)

    return _cellsar.plan(
        mission,
        {
            "scheme": scheme,
            "resolution": resolution,
            "init": init,
            "max_iterations": max_iterations,
            "time_limit_s": time_limit_s,
            "progress": progress,
            "tolerance": tolerance,
        },
    )


from . import radar  # noqa: E402  (after the names it uses)
