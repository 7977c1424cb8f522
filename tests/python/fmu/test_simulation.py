"""Simulation: the plan matches `cellsar-planner plan`, arbitrary communication points, the
receding-horizon re-plan, and a coupled co-simulation with a second FMU."""

import csv
import json
import math
import os
import pathlib
import shutil
import subprocess

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException

from conftest import REPO, Fmu, fmu_path, run, status_of

DEFAULT_MISSION = REPO / "missions" / "default-30m.toml"
OFFSET_M = 1000.0  # H tan(eta) with the the default parameters
RS_M = 200.0
ERROR = 3


def planner_bin():
    """`cellsar-planner`: $CELLSAR_PLANNER_BIN, else the workspace's release build."""
    env = os.environ.get("CELLSAR_PLANNER_BIN")
    candidates = [pathlib.Path(env)] if env else [
        REPO / "target" / "release" / "cellsar-planner",
    ]
    for c in candidates:
        if c.is_file():
            return c
    raise FileNotFoundError(
        "cellsar-planner not found: build it with "
        "`cargo build --release -p planner --bin cellsar-planner` or set CELLSAR_PLANNER_BIN")


def cli_plan(mission, outdir, flags=()):
    """Runs `cellsar-planner plan MISSION --out DIR FLAGS`; returns the completed process."""
    return subprocess.run(
        [str(planner_bin()), "plan", str(mission), "--out", str(outdir), *flags],
        capture_output=True, text=True, timeout=600)


def read_trajectory(outdir):
    """{t_s: (x_m, y_m)} at slot times from a plan directory's trajectory.csv."""
    rows = {}
    with open(outdir / "trajectory.csv", newline="") as f:
        for r in csv.DictReader(f):
            rows[round(float(r["t_s"]), 9)] = (float(r["x_m"]), float(r["y_m"]))
    return rows


def reference_plan(mission, outdir, flags=()):
    """Runs `cellsar-planner plan MISSION --out DIR FLAGS` (without flags: the CLI's default
    plan, the general cell as a best effort, which is the FMU's default initial plan);
    returns {t_s: (x_m, y_m)} at slot times."""
    p = cli_plan(mission, outdir, flags)
    assert p.returncode == 0, p.stderr
    return read_trajectory(outdir)


def cli_error(process):
    """The message of a failed `cellsar-planner` run (its last `error: ` line, without it)."""
    lines = [l for l in process.stderr.splitlines() if l.startswith("error: ")]
    assert lines, process.stderr
    return lines[-1][len("error: "):]


def test_default_mission_matches_cellsar_planner(tmp_path):
    """simulate_fmu of the default mission (resources/) against `cellsar-planner plan` on the
    same mission file: positions agree to 1e-6 m at every slot time."""
    ref = reference_plan(DEFAULT_MISSION, tmp_path / "plan")
    res = simulate_fmu(str(fmu_path("fmi2")), stop_time=300.0, output_interval=0.5,
                       output=["x_m", "y_m", "energy_j", "in_view"])
    assert len(res) == 601 and math.isclose(res["time"][-1], 300.0)
    worst = 0.0
    for t, x, y in zip(res["time"], res["x_m"], res["y_m"]):
        rx, ry = ref[round(t, 9)]
        worst = max(worst, abs(x - rx), abs(y - ry))
    assert worst <= 1e-6, f"largest deviation {worst} m"
    assert np.all(np.diff(res["energy_j"]) > 0)


def test_short_mission_matches_cellsar_planner(version, tmp_path, short_mission):
    ref = reference_plan(short_mission, tmp_path / "plan")
    rows = run(version, short_mission, stop=20.0, step=0.5, outputs=["x_m", "y_m"])
    for t, o in rows:
        rx, ry = ref[round(t, 9)]
        assert abs(o["x_m"] - rx) <= 1e-6 and abs(o["y_m"] - ry) <= 1e-6, t


