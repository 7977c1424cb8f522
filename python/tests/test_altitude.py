"""Free-altitude missions (``altitude = "free"``) through the package: the ``exact`` scheme plans
an altitude per slot (``z_m``, ``climb_mps``) within the bounds and rates, the same plan as the
CLI's; ``paper`` plans one by the paper's alternation; ``baseline`` refuses the mission with the
library's message."""

import numpy as np
import pytest

import cellsar
from conftest import read_summary

LOW_M, HIGH_M = 600.0, 1200.0


def free_mission():
    """The paper's 200 m mission with its altitude free within [600, 1200] m."""
    return cellsar.Mission.default(
        200.0, altitude="free", min_altitude_m=LOW_M, max_altitude_m=HIGH_M
    )


def test_a_free_mission_gets_an_altitude_per_slot_within_bounds_and_rates(cli_plan, tmp_path):
    mission = free_mission()
    params = mission.params
    plan = cellsar.plan(mission, resolution="paper")
    assert plan.feasible
    z = plan.z_m
    climb = plan.climb_mps
    assert len(z) == mission.slots + 1
    # the start row: the start altitude, no climb rate
    assert z[0] == params["altitude_m"]
    assert np.isnan(climb[0])
    slot_s = params["slot_s"]
    for t in range(1, mission.slots + 1):
        assert LOW_M <= z[t] <= HIGH_M, (t, z[t])
        rate = (z[t] - z[t - 1]) / slot_s
        assert climb[t] == pytest.approx(rate, rel=1e-9, abs=1e-9), t
        assert rate <= params["max_climb_mps"] + 1e-9, (t, rate)
        assert -rate <= params["max_descent_mps"] + 1e-9, (t, rate)
    # the altitude is used: lower than the fixed 1000 m somewhere, and cheaper than the fixed plan
    assert z.min() < 950.0
    fixed = cellsar.plan(cellsar.Mission.default(200.0), resolution="paper")
    assert plan.total_energy_j < fixed.total_energy_j - 100.0
    assert np.all(fixed.z_m == params["altitude_m"])

    # the same plan as `cellsar-planner plan` of the same mission file
    path = tmp_path / "free.toml"
    path.write_text(mission.to_toml())
    out = cli_plan(path, "--resolution", "paper")
    assert plan.total_energy_j == pytest.approx(read_summary(out)["energy_j"], rel=1e-9)
    table = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    np.testing.assert_allclose(z, table["z_m"], rtol=1e-9)
    np.testing.assert_allclose(climb, table["climb_mps"], rtol=1e-9, atol=1e-12, equal_nan=True)


def test_the_scheme_at_one_altitude_refuses_a_free_mission():
    with pytest.raises(cellsar.PlanError, match=r'`altitude` = "free".*scheme baseline'):
        cellsar.plan(free_mission(), scheme="baseline")


def test_the_paper_scheme_plans_a_free_mission_within_its_bounds():
    """The paper's alternation (scheme ``paper``) plans an altitude per slot, within the
    mission's bounds, starting at ``altitude_m``."""
    mission = cellsar.Mission.default(
        200.0, horizon_s=60.0, altitude="free", min_altitude_m=LOW_M, max_altitude_m=HIGH_M
    )
    plan = cellsar.plan(mission, scheme="paper", resolution="paper")
    z = np.asarray(plan.z_m)
    assert len(z) > 1
    assert z[0] == pytest.approx(mission.params["altitude_m"])
    assert z.min() >= LOW_M - 1e-6 and z.max() <= HIGH_M + 1e-6


def test_the_radar_flies_a_free_plan_at_its_altitudes():
    """``cellsar.radar.simulate`` flies the plan's altitude per slot: every pulse's z is the
    profile interpolated linearly between slot ends (the start row at ``altitude_m``)."""
    from conftest import ROOT

    mission = cellsar.Mission.default(
        30.0, horizon_s=25.0, altitude="free", min_altitude_m=LOW_M, max_altitude_m=HIGH_M
    )
    plan = cellsar.plan(mission)
    rec = cellsar.radar.simulate(mission, plan, ROOT / "tests" / "data" / "small-scene.toml")
    p = rec.pulses
    assert len(p) == sum(iq.shape[0] for iq in rec.iq)
    slot_ends_s = np.arange(len(plan.z_m)) * mission.params["slot_s"]
    expected = np.interp(p["t_s"], slot_ends_s, plan.z_m)
    assert np.abs(p["z_m"] - expected).max() < 1e-6
    # the profile is flown, not the mission's altitude_m
    assert np.ptp(p["z_m"]) > 1.0, (p["z_m"].min(), p["z_m"].max())
