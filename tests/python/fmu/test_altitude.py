"""Free-altitude missions (`altitude = "free"`) through the planner FMU: the outputs `z_m` and
`climb_mps` at every slot time are the `z_m` and `climb_mps` of `cellsar-planner plan`'s
trajectory.csv for the same mission and options, in both FMI versions; a fixed mission flies
its one altitude."""

import csv
from pathlib import Path

import pytest
from fmpy import read_model_description

from conftest import Fmu, fmu_path
from test_simulation import cli_plan

SLOT_S = 0.5
STOP_S = 100.0
# the fixed altitude (1000 m) cannot fly it; with the altitude free down to 800 m it can
ONLY_LOWER = (Path(__file__).resolve().parents[3] / "missions" / "only-a-lower-altitude.toml").read_text()


def test_altitude_outputs_are_described(version):
    md = read_model_description(str(fmu_path(version)))
    by_name = {v.name: v for v in md.modelVariables}
    for name, unit in [("z_m", "m"), ("climb_mps", "m/s")]:
        v = by_name[name]
        assert v.causality == "output", name
        assert v.type == ("Real" if version == "fmi2" else "Float64"), name
        assert v.unit == unit, name


def test_a_free_mission_flies_the_cli_plans_altitudes(version, tmp_path):
    mission = tmp_path / "only-lower.toml"
    mission.write_text(ONLY_LOWER)
    out = tmp_path / "plan"
    p = cli_plan(mission, out, ["--resolution", "paper"])
    assert p.returncode == 0, p.stderr
    with open(out / "trajectory.csv", newline="") as fh:
        ref = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    f = Fmu(version)
    f.instantiate()
    f.init(stop=STOP_S, strings={"mission_file": str(mission), "resolution": "paper"})
    assert f.get("z_m") == ref[0]["z_m"] == 1000.0
    for k in range(1, int(round(STOP_S / SLOT_S)) + 1):
        f.step(SLOT_S, t=(k - 1) * SLOT_S)
        r = ref[k]
        assert abs(f.get("x_m") - r["x_m"]) <= 1e-6, k
        assert f.get("z_m") == pytest.approx(r["z_m"], abs=1e-6), k
        assert f.get("climb_mps") == pytest.approx(r["climb_mps"], abs=1e-6), k
        assert 800.0 - 1e-9 <= f.get("z_m") <= 1000.0 + 1e-9, k
        assert -5.0 - 1e-9 <= f.get("climb_mps") <= 3.0 + 1e-9, k
    assert min(r["z_m"] for r in ref) < 900.0
    assert f.get("slots_out_of_view") == 0
    f.unload()


def test_a_fixed_mission_flies_one_altitude(version, short_mission):
    f = Fmu(version)
    f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    for k in range(4):
        f.step(SLOT_S, t=k * SLOT_S)
        assert f.get("z_m") == 1000.0
        assert f.get("climb_mps") == 0.0
    f.unload()
