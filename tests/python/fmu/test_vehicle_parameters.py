"""The vehicle limits through the planner FMU: the parameters `dynamics` and
`start_velocity_mps`, the outputs `commanded_accel_mps2`, `commanded_accel_x_mps2` and
`commanded_accel_y_mps2`, against `cellsar-planner plan` with the same options."""

import csv
import json
import math

import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException

from conftest import SHORT_MISSION, Fmu, fmu_path
from test_simulation import ERROR, cli_plan

DYNAMICS = ["vehicle", "paper"]
ACCEL = ["commanded_accel_mps2", "commanded_accel_x_mps2", "commanded_accel_y_mps2"]
STOP_S = 20.0
SLOT_S = 0.5


def read_rows(outdir):
    """trajectory.csv of a plan directory: [{column: float}] from t = 0 on."""
    with open(outdir / "trajectory.csv", newline="") as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def start_velocity_params(version, v):
    """`start_velocity_mps` as parameters for `Fmu.set`: one FMI 3 array, or its two FMI 2
    elements."""
    if version == "fmi2":
        return {"start_velocity_mps[1]": v[0], "start_velocity_mps[2]": v[1]}
    return {"start_velocity_mps": list(v)}


def set_start_velocity(f, v):
    f.set(**start_velocity_params(f.version, v))


def get_start_velocity(f):
    if f.version == "fmi2":
        return [f.get("start_velocity_mps[1]"), f.get("start_velocity_mps[2]")]
    return list(f.fmu.getFloat64([f.vr("start_velocity_mps")], nValues=2))


def fly(f):
    """Steps the initialised FMU over the short mission by slots; returns the outputs at every
    slot time t > 0: [(x, y, |a|, a_x, a_y)]."""
    rows = []
    for k in range(int(round(STOP_S / SLOT_S))):
        f.step(SLOT_S, t=k * SLOT_S)
        rows.append(tuple(f.get(n) for n in ["x_m", "y_m", *ACCEL]))
    return rows


def check_against_cli(f, outdir, start_velocity):
    """The FMU's plan is the CLI's (1e-6 m), its commanded acceleration is trajectory.csv's
    accel_mps2 at every slot time, and its components are (v_t - v_{t-1}) / slot_s from the CLI's
    positions, and (v_1 - v_0) / (slot_s / 2) into the first slot from the start velocity v_0 at
    t = 0 that summary.json reports; returns the summary."""
    summary = json.loads((outdir / "summary.json").read_text())
    assert get_start_velocity(f) == pytest.approx(summary["start_velocity_mps"], abs=1e-12)
    if start_velocity is not None:
        assert summary["start_velocity_mps"] == list(start_velocity)
    ref = read_rows(outdir)
    got = fly(f)
    assert len(got) == len(ref) - 1
    v_prev = summary["start_velocity_mps"]
    for k, (x, y, a, ax, ay) in enumerate(got, start=1):
        r, before = ref[k], ref[k - 1]
        assert abs(x - r["x_m"]) <= 1e-6 and abs(y - r["y_m"]) <= 1e-6, (k, x, y, r)
        assert a == pytest.approx(r["accel_mps2"], rel=1e-9, abs=1e-9), k
        v = [(r["x_m"] - before["x_m"]) / SLOT_S, (r["y_m"] - before["y_m"]) / SLOT_S]
        # the first slot's average velocity is that of its middle, half a slot after t = 0
        window = SLOT_S / 2 if k == 1 else SLOT_S
        want = [(v[0] - v_prev[0]) / window, (v[1] - v_prev[1]) / window]
        assert [ax, ay] == pytest.approx(want, abs=1e-5), k
        assert math.hypot(ax, ay) == pytest.approx(a, rel=1e-9, abs=1e-9), k
        v_prev = v
    peak = max(a for _, _, a, _, _ in got)
    assert peak == pytest.approx(summary["max_accel_mps2"], rel=1e-9)
    return summary


def test_model_description_declares_the_vehicle_variables(version, tmp_path, short_mission):
    """`dynamics` (String, start = the CLI's default dynamics, as its summary.json reports it),
    `start_velocity_mps` (m/s, start NaN NaN: the mission's own; FMI 2 `start_velocity_mps[1]`,
    `[2]`), and the three commanded-acceleration outputs (m/s2)."""
    cli = cli_plan(short_mission, tmp_path / "plan", ["--resolution", "paper"])
    assert cli.returncode == 0, cli.stderr
    default = json.loads((tmp_path / "plan" / "summary.json").read_text())["dynamics"]
    md = read_model_description(str(fmu_path(version)))
    v = {x.name: x for x in md.modelVariables}
    assert v["dynamics"].type == "String" and v["dynamics"].causality == "parameter"
    assert v["dynamics"].start == default
    names = ["start_velocity_mps[1]", "start_velocity_mps[2]"] if version == "fmi2" else \
        ["start_velocity_mps"]
    for n in names:
        assert v[n].causality == "parameter" and v[n].variability == "fixed"
        assert v[n].unit == "m/s"
        starts = v[n].start.split() if isinstance(v[n].start, str) else [v[n].start]
        assert all(math.isnan(float(s)) for s in starts), v[n].start
    if version == "fmi3":
        assert int(v["start_velocity_mps"].dimensions[0].start) == 2
    for n in ACCEL:
        assert v[n].causality == "output" and v[n].unit == "m/s2", n
        assert v[n].type == ("Real" if version == "fmi2" else "Float64")