def test_outputs_are_consistent_at_slot_times(version, short_mission):
    rows = run(version, short_mission, stop=20.0, step=0.5)
    energy = 0.0
    for k, (t, o) in enumerate(rows[1:], start=1):
        # the sensing centre lies H tan(eta) to the right of the track
        assert math.isclose(math.hypot(o["xc_m"] - o["x_m"], o["yc_m"] - o["y_m"]), OFFSET_M,
                            rel_tol=1e-12)
        right = (math.sin(o["heading_rad"]), -math.cos(o["heading_rad"]))
        assert math.isclose(o["xc_m"], o["x_m"] + OFFSET_M * right[0], abs_tol=1e-9)
        # in_view is the distance test at the slot end
        d = math.hypot(o["xc_m"] - o["landmark_x_m"], o["yc_m"] - o["landmark_y_m"])
        assert o["in_view"] == (d <= RS_M)
        # speed from the positions; energy is the running sum of power * slot
        px, py = rows[k - 1][1]["x_m"], rows[k - 1][1]["y_m"]
        assert math.isclose(o["speed_mps"], math.hypot(o["x_m"] - px, o["y_m"] - py) / 0.5,
                            rel_tol=1e-9, abs_tol=1e-9)
        energy += o["power_w"] * 0.5
        assert math.isclose(o["energy_j"], energy, rel_tol=1e-12)
        assert o["landmark_y_m"] == (0.0 if t <= 10.0 else 30.0)


def test_odd_steps_and_off_grid_stop_time(version, short_mission):
    grid = run(version, short_mission, stop=20.0, step=0.5, outputs=["x_m", "y_m", "energy_j"])
    gt = np.array([t for t, _ in grid])
    gx = np.array([o["x_m"] for _, o in grid])
    gy = np.array([o["y_m"] for _, o in grid])
    ge = np.array([o["energy_j"] for _, o in grid])
    res = simulate_fmu(str(fmu_path(version)), stop_time=13.37, output_interval=0.37,
                       start_values={"mission_file": str(short_mission)},
                       output=["x_m", "y_m", "energy_j"])
    assert math.isclose(res["time"][-1], 13.37, abs_tol=1e-12)
    # within a slot the UAV flies straight at constant speed and power: linear interpolation
    assert np.allclose(res["x_m"], np.interp(res["time"], gt, gx), atol=1e-9)
    assert np.allclose(res["y_m"], np.interp(res["time"], gt, gy), atol=1e-9)
    assert np.allclose(res["energy_j"], np.interp(res["time"], gt, ge), rtol=1e-12, atol=1e-9)
    # a hand-driven run with irregular steps ends where the grid run says
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    t = 0.0
    for h in [0.01, 0.73, 1.2, 0.5, 2.0, 0.333, 3.1, 0.127]:
        f.step(h, t=t)
        t += h
        assert math.isclose(f.get("x_m"), np.interp(t, gt, gx), abs_tol=1e-9)
    f.unload()


def test_stop_time_after_the_horizon_is_refused(version, short_mission):
    f = Fmu(version)
    assert f.instantiate()
    if version == "fmi2":
        f.fmu.setupExperiment(startTime=0.0, stopTime=25.0)
        f.set_string("mission_file", str(short_mission))
        f.fmu.enterInitializationMode()
    else:
        f.set_string("mission_file", str(short_mission))
        f.fmu.enterInitializationMode(startTime=0.0, stopTime=25.0)
    assert status_of(f.fmu.exitInitializationMode) == 3
    assert "after the end of the mission horizon" in f.messages()
    f.unload()


def test_step_past_the_horizon_stops_there(version, short_mission):
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=None, start=2.0, strings={"mission_file": str(short_mission)})
    f.step(19.5, t=2.0)
    assert status_of(f.fmu.doStep, 21.5, 1.0) == 2  # Discard: stopped at 22 s
    if version == "fmi2":
        from fmpy.fmi2 import fmi2Terminated, fmi2LastSuccessfulTime
        assert f.fmu.getBooleanStatus(fmi2Terminated)
        assert f.fmu.getRealStatus(fmi2LastSuccessfulTime) == 22.0
    grid = run(version, short_mission, stop=20.0, step=0.5, outputs=["x_m"])
    assert f.get("x_m") == grid[-1][1]["x_m"]
    f.unload()


def drive(version, mission, stop, move=None, name="drive"):
    """Steps the planner at 0.5 s; `move(t)` gives the landmark input at t (None: leave it).
    Returns [(t, outputs)] and the final replan count."""
    f = Fmu(version, name=name)
    assert f.instantiate()
    f.init(stop=stop, strings={"mission_file": str(mission)})
    rows = [(0.0, f.outputs())]
    n = int(round(stop / 0.5))
    for k in range(n):
        t = k * 0.5
        if move is not None and (m := move(t)) is not None:
            f.set(landmark_x_in_m=m[0], landmark_y_in_m=m[1])
        f.step(0.5, t=t)
        rows.append(((k + 1) * 0.5, f.outputs()))
    replans = f.get("replan_count")
    f.unload()
    return rows, replans


