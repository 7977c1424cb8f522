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
    PlanNotFound,
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
    "PlanNotFound",
    "RadarError",
    "radar",
]

__version__ = "0.1.0"


def plan(
    mission: Mission,
    scheme: str = "exact",
    resolution: Optional[str] = None,
    strict_resolution: bool = False,
    max_extra_energy_pct: Optional[float] = None,
    init: Optional[Union[Plan, str, "os.PathLike[str]", tuple]] = None,
    max_iterations: Optional[int] = None,
    time_limit_s: Optional[float] = None,
    progress: Optional[Callable[[dict], Any]] = None,
    tolerance: Optional[float] = None,
    dynamics: Optional[str] = None,
) -> Plan:
    """Plans ``mission`` and returns the :class:`Plan`.

    Args:
        mission: the mission.
        scheme: ``"exact"`` (the default: SCA on the exact geometry, every iterate feasible),
            ``"paper"`` (Algorithm 1 as printed), ``"baseline"`` or ``"baseline-exact"``.
        resolution: ``"general"`` (the 2-D resolution cell, as a best effort where the
            geometry does not allow it in every landmark slot) or ``"paper"`` (the paper's
            criterion: the least-energy plan). ``None`` (the default) takes the scheme's
            default, the same as ``cellsar-planner plan``, ``cellsar run`` and a plan request
            on the wire: ``"general"`` for ``"exact"``, ``"paper"`` for the comparison schemes.
            :attr:`Plan.resolution` names the one planned for.
        strict_resolution: under ``"general"`` with ``"exact"``: plan with the cell within
            d_min in every landmark slot, raising :class:`PlanNotFound` where no such plan is
            found, instead of planning the best effort.
        max_extra_energy_pct: best effort only: the best-resolved plan within this many
            percent more energy than the least-energy (``"paper"``) plan.
        init: a start: a :class:`Plan`, a trajectory CSV path (as ``cellsar-planner plan
            --init``) or a pair ``(x_m, y_m)`` of arrays (``slots`` or ``slots + 1`` points).
        max_iterations: largest number of SCA/BCD iterations (200).
        time_limit_s: wall-time limit; the last accepted iterate is returned when it passes.
        progress: called with a dict for every phase (``{"phase": ...}``) and iteration
            (``iteration``, ``objective``, ``true_energy_j``, ...); an exception raised in it
            stops the plan and is re-raised.
        tolerance: relative change of the objective that stops the iterations (1e-4).
        dynamics: ``"vehicle"`` (the velocity changes by at most the mission's
            ``max_accel_mps2`` times the slot length from slot to slot, and by half that
            from its ``start_velocity_mps`` into the first slot; with the mission's
            ``max_jerk_mps3`` the acceleration changes by at most that times the slot length
            from slot to slot; the mission's ``resolution_margin_pct``, ``accel_margin_pct`` and
            ``jerk_margin_pct`` tighten the limits the plan is made for, and
            ``plan.summary["margins"]`` gives the room kept) or ``"paper"`` (the velocity may
            jump, as in the paper).
            ``None`` (the default) takes the scheme's default, as ``cellsar-planner plan
            --dynamics``; ``"vehicle"`` with ``"paper"`` or ``"baseline"`` is a ValueError.

    A mission with ``altitude = "free"`` is planned with an altitude per slot by the
    ``"exact"`` scheme, as by ``cellsar-planner plan`` (the plan's ``z_m`` and ``climb_mps``
    columns); the other schemes refuse it with a :class:`PlanError`.

    Raises:
        InfeasibleMission: the mission cannot be flown, proven (``slot``, ``t_s``, ``reason``).
        PlanNotFound: no plan meeting every constraint was found, none proven impossible
            (``slot``, ``t_s``, ``reason``, ``best_energy_j``, ``best_violations``).
        PlanError: the solver failed, the time limit passed before a feasible start, or a
            scheme other than ``"exact"`` was given a free-altitude mission.
        ValueError: a bad option or start; ``strict_resolution`` or ``max_extra_energy_pct``
            with the ``"paper"`` resolution or a comparison scheme, which would ignore them
            (the message is the library's, as the CLI's with its flags' names).
        KeyboardInterrupt: Ctrl-C while planning.

    The planner runs with the GIL released, so other Python threads run meanwhile.
    """
    import os  # noqa: F401  (for the annotation)

    return _cellsar.plan(
        mission,
        {
            "scheme": scheme,
            "resolution": resolution,
            "strict_resolution": strict_resolution,
            "max_extra_energy_pct": max_extra_energy_pct,
            "init": init,
            "max_iterations": max_iterations,
            "time_limit_s": time_limit_s,
            "progress": progress,
            "tolerance": tolerance,
            "dynamics": dynamics,
        },
    )


from . import radar  # noqa: E402  (after the names it uses)
