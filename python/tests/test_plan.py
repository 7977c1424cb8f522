"""Plans made through the package equal the CLI's for the same mission: the energy to 1e-9
relative, every column of trajectory.csv, the summary's keys and values, the CSV byte for byte."""

import numpy as np
import pytest

import cellsar
from conftest import MISSIONS, read_summary


def read_csv(path):
    return np.genfromtxt(path, delimiter=",", names=True)


def short_mission_file(directory):
    """The default mission cut to 60 s (six landmarks), as a file."""
    path = directory / "short.toml"
    path.write_text(cellsar.Mission.default(30.0, horizon_s=60.0).to_toml())
    return path


@pytest.mark.parametrize(
    "mission_file, scheme",
    [("default-30m.toml", "exact"), ("default-200m.toml", "exact"), ("short", "paper"),
     ("short", "baseline-exact")],
)
def test_plan_equals_cli(cli_plan, tmp_path, mission_file, scheme):
    path = short_mission_file(tmp_path) if mission_file == "short" else MISSIONS / mission_file
    # the least-energy plan asked for through both (their common default: test_defaults_agree)
    out = cli_plan(path, "--scheme", scheme, "--resolution", "paper")
    mission = cellsar.Mission.from_file(path)
    plan = cellsar.plan(mission, scheme=scheme, resolution="paper")

    cli = read_summary(out)
    ours = plan.summary
    assert set(ours) == set(cli)
    assert ours["energy_j"] == pytest.approx(cli["energy_j"], rel=1e-9)
    assert plan.total_energy_j == ours["energy_j"]
    for key, value in cli.items():
        if key == "solve_seconds":
            continue
        if isinstance(value, float):
            assert ours[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
        else:
            assert ours[key] == value, key

    table = read_csv(out / "trajectory.csv")
    assert list(table.dtype.names) == plan.columns
    for name in table.dtype.names:
        np.testing.assert_allclose(
            getattr(plan, name), table[name], rtol=1e-9, atol=1e-12, equal_nan=True, err_msg=name
        )
    assert len(plan) == mission.slots + 1

    plan.to_csv(tmp_path / "trajectory.csv")
    assert (tmp_path / "trajectory.csv").read_bytes() == (out / "trajectory.csv").read_bytes()


@pytest.mark.parametrize("scheme", ["exact", "baseline-exact"])
def test_defaults_agree_with_the_cli(cli_plan, tmp_path, scheme):
    # one request, one plan: the package, like the CLI, plans `exact` for the general cell as a
    # best effort and the comparison schemes for the paper's resolution unless told otherwise
    path = short_mission_file(tmp_path)
    cli = read_summary(cli_plan(path, "--scheme", scheme))
    plan = cellsar.plan(cellsar.Mission.from_file(path), scheme=scheme)
    expected = "general" if scheme == "exact" else "paper"
    assert plan.resolution == plan.summary["resolution"] == cli["resolution"] == expected
    assert plan.summary["energy_j"] == pytest.approx(cli["energy_j"], rel=1e-9)
    assert (plan.summary["best_effort"] is None) == (cli["best_effort"] is None)
    ours, theirs = plan.summary["resolution_shortfall"], cli["resolution_shortfall"]
    for key in ["unresolved_slots", "unresolved_windows", "first_unresolved_slot"]:
        assert ours[key] == theirs[key], key


def test_plan_columns_and_attributes():
    mission = cellsar.Mission.default(30.0)
    plan = cellsar.plan(mission, resolution="paper")
    assert plan.feasible and plan.scheme == "exact" and plan.resolution == "paper"
    for name in ["t_s", "x_m", "y_m", "speed_mps", "heading_rad", "xc_m", "yc_m", "power_w", "energy_j"]:
        column = getattr(plan, name)
        assert column.dtype == np.float64 and column.shape == (mission.slots + 1,)
    assert plan.t_s[0] == 0.0 and plan.energy_j[0] == 0.0
    assert (plan.x_m[0], plan.y_m[0]) == tuple(mission.start_m)
    np.testing.assert_allclose(np.diff(plan.t_s), mission.slot_s)
    assert plan.energy_j[-1] == pytest.approx(plan.summary["energy_j"], rel=1e-12)
    np.testing.assert_array_equal(plan.column("power_w"), plan.power_w)
    assert set(plan.to_dict()) == set(plan.columns)
    assert plan.records and plan.records[-1]["accepted"] in (True, False)
    with pytest.raises(AttributeError):
        plan.no_such_column


def test_plan_from_a_start_and_with_progress():
    mission = cellsar.Mission.default(30.0)
    first = cellsar.plan(mission, resolution="paper")
    seen = []
    again = cellsar.plan(mission, init=first, progress=seen.append, resolution="paper")
    assert again.feasible
    assert again.total_energy_j <= first.total_energy_j * (1 + 1e-6)
    assert {"phase": "solve"} in seen
    again_xy = cellsar.plan(mission, init=(first.x_m, first.y_m), max_iterations=2, resolution="paper")
    assert again_xy.summary["iterations"] <= 2


def test_to_pandas():
    pandas = pytest.importorskip("pandas")
    plan = cellsar.plan(cellsar.Mission.default(30.0), resolution="paper")
    frame = plan.to_pandas()
    assert isinstance(frame, pandas.DataFrame)
    assert list(frame.columns) == plan.columns
    np.testing.assert_array_equal(frame["x_m"].to_numpy(), plan.x_m)


def test_mission_attributes():
    mission = cellsar.Mission.default(60.0, horizon_s=200.0)
    assert mission.horizon_s == 200.0 and mission.params["horizon_s"] == 200.0
    assert mission.slots == 400
    assert mission.landmarks[1]["y_m"] - mission.landmarks[0]["y_m"] == 60.0
    assert set(mission.landmarks[0]) == {"x_m", "y_m", "from_s", "to_s"}
    assert mission.slot_landmark.shape == (400,) and mission.slot_landmark[0] == 0
    again = cellsar.Mission.from_dict(mission.to_dict())
    assert again == mission
    assert cellsar.Mission.from_file(MISSIONS / "default-30m.toml").params == cellsar.Mission.default().params
    changed = mission.with_params(d_min_m=25.0)
    assert changed.d_min_m == 25.0 and mission.d_min_m == 20.0
    with pytest.raises(AttributeError):
        mission.horizon_s = 1.0
    assert "horizon_s" in mission.to_toml()


def test_jerk_limit_and_margins_are_mission_parameters():
    """The vehicle limits travel as the mission's parameters: the plan keeps the jerk limit and
    the acceleration margin (measured on its columns), and its summary reports them."""
    mission = cellsar.Mission.default(30.0, horizon_s=60.0).with_params(
        max_jerk_mps3=10.0, accel_margin_pct=10.0)
    assert mission.params["max_jerk_mps3"] == 10.0 and mission.params["accel_margin_pct"] == 10.0
    plan = cellsar.plan(mission, resolution="paper")
    assert plan.summary["jerk"]["jerk_limit_mps3"] == 10.0
    assert np.nanmax(plan.jerk_mps3) <= 10.0 * (1 + 1e-9)
    assert np.nanmax(plan.accel_mps2) <= 0.9 * mission.params["max_accel_mps2"] * (1 + 1e-9)
    assert plan.summary["margins"]["accel_room_pct"] >= 10.0 - 1e-6
    assert mission.with_params(max_jerk_mps3=None).params["max_jerk_mps3"] is None
    with pytest.raises(cellsar.MissionError, match="max_jerk_mps3"):
        mission.with_params(max_jerk_mps3=-1.0)
    with pytest.raises(cellsar.MissionError, match="accel_margin_pct"):
        mission.with_params(accel_margin_pct=60.0)