def test_moved_landmark_is_kept_in_view_from_the_next_window_on(version, short_mission):
    moved = (40.0, 20.0)
    # the input holds the moved landmark from t = 5 s on: the rest of window 0 and window 1.
    # The input refers to the landmark the outputs show (the slot rule: slot ceil(t/0.5)), so window 1's
    # landmark moves at the doStep from 10.5 s, when its first slot (10, 10.5] is flown.
    rows, replans = drive(version, short_mission, 20.0,
                          move=lambda t: moved if t >= 5.0 else None)
    assert replans == 2
    for t, o in rows:
        if t > 5.0 and t != 10.5:
            assert (o["landmark_x_m"], o["landmark_y_m"]) == moved, t
        if t > 10.0:  # the next window on
            assert o["in_view"], t


def test_one_shot_move_changes_only_its_window(version, short_mission):
    moved = (40.0, 20.0)
    rows, replans = drive(version, short_mission, 20.0,
                          move=lambda t: moved if t == 5.0 else (float("nan"),) * 2)
    assert replans == 1
    before, _ = drive(version, short_mission, 20.0)
    for (t, o), (_, b) in zip(rows, before):
        if t <= 5.0:
            assert o == b, t  # the past is not rewritten before the move
        elif t <= 10.0:
            assert (o["landmark_x_m"], o["landmark_y_m"]) == moved
        else:
            assert (o["landmark_x_m"], o["landmark_y_m"]) == (0.0, 30.0)
            assert o["in_view"], t


def test_coupled_cosimulation_with_a_second_fmu(version, short_mission):
    """Gauss-Seidel master: CellsarPlanner -> LandmarkMover -> CellsarPlanner. The mover shifts
    the current landmark by (40, 20) m at t = 5 s for 5 s; the planner re-plans."""
    p = Fmu(version, name="planner")
    m = Fmu(version, "LandmarkMover", name="mover")
    assert p.instantiate() and m.instantiate()
    p.init(stop=20.0, strings={"mission_file": str(short_mission)})
    m.init(stop=20.0, params={"move_at_s": 5.0, "offset_x_m": 40.0, "offset_y_m": 20.0,
                              "hold_s": 5.0})
    h, t, seen_moved = 0.5, 0.0, False
    rows = []
    while t < 20.0 - 1e-9:
        p.step(h, t=t)
        m.set(landmark_x_m=p.get("landmark_x_m"), landmark_y_m=p.get("landmark_y_m"))
        m.step(h, t=t)
        seen_moved |= m.get("moved")
        p.set(landmark_x_in_m=m.get("landmark_x_out_m"), landmark_y_in_m=m.get("landmark_y_out_m"))
        t += h
        rows.append((t, p.outputs()))
    assert math.isclose(t, 20.0) and seen_moved
    assert p.get("replan_count") == 1
    for t, o in rows:
        if 5.5 < t <= 10.0:
            assert (o["landmark_x_m"], o["landmark_y_m"]) == (40.0, 20.0), t
        if t > 10.0:
            assert (o["landmark_x_m"], o["landmark_y_m"]) == (0.0, 30.0)
            assert o["in_view"], t
    p.fmu.terminate()
    m.fmu.terminate()
    p.unload()
    m.unload()


def test_outputs_fed_back_to_the_inputs_change_nothing(version, short_mission):
    """Connecting landmark_*_m to landmark_*_in_m (no delay) is not a move, also at the window
    boundary where the outputs still show the previous window's landmark."""
    f = Fmu(version, name="loop")
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    rows = [(0.0, f.outputs())]
    for k in range(40):
        f.set(landmark_x_in_m=f.get("landmark_x_m"), landmark_y_in_m=f.get("landmark_y_m"))
        f.step(0.5, t=k * 0.5)
        rows.append(((k + 1) * 0.5, f.outputs()))
    assert f.get("replan_count") == 0
    assert rows == run(version, short_mission, stop=20.0, step=0.5)
    f.unload()