@pytest.mark.parametrize("dynamics", DYNAMICS)
def test_each_dynamics_is_the_cli_plan_with_its_acceleration(version, tmp_path, short_mission,
                                                             dynamics):
    """`dynamics` = vehicle | paper gives `cellsar-planner plan --dynamics` of the same name
    (least-energy plans, `resolution` = paper: fast), with the CLI's accelerations; under vehicle
    no slot exceeds `max_accel_mps2` by more than 1e-6 relative."""
    flags = ["--resolution", "paper", "--dynamics", dynamics]
    cli = cli_plan(short_mission, tmp_path / "plan", flags)
    assert cli.returncode == 0, cli.stderr
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=STOP_S, strings={"mission_file": str(short_mission), "resolution": "paper",
                                 "dynamics": dynamics})
    assert f.get("dynamics") == dynamics
    summary = check_against_cli(f, tmp_path / "plan", None)
    assert summary["dynamics"] == dynamics
    if dynamics == "vehicle":
        assert summary["max_accel_mps2"] <= f.get("max_accel_mps2") * (1 + 1e-6)
    f.unload()


@pytest.mark.parametrize("dynamics", DYNAMICS)
def test_start_velocity_is_the_mission_files_start_velocity(version, tmp_path, dynamics):
    """`start_velocity_mps` set through FMI plans what the CLI plans with the same
    `start_velocity_mps` in the mission file (a velocity 10 degrees off the mission's rule, a turn
    the first slot can make within a_max slot_s / 2); the first slot's acceleration counts from
    it. Under paper the plan ignores it and the first slot exceeds the limit; under vehicle it
    does not."""
    start = (-11.2, 14.6)
    plain = tmp_path / "short.toml"
    plain.write_text(SHORT_MISSION, encoding="utf-8")
    stated = tmp_path / "stated.toml"
    stated.write_text(SHORT_MISSION.replace(
        "horizon_s = 20", f"horizon_s = 20\nstart_velocity_mps = [{start[0]}, {start[1]}]"),
        encoding="utf-8")
    cli = cli_plan(stated, tmp_path / "plan", ["--resolution", "paper", "--dynamics", dynamics])
    assert cli.returncode == 0, cli.stderr
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=STOP_S, params=start_velocity_params(version, start),
           strings={"mission_file": str(plain), "resolution": "paper", "dynamics": dynamics})
    summary = check_against_cli(f, tmp_path / "plan", start)
    limit = f.get("max_accel_mps2")
    rows = read_rows(tmp_path / "plan")
    if dynamics == "vehicle":
        assert summary["max_accel_mps2"] <= limit * (1 + 1e-6)
    else:
        assert rows[1]["accel_mps2"] > limit, rows[1]
    f.unload()


def test_bad_vehicle_values_are_refused(version, short_mission):
    """An unknown `dynamics` and an infinite start-velocity component are refused by the set (the
    value stays); one NaN component with one finite is refused at ExitInitializationMode, naming
    the parameter; both are fixed after initialisation."""
    f = Fmu(version)
    assert f.instantiate()
    if version == "fmi2":
        f.fmu.setupExperiment(startTime=0.0, stopTime=STOP_S)
        f.fmu.enterInitializationMode()
    else:
        f.fmu.enterInitializationMode(startTime=0.0, stopTime=STOP_S)
    default = f.get("dynamics")
    with pytest.raises(FMICallException):
        f.set(dynamics="jerk")
    assert "`dynamics` = \"jerk\"" in f.messages() and "paper, vehicle" in f.messages()
    assert f.get("dynamics") == default
    with pytest.raises(FMICallException):
        set_start_velocity(f, (math.inf, 0.0))
    assert all(math.isnan(x) for x in get_start_velocity(f))
    f.set_string("mission_file", str(short_mission))
    set_start_velocity(f, (5.0, math.nan))
    with pytest.raises(FMICallException):
        f.fmu.exitInitializationMode()
    errors = [m for _, s, m in f.logs if s == ERROR]
    assert any("`start_velocity_mps` = (5, NaN)" in m for m in errors), f.logs
    f.unload()
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=STOP_S, strings={"mission_file": str(short_mission), "resolution": "paper",
                                 "dynamics": "vehicle"})
    with pytest.raises(FMICallException):
        f.set(dynamics="paper")
    with pytest.raises(FMICallException):
        set_start_velocity(f, (1.0, 1.0))
    assert "is fixed" in f.messages()
    f.unload()


def test_a_replan_under_the_vehicle_dynamics_keeps_the_limit(version, short_mission):
    """A landmark move re-plans under the same dynamics, from the velocity flown: under vehicle
    every slot's commanded acceleration stays within the limit (1e-6 relative) after it."""
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=STOP_S, strings={"mission_file": str(short_mission), "resolution": "paper",
                                 "dynamics": "vehicle"})
    limit = f.get("max_accel_mps2")
    peak = 0.0
    for k in range(int(round(STOP_S / SLOT_S))):
        if k == 5:
            f.set(landmark_x_in_m=60.0, landmark_y_in_m=40.0)
        f.step(SLOT_S, t=k * SLOT_S)
        if k == 5:
            f.set(landmark_x_in_m=math.nan, landmark_y_in_m=math.nan)
        peak = max(peak, f.get("commanded_accel_mps2"))
    assert f.get("replan_count") == 1, f.messages()
    assert peak <= limit * (1 + 1e-6), peak
    f.unload()
