"""evaluate, power_w and dmin against closed forms on hand-made paths."""

import math

import numpy as np
import pytest

import cellsar

# Table II's defaults (planner::Params::default).
P0, U_TIP, P1, V0 = 3.4, 60.0, 118.0, 5.4
PARASITE = 0.5 * 0.3 * 1.225 * 0.02 * 0.5


def power(v):
    """P(V) of the rotary-wing model, written out."""
    induced = math.sqrt(math.sqrt(1 + v**4 / (4 * V0**4)) - v**2 / (2 * V0**2))
    return P0 * (1 + 3 * v**2 / U_TIP**2) + P1 * induced + PARASITE * v**3


def test_power_w_closed_form():
    assert cellsar.power_w(0.0) == pytest.approx(P0 + P1, rel=1e-12)
    speeds = np.array([[0.0, 5.0], [12.5, 30.0]])
    got = cellsar.power_w(speeds)
    assert got.shape == speeds.shape
    np.testing.assert_allclose(got, np.vectorize(power)(speeds), rtol=1e-10)
    assert cellsar.power_w([10.0]).tolist() == pytest.approx([power(10.0)], rel=1e-10)
    heavy = cellsar.Mission.default(30.0, induced_power_w=200.0)
    assert cellsar.power_w(0.0, heavy) == pytest.approx(P0 + 200.0, rel=1e-12)


def test_evaluate_hover():
    mission = cellsar.Mission.default(30.0)
    n = mission.slots
    x = np.full(n, mission.start_m[0])
    y = np.full(n, mission.start_m[1])
    ev = cellsar.evaluate(mission, x, y)
    assert ev["energy_j"] == pytest.approx(mission.horizon_s * (P0 + P1), rel=1e-12)
    assert ev["length_m"] == 0.0 and ev["max_speed_mps"] == 0.0
    assert ev["feasible"] is False and ev["slots_out_of_view"] > 0
    assert ev["violations"]["min_speed_mps"] > 0


def test_evaluate_straight_line():
    mission = cellsar.Mission.default(30.0)
    v = 10.0
    t = np.arange(mission.slots + 1) * mission.slot_s
    x = mission.start_m[0] + v * t
    y = np.full_like(t, mission.start_m[1])
    ev = cellsar.evaluate(mission, x, y)  # slots + 1 points: the first is the start
    assert ev["energy_j"] == pytest.approx(mission.horizon_s * power(v), rel=1e-12)
    assert ev["length_m"] == pytest.approx(v * mission.horizon_s, rel=1e-12)
    assert ev["min_speed_mps"] == pytest.approx(v) and ev["max_speed_mps"] == pytest.approx(v)
    cols = ev["columns"]
    np.testing.assert_allclose(cols["speed_mps"][1:], v)
    np.testing.assert_allclose(cols["heading_rad"][1:], 0.0, atol=1e-12)
    # right-looking: the sensing centre lies H tan(eta) to the right of the heading (-y here)
    offset = mission.altitude_m * math.tan(mission.observation_angle_rad)
    np.testing.assert_allclose(cols["xc_m"][1:], x[1:])
    np.testing.assert_allclose(cols["yc_m"][1:], y[1:] - offset)
    np.testing.assert_allclose(cols["energy_j"], power(v) * t, rtol=1e-12)


def test_evaluate_agrees_with_a_plan():
    mission = cellsar.Mission.default(30.0)
    plan = cellsar.plan(mission, resolution="paper")
    ev = cellsar.evaluate(mission, plan.x_m, plan.y_m)
    assert ev["energy_j"] == plan.summary["energy_j"]
    assert ev["feasible"]
    for name in plan.columns:
        np.testing.assert_array_equal(ev["columns"][name], getattr(plan, name), err_msg=name)


def test_evaluate_rejects_bad_paths():
    mission = cellsar.Mission.default(30.0)
    with pytest.raises(ValueError, match="slots"):
        cellsar.evaluate(mission, [0.0, 1.0], [0.0, 1.0])
    with pytest.raises(ValueError, match="non-finite"):
        cellsar.evaluate(mission, np.full(mission.slots, np.nan), np.zeros(mission.slots))


def test_dmin():
    # N = 2: the mean distance between two uniform points in a disk is 128 R / (45 pi)
    assert cellsar.dmin(1.0, 2) == pytest.approx(128 / (45 * math.pi), rel=1e-6)
    exact = cellsar.dmin(5000.0, 100)
    mc = cellsar.dmin(5000.0, 100, method="monte_carlo", trials=4000, seed=3)
    assert mc == pytest.approx(exact, rel=0.1)
    assert cellsar.dmin(5000.0, 100, method="printed") != exact
    with pytest.raises(ValueError, match="objects"):
        cellsar.dmin(5000.0, 1)
    with pytest.raises(ValueError, match="method"):
        cellsar.dmin(5000.0, 10, method="guess")