def test_parameters_override_the_mission_file(version, tmp_path):
    """[params] of the file over the default parameters; FMI parameters (other than their start values)
    over the file; after initialisation the parameters read back the values in effect."""
    mission = tmp_path / "m.toml"
    mission.write_text(
        "[params]\nhorizon_s = 10\naltitude_m = 1100\nmax_speed_mps = 40\n"
        "[landmarks]\npoints = [ { x_m = 0, y_m = 0, from_s = 0, to_s = 10 } ]\n",
        encoding="utf-8")
    f = Fmu(version)
    assert f.instantiate()
    # altitude back to its start value (as importers do): the file's 1100 m stays;
    # max speed to 45: overrides the file's 40
    f.init(stop=10.0, params={"altitude_m": 1000.0, "max_speed_mps": 45.0},
           strings={"mission_file": str(mission)})
    assert f.get("altitude_m") == 1100.0
    assert f.get("max_speed_mps") == 45.0
    assert f.get("horizon_s") == 10.0
    assert f.get("bandwidth_hz") == 150e6
    # the sensing centre lies H tan(eta) = 1100 m from the UAV
    f.step(0.5, t=0.0)
    assert math.isclose(math.hypot(f.get("xc_m") - f.get("x_m"), f.get("yc_m") - f.get("y_m")),
                        1100.0, rel_tol=1e-12)
    f.unload()


WARNING = 1


def test_move_out_of_reach_leaves_the_window_out_with_a_warning(version, short_mission):
    """A landmark moved 90 km away cannot be kept in view: the re-plan leaves its window out
    and the step returns Warning naming the landmark and slots (it returned OK with nothing
    logged); `slots_out_of_view` counts the slots. The next window is planned as usual."""
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    for k in range(5):
        assert f.step_status(0.5) == 0
    assert f.get("slots_out_of_view") == 0
    f.set(landmark_x_in_m=9e4, landmark_y_in_m=0.0)
    n = len(f.logs)
    assert f.step_status(0.5) == WARNING  # the doStep from t = 2.5 s
    warnings = [m for c, s, m in f.logs[n:] if s == WARNING]
    assert len(warnings) == 1, f.logs[n:]
    assert "landmark 0" in warnings[0] and "slots 6..20" in warnings[0], warnings[0]
    assert "to (90000, 0) m" in warnings[0]
    # the plan's slots 6..20 (t = 3..10 s) cannot see it; flown slots count against it too
    assert f.get("slots_out_of_view") == 20
    assert f.get("replan_count") == 1
    f.set(landmark_x_in_m=float("nan"), landmark_y_in_m=float("nan"))
    while f.time < 20.0 - 1e-9:
        assert f.step_status(0.5) == 0
        if f.time <= 10.0:
            assert not f.get("in_view") and f.get("landmark_x_m") == 9e4, f.time
        else:
            assert f.get("in_view") and f.get("landmark_y_m") == 30.0, f.time
    f.unload()


ERROR = 3


def test_move_beyond_the_physical_bounds_is_an_error_naming_the_input(version, short_mission):
    """A landmark input 1e16 m away is no place on Earth: the physical bounds refuse it, the
    doStep returns Error, and the log names the input as given (not 17 digits)."""
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    for k in range(5):
        assert f.step_status(0.5) == 0
    f.set(landmark_x_in_m=1e16, landmark_y_in_m=0.0)
    n = len(f.logs)
    assert f.step_status(0.5) == ERROR
    errors = [m for c, s, m in f.logs[n:] if s == ERROR]
    assert len(errors) == 1, f.logs[n:]
    assert "landmark input (1e16, 0) m rejected" in errors[0], errors[0]
    f.unload()


def test_persistent_far_input_warns_at_every_window(version, short_mission):
    """An input that keeps a landmark 90 km away re-plans each window without it, and each
    such doStep returns Warning (every step returned OK before)."""
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    statuses = []
    while f.time < 20.0 - 1e-9:
        if f.time >= 2.5:
            f.set(landmark_x_in_m=9e4, landmark_y_in_m=0.0)
        statuses.append((f.time, f.step_status(0.5)))
    assert [t for t, s in statuses if s == WARNING] == [2.5, 10.5], statuses
    assert all(s in (0, WARNING) for _, s in statuses)
    assert f.get("replan_count") == 2
    assert f.get("slots_out_of_view") == 40
    f.unload()


