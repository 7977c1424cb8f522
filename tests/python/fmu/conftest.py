"""Shared helpers for the fmpy tests of the cellsar FMUs.

The FMUs are taken from $CELLSAR_FMU_DIR (default: <repo>/target/fmu), as written by
`cargo run --release -p fmu --bin package-fmu`. fmpy must be 0.3.32.
"""

import atexit
import ctypes
import os
import pathlib
import shutil
import tempfile

import pytest

import fmpy  # noqa: E402  (provisioned by the test harness)

from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import (  # noqa: E402
    FMU2Slave,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
)
from fmpy.fmi3 import FMU3Slave  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[3]
FMU_DIR = pathlib.Path(os.environ.get("CELLSAR_FMU_DIR", REPO / "target" / "fmu"))
VERSIONS = ["fmi2", "fmi3"]
DEBUG_INJECT_PANIC_VR = 0x7FFF0001

# Two landmarks of the paper's default layout, 20 s: plans in a fraction of a second.
SHORT_MISSION = """name = "short test mission"
[params]
horizon_s = 20
[landmarks]
points = [
  { x_m = 0, y_m = 0, from_s = 0, to_s = 10 },
  { x_m = 0, y_m = 30, from_s = 10, to_s = 20 },
]
"""

# One landmark, 2 s (4 slots): for tests that plan hundreds of times.
TINY_MISSION = """name = "tiny test mission"
[params]
horizon_s = 2
[landmarks]
points = [ { x_m = 0, y_m = 0, from_s = 0, to_s = 2 } ]
"""

OUTPUTS = [
    "x_m", "y_m", "speed_mps", "heading_rad", "power_w", "energy_j", "xc_m", "yc_m",
    "landmark_x_m", "landmark_y_m", "in_view", "range_resolution_m", "azimuth_resolution_m",
]

assert fmpy.__version__ == "0.3.32", f"fmpy 0.3.32 required, found {fmpy.__version__}"


def fmu_path(version, model="CellsarPlanner"):
    p = FMU_DIR / version / f"{model}.fmu"
    if not p.is_file():
        raise FileNotFoundError(
            f"{p} missing: run `cargo run --release -p fmu --bin package-fmu` first "
            "(or set CELLSAR_FMU_DIR)")
    return p


@pytest.fixture(params=VERSIONS)
def version(request):
    return request.param


@pytest.fixture
def short_mission(tmp_path):
    p = tmp_path / "short.toml"
    p.write_text(SHORT_MISSION, encoding="utf-8")
    return p


@pytest.fixture
def tiny_mission(tmp_path):
    p = tmp_path / "tiny.toml"
    p.write_text(TINY_MISSION, encoding="utf-8")
    return p


_libc = ctypes.CDLL(None)
_libc.calloc.restype = ctypes.c_void_p
_libc.calloc.argtypes = [ctypes.c_size_t, ctypes.c_size_t]
_libc.free.argtypes = [ctypes.c_void_p]


