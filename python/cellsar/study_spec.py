"""The study file (TOML): what a study runs, and the runs it expands into.

A study file names a base mission and scene, the parameters it sweeps (on a grid, drawn at
random, or both), the number of realisations and what each run does::

    [study]
    name = "spacing"
    mission = "../missions/default-30m.toml"   # relative to the study file
    scene = "../radar-sim/scenes/default.toml" # closed-loop only; default: the scene defaults
    mode = "plan"                              # or "closed-loop" (plan, simulate, process)
    realisations = 20
    seed = 0                                   # seed of the random draws
    realisation_seeds = ["landmarks.seed"]     # paths set to seed_offset + realisation index
    seed_offset = 0
    retries = 2                                # Dask retries of a run lost to its worker

    [run]                                      # the plan's options (cellsar.plan's arguments)
    scheme = "exact"

    [set]                                      # fixed values, by path
    "params.horizon_s" = 20

    [grid]                                     # every combination of these values
    "landmarks.spacing_m" = [10, 30, 60]

    [random]                                   # drawn per realisation
    "params.altitude_m" = { uniform = [80, 120] }
    "objects.seed" = { integers = [0, 1000] }

A path names a field of the mission file (``params.*``, ``landmarks.*``, ``name``), of the
scene file (``objects.*``, ``radar.*``, ``processing.*``) or a plan option (``run.*``). Every
error names the file and the field.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

try:
    import tomllib  # Python >= 3.11
except ImportError:  # pragma: no cover - older interpreters
    import tomli as tomllib  # type: ignore[no-redef]

#: What a run does.
MODES = ("plan", "closed-loop")
#: Top-level tables of a mission file that a path may name.
MISSION_ROOTS = ("params", "landmarks", "name")
#: Tables of a scene file that a path may name.
SCENE_ROOTS = ("objects", "radar", "processing")
#: Options of :func:`cellsar.plan` that ``[run]`` and ``run.*`` paths may set.
RUN_OPTIONS = (
    "scheme",
    "resolution",
    "strict_resolution",
    "max_extra_energy_pct",
    "max_iterations",
    "time_limit_s",
    "tolerance",
    "dynamics",
)
#: Distributions of ``[random]`` and their arguments ``[low, high]``.
DISTRIBUTIONS = ("uniform", "log_uniform", "integers", "choice")
STUDY_KEYS = (
    "name",
    "mission",
    "scene",
    "mode",
    "realisations",
    "seed",
    "realisation_seeds",
    "seed_offset",
    "retries",
)
TOP_KEYS = ("study", "run", "set", "grid", "random", "mission", "scene")


class StudyError(ValueError):
    """A study file that cannot be used; the message names the file and the field."""


@dataclass(frozen=True)
class Run:
    """One run of a study: its parameter values by path, realisation and seed."""

    run_id: str
    index: int
    realisation: int
    seed: int
    values: Dict[str, Any]
    mode: str
    options: Dict[str, Any]
    mission: Dict[str, Any]
    scene: Optional[Dict[str, Any]]


@dataclass
class Study:
    """A validated study file."""

    path: Path
    name: str
    mode: str
    realisations: int
    seed: int
    seed_offset: int
    retries: int
    realisation_seeds: List[str]
    options: Dict[str, Any]
    fixed: Dict[str, Any]
    grid: Dict[str, List[Any]]
    random: Dict[str, Tuple[str, List[Any]]]
    mission: Dict[str, Any]
    scene: Optional[Dict[str, Any]]
    base_digest: str = field(default="")

    @property
    def swept(self) -> List[str]:
        """The paths that vary between runs (grid, then random, then realisation seeds)."""
        out: List[str] = []
        for p in [*self.grid, *self.random, *self.realisation_seeds]:
            if p not in out:
                out.append(p)
        return out

    def runs(self) -> List[Run]:
        """Every run: the grid's combinations times the realisations, in a stable order."""
        import numpy as np

        keys = list(self.grid)
        combos = list(itertools.product(*(self.grid[k] for k in keys))) if keys else [()]
        out: List[Run] = []
        for r in range(self.realisations):
            rng = np.random.default_rng([self.seed, r])
            drawn = {p: draw(rng, d, a) for p, (d, a) in self.random.items()}
            seed = self.seed_offset + r
            for combo in combos:
                values: Dict[str, Any] = dict(zip(keys, combo))
                values.update(drawn)
                for p in self.realisation_seeds:
                    values[p] = seed
                out.append(self._run(len(out), r, seed, values))
        return out

    def _run(self, index: int, realisation: int, seed: int, values: Dict[str, Any]) -> Run:
        settings = {**self.fixed, **values}
        mission = copy.deepcopy(self.mission)
        scene = copy.deepcopy(self.scene) if self.scene is not None else None
        options = dict(self.options)
        for p, v in settings.items():
            root, _, rest = p.partition(".")
            if root == "run":
                options[rest] = v
            elif root in SCENE_ROOTS:
                if scene is None:
                    scene = {}
                set_path(scene, p, v)
            else:
                set_path(mission, p, v)
        ident = {
            "values": {k: values[k] for k in sorted(values)},
            "realisation": realisation,
            "seed": seed,
            "mode": self.mode,
            "base": self.base_digest,
        }
        run_id = hashlib.sha256(canonical(ident).encode()).hexdigest()[:16]
        return Run(run_id, index, realisation, seed, values, self.mode, options, mission, scene)