def test_mover_and_planner_agree_at_a_window_boundary(version, short_mission):
    """LandmarkMover latches the landmark the planner reports at its move time; at a window
    boundary (t = 10 s) that is window 0's (the slot rule: slot 20 covers (9.5, 10] s), and the planner
    applies the mover's output to that same window (it moved window 1's landmark before). Window
    0 has no slot left, so nothing is re-planned and the step warns; window 1 is untouched."""
    p = Fmu(version, name="planner")
    m = Fmu(version, "LandmarkMover", name="mover")
    assert p.instantiate() and m.instantiate()
    p.init(stop=20.0, strings={"mission_file": str(short_mission)})
    m.init(stop=20.0, params={"move_at_s": 10.0, "offset_x_m": 40.0, "offset_y_m": 0.0,
                              "hold_s": 0.5})
    h, statuses = 0.5, {}
    while p.time < 20.0 - 1e-9:
        t = p.time
        statuses[t] = p.step_status(h)
        m.set(landmark_x_m=p.get("landmark_x_m"), landmark_y_m=p.get("landmark_y_m"))
        m.step(h, t=t)
        p.set(landmark_x_in_m=m.get("landmark_x_out_m"), landmark_y_in_m=m.get("landmark_y_out_m"))
        if p.time > 10.0:
            assert (p.get("landmark_x_m"), p.get("landmark_y_m")) == (0.0, 30.0), p.time
    # fmpy's FMI 2 logger proxy is process-wide: the planner's messages may land in m.logs
    moved = [msg for _, _, msg in p.logs + m.logs if "moved from" in msg]
    assert len(moved) == 1 and "landmark 0 " in moved[0] and "to (40, 0) m" in moved[0], moved
    assert statuses[10.0] == WARNING and "no slot left" in moved[0]
    assert p.get("replan_count") == 0
    p.unload()
    m.unload()


def test_mover_default_move_is_mid_window(version):
    """The mover's default move time (65 s) lies inside a 10 s window of the default mission, so
    its default co-simulation moves landmark 6 and re-plans (60 s was a window boundary)."""
    m = Fmu(version, "LandmarkMover", name="mover")
    assert m.instantiate()
    m.init(stop=300.0)
    assert m.get("move_at_s") == 65.0 and m.get("hold_s") == 0.0
    m.unload()


def test_parameter_array_elements_override_the_file_one_by_one(version, tmp_path):
    """Setting one element of start_m (FMI 2: start_m[2]; FMI 3: the array with x at its start
    value) keeps the mission file's other element (it was reset to the default)."""
    mission = tmp_path / "m.toml"
    mission.write_text(
        "[params]\nhorizon_s = 20\nstart_m = [-1100.0, -450.0]\nbs_m = [10.0, 20.0]\n"
        "[landmarks]\npoints = [\n  { x_m = 0, y_m = 0, from_s = 0, to_s = 10 },\n"
        "  { x_m = 0, y_m = 30, from_s = 10, to_s = 20 },\n]\n", encoding="utf-8")
    f = Fmu(version)
    assert f.instantiate()
    if version == "fmi2":
        f.fmu.setupExperiment(startTime=0, stopTime=20)
        f.fmu.setReal([f.vr("start_m[2]")], [-460.0])
        f.fmu.setReal([f.vr("bs_m[1]")], [11.0])
        f.set_string("mission_file", str(mission))
        f.fmu.enterInitializationMode()
        f.fmu.exitInitializationMode()
        start = f.fmu.getReal([f.vr("start_m[1]"), f.vr("start_m[2]")])
        bs = f.fmu.getReal([f.vr("bs_m[1]"), f.vr("bs_m[2]")])
    else:
        f.fmu.setFloat64([f.vr("start_m")], [-1000.0, -460.0])
        f.fmu.setFloat64([f.vr("bs_m")], [11.0, -1000.0])  # y at its start value
        f.set_string("mission_file", str(mission))
        f.fmu.enterInitializationMode(startTime=0, stopTime=20)
        f.fmu.exitInitializationMode()
        start = f.fmu.getFloat64([f.vr("start_m")], nValues=2)
        bs = f.fmu.getFloat64([f.vr("bs_m")], nValues=2)
    assert list(start) == [-1100.0, -460.0]
    assert list(bs) == [11.0, 20.0]
    assert (f.get("x_m"), f.get("y_m")) == (-1100.0, -460.0)
    f.unload()


