"""Type stubs of the native module (cellsar._cellsar); the public names are re-exported by
cellsar and cellsar.radar."""

import os
from typing import Any, Dict, List, Optional, Union

import numpy as np
import numpy.typing as npt

from . import radar as radar

_F64 = npt.NDArray[np.float64]
_ArrayLike = npt.ArrayLike
_Path = Union[str, "os.PathLike[str]"]

class MissionError(ValueError):
    """A mission that cannot be read or built; the message names the file, field or slot."""

class PlanError(RuntimeError):
    """A plan that failed: the solver, the time limit, or an internal error."""

class InfeasibleMission(PlanError):
    """A mission that cannot be flown, proven (a closed-form bound rules out every trajectory)."""

    slot: int
    """The first slot (1-based) that cannot be met."""
    t_s: float
    """End time of that slot, s."""
    reason: str
    """What cannot be met."""

class PlanNotFound(PlanError):
    """No plan meets every constraint, and none is proven impossible."""

    slot: int
    """The first slot (1-based) that the best plan found violates."""
    t_s: float
    """End time of that slot, s."""
    reason: str
    """What that plan violates."""
    best_energy_j: Optional[float]
    """The best plan's true energy, J (None when there is none)."""
    best_violations: Optional[dict[str, float]]
    """The best plan's largest violations (the keys of `Evaluation.violations`)."""

class RadarError(ValueError):
    """A radar simulation or processing step that failed."""

class Mission:
    """A validated mission: parameters and a landmark schedule, read-only."""

    @staticmethod
    def from_file(path: _Path) -> Mission: ...
    @staticmethod
    def from_dict(d: Dict[str, Any]) -> Mission: ...
    @staticmethod
    def default(spacing_m: float = 30.0, **params: Any) -> Mission: ...
    def with_params(self, **params: Any) -> Mission: ...
    @property
    def name(self) -> str: ...
    @property
    def slots(self) -> int: ...
    @property
    def params(self) -> Dict[str, Any]: ...
    @property
    def landmarks(self) -> List[Dict[str, float]]: ...
    @property
    def slot_landmark(self) -> npt.NDArray[np.int64]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def to_toml(self) -> str: ...
    # the resolved parameters
    bandwidth_hz: float
    wavelength_m: float
    integration_time_s: float
    observation_angle_rad: float
    d_min_m: float
    altitude_m: float
    max_speed_mps: float
    slot_s: float
    horizon_s: float
    start_m: List[float]
    bs_m: List[float]
    bs_height_m: float
    sensing_radius_m: float
    blade_power_w: float
    tip_speed_mps: float
    induced_power_w: float
    induced_velocity_mps: float
    rotor_solidity: float
    rotor_disc_area_m2: float
    air_density_kgpm3: float
    fuselage_drag_ratio: float
    uav_mass_kg: float

class Plan:
    """A plan: the columns of trajectory.csv as arrays (slots + 1 rows, the start first)."""

    @property
    def mission(self) -> Mission: ...
    @property
    def columns(self) -> List[str]: ...
    def column(self, name: str) -> _F64: ...
    @property
    def total_energy_j(self) -> float: ...
    @property
    def feasible(self) -> bool: ...
    @property
    def scheme(self) -> str: ...
    @property
    def resolution(self) -> str: ...
    @property
    def summary(self) -> Dict[str, Any]: ...
    @property
    def records(self) -> List[Dict[str, Any]]: ...
    def to_csv(self, path: _Path) -> None: ...
    def to_dict(self) -> Dict[str, _F64]: ...
    def to_pandas(self) -> Any: ...
    def __len__(self) -> int: ...
    # the columns of trajectory.csv
    t_s: _F64
    x_m: _F64
    y_m: _F64
    speed_mps: _F64
    heading_rad: _F64
    xc_m: _F64
    yc_m: _F64
    landmark_x_m: _F64
    landmark_y_m: _F64
    in_view: _F64
    centre_error_m: _F64
    power_w: _F64
    energy_j: _F64
    range_resolution_paper_m: _F64
    range_resolution_general_m: _F64
    azimuth_resolution_m: _F64
    bistatic_angle_deg: _F64
    grad_norm: _F64
    psi_rad: _F64
    along_track_width_m: _F64
    cross_track_width_m: _F64
    worst_width_m: _F64

def plan(mission: Mission, args: Dict[str, Any]) -> Plan: ...
def evaluate(mission: Mission, x_m: _ArrayLike, y_m: _ArrayLike) -> Dict[str, Any]: ...
def dmin(
    radius_m: float, objects: int, method: str = "exact", trials: int = 2000, seed: int = 1
) -> float: ...
def power_w(speed_mps: _ArrayLike, mission: Optional[Mission] = None) -> Any: ...