def canonical(value: Any) -> str:
    """JSON with sorted keys and no spaces: the text that identities are hashed from."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)


def set_path(d: Dict[str, Any], path: str, value: Any) -> None:
    """Sets ``d[a][b]... = value`` for the path ``a.b...``, creating tables on the way."""
    parts = path.split(".")
    for p in parts[:-1]:
        nxt = d.get(p)
        if not isinstance(nxt, dict):
            nxt = {}
            d[p] = nxt
        d = nxt
    d[parts[-1]] = value


def draw(rng: Any, dist: str, args: List[Any]) -> Any:
    """One value of a ``[random]`` distribution."""
    if dist == "uniform":
        return float(rng.uniform(args[0], args[1]))
    if dist == "log_uniform":
        return float(math.exp(rng.uniform(math.log(args[0]), math.log(args[1]))))
    if dist == "integers":
        return int(rng.integers(args[0], args[1], endpoint=True))
    return args[int(rng.integers(0, len(args)))]


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class _Checker:
    """Reads a study file's tables, raising :class:`StudyError` with the file and field."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, where: str, message: str) -> StudyError:
        return StudyError(f"{self.path}: `{where}`: {message}")

    def table(self, doc: Dict[str, Any], key: str) -> Dict[str, Any]:
        t = doc.get(key, {})
        if not isinstance(t, dict):
            raise self.fail(key, "expected a table")
        return t

    def int_in(self, t: Dict[str, Any], key: str, default: int, low: int) -> int:
        v = t.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise self.fail(f"study.{key}", f"expected an integer >= {low}, got {v!r}")
        return v

    def path_name(self, where: str, p: Any, mode: str) -> str:
        if not isinstance(p, str) or not p:
            raise self.fail(where, f"expected a path such as `params.bandwidth_hz`, got {p!r}")
        root, dot, rest = p.partition(".")
        if root == "run":
            if rest not in RUN_OPTIONS:
                raise self.fail(
                    f"{where}.{p}", f"unknown plan option, expected one of {', '.join(RUN_OPTIONS)}"
                )
        elif root in SCENE_ROOTS:
            if not dot or not rest:
                raise self.fail(f"{where}.{p}", "expected a key of the table, e.g. `radar.tx_power_w`")
            if mode != "closed-loop":
                raise self.fail(f"{where}.{p}", "a scene path needs study.mode = \"closed-loop\"")
        elif root not in MISSION_ROOTS or (root != "name" and not rest):
            raise self.fail(
                f"{where}.{p}",
                "unknown path: expected params.*, landmarks.*, name (mission), "
                "objects.*, radar.*, processing.* (scene) or run.* (plan option)",
            )
        return p

    def value(self, where: str, v: Any) -> Any:
        if isinstance(v, (dict, list)) and not (
            isinstance(v, list) and len(v) == 2 and all(_is_number(x) for x in v)
        ):
            raise self.fail(where, f"expected a number, string, boolean or [x, y], got {v!r}")
        if isinstance(v, float) and not math.isfinite(v):
            raise self.fail(where, f"expected a finite value, got {v!r}")
        return v

    def random(self, p: str, spec: Any) -> Tuple[str, List[Any]]:
        where = f"random.{p}"
        if not isinstance(spec, dict) or len(spec) != 1:
            raise self.fail(where, f"expected one of {{ {' | '.join(DISTRIBUTIONS)} = [...] }}")
        ((dist, args),) = spec.items()
        if dist not in DISTRIBUTIONS:
            raise self.fail(f"{where}.{dist}", f"unknown distribution, expected {', '.join(DISTRIBUTIONS)}")
        if dist == "choice":
            if not isinstance(args, list) or not args:
                raise self.fail(f"{where}.choice", "expected a non-empty list of values")
            return dist, [self.value(f"{where}.choice", a) for a in args]
        if not (isinstance(args, list) and len(args) == 2 and all(_is_number(a) for a in args)):
            raise self.fail(f"{where}.{dist}", f"expected [low, high], got {args!r}")
        low, high = args
        if high < low or (dist == "log_uniform" and low <= 0):
            raise self.fail(f"{where}.{dist}", f"expected 0 < low <= high (log) or low <= high, got {args!r}")
        if dist == "integers" and not all(isinstance(a, int) for a in args):
            raise self.fail(f"{where}.{dist}", f"expected integers, got {args!r}")
        return dist, list(args)

    def base(self, study: Dict[str, Any], doc: Dict[str, Any], key: str) -> Optional[Dict[str, Any]]:
        """The base mission or scene: an inline table `[key]` or a file named by `study.key`."""
        inline, named = doc.get(key), study.get(key)
        if inline is not None and named is not None:
            raise self.fail(f"study.{key}", f"give either study.{key} (a file) or a [{key}] table, not both")
        if inline is not None:
            if not isinstance(inline, dict):
                raise self.fail(key, "expected a table")
            return copy.deepcopy(inline)
        if named is None:
            return None
        if not isinstance(named, str):
            raise self.fail(f"study.{key}", f"expected a file path, got {named!r}")
        file = (self.path.parent / named).resolve()
        try:
            with open(file, "rb") as f:
                return tomllib.load(f)
        except OSError as e:
            raise self.fail(f"study.{key}", f"cannot read {file}: {e.strerror}") from None
        except tomllib.TOMLDecodeError as e:
            raise self.fail(f"study.{key}", f"{file}: {e}") from None