def test_replan_skips_planner_calls_that_cannot_succeed(version):
    """From the paper's initial plan (parameter `resolution` = paper) under the paper's dynamics
    (the reach bound that skips the calls is the speed limit's), the default mission's
    landmark moved by (40, 20) m at t = 65 s cannot be seen in the next slot: the re-plan goes
    straight to a one-slot delay (one planner call; the planner spent about 9 s failing on the
    zero delay before), and the debug log lists every call's time."""
    f = Fmu(version)
    assert f.instantiate(debug=True)
    # the paper's plan, whose sensing centre passes landmark 6 on the side the move goes away
    # from; the default best effort circles a centre on the other side, towards which the move
    # goes, and keeps the moved landmark in view at once
    f.init(stop=300.0, params={"resolution": "paper"}, strings={"dynamics": "paper"})
    assert f.get("plan_resolution") == 0
    while f.time < 65.0 - 1e-9:
        f.step(0.5)
    f.set(landmark_x_in_m=f.get("landmark_x_m") + 40.0,
          landmark_y_in_m=f.get("landmark_y_m") + 20.0)
    n = len(f.logs)
    assert f.step_status(0.5) == WARNING  # one transition slot out of view
    replanned = [m for _, _, m in f.logs[n:] if m.startswith("re-planned:")]
    assert len(replanned) == 1, f.logs[n:]
    assert "1 planner call(s) (delay 1: " in replanned[0], replanned[0]
    assert "1 transition slot(s)" in replanned[0]
    warning = [m for _, s, m in f.logs[n:] if s == WARNING]
    assert "1 re-planned slot(s) are out of view: landmark 6 in slot 131 " in warning[0], warning
    assert f.get("replan_count") == 1
    f.unload()


# The initial plan's options as FMU parameters and as the same options of `cellsar-planner plan`,
# and the value of the output `plan_resolution` before any re-plan.
PLAN_OPTIONS = [
    ({}, [], 1),
    ({"resolution": "paper"}, ["--resolution", "paper"], 0),
    ({"max_extra_energy_pct": 10.0}, ["--max-extra-energy-pct", "10"], 1),
    ({"strict_resolution": True}, ["--strict-resolution"], 1),
]


def plan_outputs(f, stop, step=0.5):
    """Steps the FMU from 0 to `stop`; returns {t_s: (x_m, y_m)} at every step."""
    rows = {0.0: (f.get("x_m"), f.get("y_m"))}
    for k in range(int(round(stop / step))):
        f.step(step, t=k * step)
        rows[round((k + 1) * step, 9)] = (f.get("x_m"), f.get("y_m"))
    return rows


def test_default_initial_plan_is_the_cli_default_plan(version, tmp_path, short_mission):
    """Without plan options the initial plan is `cellsar-planner plan`'s default plan, the
    general resolution cell as a best effort (the CLI's summary.json says so), to 1e-6 m; the
    parameters read back the library's defaults and `plan_resolution` is 1 (general)."""
    ref = reference_plan(short_mission, tmp_path / "plan")
    summary = json.loads((tmp_path / "plan" / "summary.json").read_text())
    assert summary["resolution"] == "general" and summary["best_effort"] is not None, summary
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    assert f.get("resolution") == "general"
    assert f.get("strict_resolution") is False
    assert math.isnan(f.get("max_extra_energy_pct"))
    assert f.get("plan_resolution") == 1
    got = plan_outputs(f, 20.0)
    worst = max(max(abs(got[t][0] - x), abs(got[t][1] - y)) for t, (x, y) in ref.items())
    assert worst <= 1e-6, f"largest deviation {worst} m"
    f.unload()


@pytest.mark.parametrize("params,flags,code", PLAN_OPTIONS,
                         ids=["default", "paper", "cap-10pct", "strict"])
def test_initial_plan_options_match_cellsar_planner(version, tmp_path, short_mission, params,
                                                    flags, code):
    """Each plan option set as a parameter gives the plan `cellsar-planner plan` makes with the
    same option, to 1e-6 m at every slot time; a mission the CLI cannot plan with it is refused
    at ExitInitializationMode with the same message in the log (the strict general resolution
    cannot be held on the short mission today)."""
    cli = cli_plan(short_mission, tmp_path / "plan", flags)
    f = Fmu(version)
    assert f.instantiate()
    status = f.init_status(stop=20.0, params=params,
                           strings={"mission_file": str(short_mission)})
    for name, value in params.items():
        assert f.get(name) == value, name
    if cli.returncode != 0:
        assert status == ERROR, f.messages()
        # the CLI says "mission cannot be flown: <the planner's message>"
        detail = cli_error(cli).split("cannot be flown: ", 1)[-1]
        assert "cannot be flown" in f.messages() and detail in f.messages(), (detail, f.logs)
        f.unload()
        return
    assert status == 0, f.messages()
    assert f.get("plan_resolution") == code
    ref = read_trajectory(tmp_path / "plan")
    got = plan_outputs(f, 20.0)
    worst = max(max(abs(got[t][0] - x), abs(got[t][1] - y)) for t, (x, y) in ref.items())
    assert worst <= 1e-6, f"largest deviation {worst} m"
    f.unload()


