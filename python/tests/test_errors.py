"""Bad missions, options and starts raise Python exceptions that name the field, slot or file."""

import pytest

import cellsar


def test_exception_hierarchy():
    assert issubclass(cellsar.MissionError, ValueError)
    assert issubclass(cellsar.InfeasibleMission, cellsar.PlanError)


@pytest.mark.parametrize(
    "params, field",
    [({"horizon_s": -1.0}, "horizon_s"), ({"d_min_m": float("nan")}, "d_min_m"),
     ({"observation_angle_rad": 2.0}, "observation_angle_rad")],
)
def test_bad_parameter_names_the_field(params, field):
    with pytest.raises(cellsar.MissionError, match=field):
        cellsar.Mission.default(30.0, **params)


def test_unknown_field_is_named():
    with pytest.raises(cellsar.MissionError, match="horizon_sec"):
        cellsar.Mission.from_dict({"params": {"horizon_sec": 10}, "landmarks": {"preset": "default"}})
    with pytest.raises(cellsar.MissionError, match="horizon_sec"):
        cellsar.Mission.default(30.0, horizon_sec=10.0)
    with pytest.raises(cellsar.MissionError, match="landmarks"):
        cellsar.Mission.from_dict({"params": {}})
    with pytest.raises(cellsar.MissionError, match="dict"):
        cellsar.Mission.from_dict([1, 2])


def test_bad_file_is_named(tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(cellsar.MissionError, match="nope.toml"):
        cellsar.Mission.from_file(missing)
    broken = tmp_path / "broken.toml"
    broken.write_text("[landmarks]\npreset = 'nowhere'\n")
    with pytest.raises(cellsar.MissionError, match="broken.toml"):
        cellsar.Mission.from_file(broken)


def test_landmark_window_error_names_it():
    with pytest.raises(cellsar.MissionError):
        cellsar.Mission.from_dict(
            {"landmarks": {"points": [{"x_m": 0, "y_m": 0, "from_s": 20, "to_s": 10}]}}
        )


def test_infeasible_mission_names_the_first_slot():
    far = cellsar.Mission.from_dict(
        {"params": {"horizon_s": 20.0},
         "landmarks": {"points": [{"x_m": 20000.0, "y_m": 0.0, "from_s": 0.0, "to_s": 10.0}]}}
    )
    with pytest.raises(cellsar.InfeasibleMission, match="slot") as caught:
        cellsar.plan(far)
    assert caught.value.slot >= 1
    assert caught.value.t_s == pytest.approx(caught.value.slot * far.slot_s)
    assert caught.value.reason and caught.value.reason in str(caught.value)


def test_bad_options():
    mission = cellsar.Mission.default(30.0)
    with pytest.raises(ValueError, match="scheme"):
        cellsar.plan(mission, scheme="fastest")
    with pytest.raises(ValueError, match="resolution"):
        cellsar.plan(mission, resolution="fine")
    with pytest.raises(ValueError, match="time_limit_s"):
        cellsar.plan(mission, time_limit_s=-1.0)
    with pytest.raises(ValueError, match="tolerance"):
        cellsar.plan(mission, tolerance=0.0)
    with pytest.raises(ValueError, match="init"):
        cellsar.plan(mission, init=([0.0, 1.0], [0.0, 1.0]))
    with pytest.raises(ValueError, match="init"):
        cellsar.plan(mission, init=42)
    # the best-effort options where the plan would ignore them: the library's rule and message
    with pytest.raises(
        ValueError, match="^strict_resolution applies to resolution general only, not to paper$"
    ):
        cellsar.plan(mission, resolution="paper", strict_resolution=True)
    with pytest.raises(ValueError, match="max_extra_energy_pct applies to resolution general only"):
        cellsar.plan(mission, scheme="baseline", max_extra_energy_pct=5.0)
    with pytest.raises(ValueError, match="applies to scheme exact only, not to baseline-exact"):
        cellsar.plan(mission, scheme="baseline-exact", resolution="general", strict_resolution=True)
    # both together: a strict plan would ignore the cap
    with pytest.raises(
        ValueError,
        match="^strict_resolution and max_extra_energy_pct exclude each other: a strict plan has no energy cap$",
    ):
        cellsar.plan(mission, strict_resolution=True, max_extra_energy_pct=5.0)


def test_progress_exception_stops_the_plan():
    def fail(record):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        cellsar.plan(cellsar.Mission.default(30.0), progress=fail)


def test_mistyped_field_is_named():
    with pytest.raises(cellsar.MissionError, match="params.horizon_s"):
        cellsar.Mission.from_dict({"params": {"horizon_s": "long"}, "landmarks": {"preset": "default"}})