class Fmu:
    """A thin driver over fmpy's FMU2Slave / FMU3Slave that records the FMU's log messages
    (category, status, message) and exposes raw status codes."""

    _extracted = {}

    def __init__(self, version, model="CellsarPlanner", unzipdir=None, name="instance"):
        self.version = version
        self.path = fmu_path(version, model)
        self.md = read_model_description(str(self.path))
        key = (version, model)
        if unzipdir is None:
            if key not in Fmu._extracted:
                Fmu._extracted[key] = extract(str(self.path))
                atexit.register(shutil.rmtree, Fmu._extracted[key], True)
            unzipdir = Fmu._extracted[key]
        self.unzipdir = unzipdir
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.logs = []
        cls = FMU2Slave if version == "fmi2" else FMU3Slave
        self.fmu = cls(guid=self.md.guid, unzipDirectory=unzipdir,
                       modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.name = name
        self.time = 0.0

    # logging -------------------------------------------------------------------------------
    def _log2(self, env, instance_name, status, category, message):
        self.logs.append((category.decode(), status, message.decode("utf-8")))

    def _log3(self, env, status, category, message):
        self.logs.append((category.decode(), status, message.decode("utf-8")))

    def messages(self):
        return "\n".join(m for _, _, m in self.logs)

    # lifecycle -----------------------------------------------------------------------------
    def instantiate(self, debug=False, guid=None, name=None, resources=None):
        """Instantiates; returns the component pointer (None when refused)."""
        name = self.name if name is None else name
        token = (guid or self.md.guid).encode()
        res_dir = os.path.join(self.unzipdir, "resources")
        if self.version == "fmi2":
            cb = fmi2CallbackFunctions()
            cb.logger = fmi2CallbackLoggerTYPE(self._log2)
            cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(_libc.calloc)
            cb.freeMemory = fmi2CallbackFreeMemoryTYPE(_libc.free)
            from fmpy.logging import addLoggerProxy
            addLoggerProxy(ctypes.byref(cb))
            self._callbacks = cb
            loc = pathlib.Path(res_dir).as_uri() if resources is None else resources
            self.fmu.component = self.fmu.fmi2Instantiate(
                name.encode(), 1, token, loc.encode(), ctypes.byref(cb), 0, int(debug))
        else:
            from fmpy.fmi3 import fmi3LogMessageCallback, fmi3IntermediateUpdateCallback, fmi3ValueReference
            self._cb3 = fmi3LogMessageCallback(self._log3)
            loc = res_dir + os.sep if resources is None else resources
            self.fmu.component = self.fmu.fmi3InstantiateCoSimulation(
                name.encode(), token, loc.encode(), False, debug, False, False,
                (fmi3ValueReference * 0)(), 0, None, self._cb3, fmi3IntermediateUpdateCallback())
        return self.fmu.component

    def init(self, start=0.0, stop=None, params=None, strings=None):
        """Sets parameters, then initialises (plans) the mission."""
        if self.version == "fmi2":
            self.fmu.setupExperiment(startTime=start, stopTime=stop)
        self.set(**(params or {}))
        for k, v in (strings or {}).items():
            self.set_string(k, v)
        if self.version == "fmi2":
            self.fmu.enterInitializationMode()
        else:
            self.fmu.enterInitializationMode(startTime=start, stopTime=stop)
        self.fmu.exitInitializationMode()
        self.time = start

    def init_status(self, start=0.0, stop=None, params=None, strings=None):
        """`init`, returning the FMI status of the first call that fails (3 Error; 0 when none
        does) instead of raising."""
        try:
            self.init(start=start, stop=stop, params=params, strings=strings)
            return 0
        except FMICallException as e:
            return e.status

    def step(self, h, t=None):
        t = self.time if t is None else t
        self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        self.time = t + h

    def step_status(self, h, t=None):
        """doStep with the raw FMI status (0 OK, 1 Warning, 2 Discard, 3 Error, 4 Fatal): fmpy's
        doStep raises only above Warning. The time advances unless the step failed."""
        t = self.time if t is None else t
        try:
            if self.version == "fmi2":
                status = self.fmu.fmi2DoStep(self.fmu.component, t, h, 1)
            else:
                from fmpy.fmi3 import fmi3Boolean, fmi3Float64
                flags = [fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64()]
                status = self.fmu.fmi3DoStep(self.fmu.component, t, h, fmi3Boolean(True),
                                             *[ctypes.byref(x) for x in flags])
        except FMICallException as e:
            return e.status
        if status <= 2:
            self.time = t + h
        return status

    def free(self):
        if self.fmu.component:
            if self.version == "fmi2":
                self.fmu.fmi2FreeInstance(self.fmu.component)
            else:
                self.fmu.fmi3FreeInstance(self.fmu.component)
            self.fmu.component = None

    def unload(self):
        self.free()
        self.fmu.freeLibrary()

    # variables -----------------------------------------------------------------------------
    def vr(self, name):
        return self.vars[name].valueReference

    def set(self, **values):
        """Sets variables by name, each with the call of its type (Real/Float64, Boolean,
        String)."""
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Boolean":
                self.fmu.setBoolean([v.valueReference], [bool(value)])
            elif v.type == "String":
                self.fmu.setString([v.valueReference], [value])
            elif self.version == "fmi2":
                self.fmu.setReal([v.valueReference], [float(value)])
            else:
                vals = list(value) if v.shape else [float(value)]
                self.fmu.setFloat64([v.valueReference], vals)

    def set_string(self, name, value):
        self.fmu.setString([self.vr(name)], [value])

    def get(self, name):
        v = self.vars[name]
        if v.type in ("Real", "Float64"):
            if self.version == "fmi2":
                return self.fmu.getReal([v.valueReference])[0]
            return self.fmu.getFloat64([v.valueReference])[0]
        if v.type == "Boolean":
            return bool(self.fmu.getBoolean([v.valueReference])[0])
        if v.type in ("Integer", "Int32"):
            if self.version == "fmi2":
                return self.fmu.getInteger([v.valueReference])[0]
            return self.fmu.getInt32([v.valueReference])[0]
        s = self.fmu.getString([v.valueReference])[0]  # FMI 2: bytes
        return s.decode("utf-8") if isinstance(s, bytes) else s

    def outputs(self, names=OUTPUTS):
        return {n: self.get(n) for n in names}

    def set_int(self, vr, value):
        if self.version == "fmi2":
            self.fmu.setInteger([vr], [value])
        else:
            self.fmu.setInt32([vr], [value])


def status_of(fn, *args, **kwargs):
    """Calls an fmpy wrapper and returns the FMI status code (0 when it returned normally)."""
    try:
        fn(*args, **kwargs)
        return 0
    except FMICallException as e:
        return e.status


def run(version, mission=None, stop=20.0, step=0.5, params=None, outputs=OUTPUTS, name="run"):
    """Runs the planner FMU with a fixed step and returns [(t, {name: value})]."""
    f = Fmu(version, name=name)
    assert f.instantiate()
    strings = {"mission_file": str(mission)} if mission else None
    f.init(stop=stop, params=params, strings=strings)
    rows = [(0.0, f.outputs(outputs))]
    n = int(round(stop / step))
    for k in range(n):
        f.step(step, t=k * step)
        rows.append(((k + 1) * step, f.outputs(outputs)))
    f.fmu.terminate()
    f.free()
    return rows


@pytest.fixture(scope="session")
def tmpdir_session():
    d = tempfile.mkdtemp(prefix="cellsar-fmu-tests-")
    yield pathlib.Path(d)
    shutil.rmtree(d, ignore_errors=True)