def test_best_effort_options_under_the_paper_resolution_are_refused(version, tmp_path,
                                                                    short_mission):
    """`strict_resolution` or `max_extra_energy_pct` with `resolution` = paper: the library's
    check refuses the combination at ExitInitializationMode (the order of the sets does not
    matter), with the message `cellsar-planner plan` gives for the same flags, naming the
    parameters instead of the flags; nothing is planned."""
    flag_names = [("--strict-resolution", "strict_resolution"),
                  ("--max-extra-energy-pct", "max_extra_energy_pct"),
                  ("--resolution", "resolution")]
    for params, flags in [
        ({"strict_resolution": True}, ["--strict-resolution"]),
        ({"max_extra_energy_pct": 10.0}, ["--max-extra-energy-pct", "10"]),
    ]:
        cli = cli_plan(short_mission, tmp_path / "plan", ["--resolution", "paper", *flags])
        assert cli.returncode != 0
        expected = cli_error(cli)
        for flag, name in flag_names:
            expected = expected.replace(flag, name)
        assert "applies to resolution general only, not to paper" in expected, expected
        f = Fmu(version)
        assert f.instantiate()
        # the best-effort option first: each set is fine on its own
        status = f.init_status(stop=20.0, params={**params, "resolution": "paper"},
                               strings={"mission_file": str(short_mission)})
        assert status == ERROR, f.messages()
        errors = [m for _, s, m in f.logs if s == ERROR]
        assert len(errors) == 1 and expected in errors[0], (expected, f.logs)
        assert "ExitInitializationMode" in errors[0], errors
        with pytest.raises(Exception):
            f.get("x_m")
        f.unload()


def test_bad_plan_option_values_are_refused_at_the_set(version, short_mission, tmp_path):
    """An unknown `resolution` or a negative or infinite `max_extra_energy_pct` is refused by the
    set call (the latter with the library's message, as `cellsar-planner plan` prints it), and
    the value stays as it was; NaN is no cap."""
    f = Fmu(version)
    assert f.instantiate()
    # parameters can be read from initialisation mode on (and set until its end)
    if version == "fmi2":
        f.fmu.setupExperiment(startTime=0.0, stopTime=20.0)
        f.fmu.enterInitializationMode()
    else:
        f.fmu.enterInitializationMode(startTime=0.0, stopTime=20.0)
    f.set_string("mission_file", str(short_mission))
    with pytest.raises(FMICallException):
        f.set(resolution="exact")
    assert "`resolution` = \"exact\"" in f.messages() and "general" in f.messages()
    assert f.get("resolution") == "general"
    for bad, text in [(-1.0, "-1"), (math.inf, "inf")]:
        cli = cli_plan(short_mission, tmp_path / "plan", [f"--max-extra-energy-pct={text}"])
        assert cli.returncode != 0
        with pytest.raises(FMICallException):
            f.set(max_extra_energy_pct=bad)
        assert cli_error(cli) in f.messages(), (cli.stderr, f.logs)
        assert math.isnan(f.get("max_extra_energy_pct"))
    f.set(max_extra_energy_pct=5.0)
    assert f.get("max_extra_energy_pct") == 5.0
    f.set(max_extra_energy_pct=math.nan)
    assert math.isnan(f.get("max_extra_energy_pct"))
    f.set(resolution="paper")
    f.fmu.exitInitializationMode()
    assert f.get("resolution") == "paper" and f.get("plan_resolution") == 0
    # fixed after initialisation
    with pytest.raises(FMICallException):
        f.set(resolution="general")
    with pytest.raises(FMICallException):
        f.set(strict_resolution=True)
    assert "is fixed" in f.messages()
    f.unload()