def load(path: "str | Path") -> Study:
    """Reads and validates a study file; raises :class:`StudyError` naming the field."""
    path = Path(path)
    c = _Checker(path)
    try:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    except OSError as e:
        raise StudyError(f"{path}: cannot read: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{path}: {e}") from None
    for k in doc:
        if k not in TOP_KEYS:
            raise c.fail(k, f"unknown table, expected one of {', '.join(TOP_KEYS)}")
    study = c.table(doc, "study")
    for k in study:
        if k not in STUDY_KEYS:
            raise c.fail(f"study.{k}", f"unknown key, expected one of {', '.join(STUDY_KEYS)}")
    name = study.get("name", path.stem)
    if not isinstance(name, str) or not name:
        raise c.fail("study.name", "expected a non-empty string")
    mode = study.get("mode", "plan")
    if mode not in MODES:
        raise c.fail("study.mode", f"expected one of {', '.join(MODES)}, got {mode!r}")
    mission = c.base(study, doc, "mission")
    if mission is None:
        raise c.fail("study.mission", "missing: a mission file or a [mission] table is required")
    scene = c.base(study, doc, "scene")
    if scene is not None and mode != "closed-loop":
        raise c.fail("study.scene", "a scene needs study.mode = \"closed-loop\"")
    seeds = study.get("realisation_seeds", [])
    if not isinstance(seeds, list):
        raise c.fail("study.realisation_seeds", "expected a list of paths")
    options = c.table(doc, "run")
    for k, v in options.items():
        if k not in RUN_OPTIONS:
            raise c.fail(f"run.{k}", f"unknown plan option, expected one of {', '.join(RUN_OPTIONS)}")
        c.value(f"run.{k}", v)
    fixed = {c.path_name("set", p, mode): c.value(f"set.{p}", v) for p, v in c.table(doc, "set").items()}
    grid: Dict[str, List[Any]] = {}
    for p, vs in c.table(doc, "grid").items():
        c.path_name("grid", p, mode)
        if not isinstance(vs, list) or not vs:
            raise c.fail(f"grid.{p}", "expected a non-empty list of values")
        grid[p] = [c.value(f"grid.{p}", v) for v in vs]
    random = {c.path_name("random", p, mode): c.random(p, d) for p, d in c.table(doc, "random").items()}
    s = Study(
        path=path,
        name=name,
        mode=mode,
        realisations=c.int_in(study, "realisations", 1, 1),
        seed=c.int_in(study, "seed", 0, 0),
        seed_offset=c.int_in(study, "seed_offset", 0, 0),
        retries=c.int_in(study, "retries", 2, 0),
        realisation_seeds=[c.path_name("study.realisation_seeds", p, mode) for p in seeds],
        options=options,
        fixed=fixed,
        grid=grid,
        random=random,
        mission=mission,
        scene=scene,
    )
    twice = set(grid) & set(random) | (set(grid) | set(random)) & set(s.realisation_seeds)
    if twice:
        p = sorted(twice)[0]
        raise c.fail(p, "swept twice (grid, random and realisation_seeds must name distinct paths)")
    s.base_digest = hashlib.sha256(
        canonical({"mission": mission, "scene": scene, "run": options, "set": fixed}).encode()
    ).hexdigest()[:16]
    _check_missions(c, s)
    return s


def _check_missions(c: _Checker, s: Study) -> None:
    """Builds the mission and checks the scene of every grid point of the first realisation,
    so that a wrong path or value is refused before any run, naming the field."""
    from . import Mission, MissionError, RadarError
    from .radar import check_scene

    seen = set()
    runs = s.runs()
    for run in runs[: max(1, len(runs) // s.realisations)]:
        key = canonical([run.mission, run.scene])
        if key in seen:
            continue
        seen.add(key)
        which = ", ".join(f"{k} = {v!r}" for k, v in run.values.items()) or "the base"
        try:
            Mission.from_dict(run.mission)
        except MissionError as e:
            raise StudyError(f"{c.path}: mission of {which}: {e}") from None
        try:
            check_scene(run.scene)
        except RadarError as e:
            raise StudyError(f"{c.path}: scene of {which}: {e}") from None
