"""The packaged FMUs: fmpy validation, archive entries, exported symbols."""

import inspect
import shutil
import subprocess
import zipfile

import pytest
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from conftest import VERSIONS, fmu_path

MODELS = ["CellsarPlanner", "LandmarkMover"]
PLATFORM = {"fmi2": "linux64", "fmi3": "x86_64-linux"}


@pytest.mark.parametrize("model", MODELS)
def test_fmpy_validate_finds_no_problems(version, model):
    assert validate_fmu(str(fmu_path(version, model))) == []


@pytest.mark.parametrize("model", MODELS)
def test_archive_has_only_the_expected_entries(version, model):
    with zipfile.ZipFile(fmu_path(version, model)) as z:
        names = sorted(z.namelist())
        assert z.testzip() is None
    expected = ["modelDescription.xml", f"binaries/{PLATFORM[version]}/{model}.so"]
    if model == "CellsarPlanner":
        expected.append("resources/default_mission.toml")
    assert names == sorted(expected)


def test_model_description_basics(version):
    md = read_model_description(str(fmu_path(version)))
    assert md.fmiVersion == ("2.0" if version == "fmi2" else "3.0")
    cs = md.coSimulation
    assert cs.modelIdentifier == "CellsarPlanner"
    assert cs.canHandleVariableCommunicationStepSize
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    names = {v.name for v in md.modelVariables}
    for n in ["x_m", "y_m", "speed_mps", "heading_rad", "power_w", "energy_j", "xc_m", "yc_m",
              "landmark_x_m", "landmark_y_m", "in_view", "range_resolution_m",
              "azimuth_resolution_m", "landmark_x_in_m", "landmark_y_in_m", "mission_file",
              "bandwidth_hz", "horizon_s", "sensing_radius_m"]:
        assert n in names, n
    if version == "fmi2":
        assert {"start_m[1]", "start_m[2]", "bs_m[1]", "bs_m[2]"} <= names
    else:
        assert {"start_m", "bs_m", "time"} <= names
    # the default parameters as start values
    start = {v.name: v.start for v in md.modelVariables}
    assert float(start["bandwidth_hz"]) == 150e6
    assert float(start["altitude_m"]) == 1000.0
    assert start["mission_file"] == "default_mission.toml"


@pytest.mark.skipif(shutil.which("nm") is None, reason="nm (binutils) not installed")
def test_only_fmi_symbols_are_exported(tmp_path):
    # Both FMUs carry the same library; it exports exactly the functions fmpy looks up.
    expected = set()
    for cls, prefix in [(FMU2Slave, "fmi2"), (FMU3Slave, "fmi3")]:
        expected |= {n for n, _ in inspect.getmembers(cls) if n.startswith(prefix)}
    for version in VERSIONS:
        with zipfile.ZipFile(fmu_path(version)) as z:
            so = z.extract(f"binaries/{PLATFORM[version]}/CellsarPlanner.so", tmp_path / version)
        out = subprocess.run(["nm", "-D", "--defined-only", so], check=True,
                             capture_output=True, text=True).stdout
        symbols = {line.split()[-1] for line in out.splitlines() if line.strip()}
        assert symbols == expected, sorted(symbols ^ expected)


@pytest.mark.skipif(shutil.which("nm") is None, reason="nm (binutils) not installed")
def test_library_cannot_start_threads(tmp_path):
    """No thread can outlive FreeInstance: the library does not even import pthread_create."""
    with zipfile.ZipFile(fmu_path("fmi2")) as z:
        so = z.extract("binaries/linux64/CellsarPlanner.so", tmp_path)
    out = subprocess.run(["nm", "-D", "--undefined-only", so], check=True,
                         capture_output=True, text=True).stdout
    imported = {line.split()[-1].split("@")[0] for line in out.splitlines() if line.strip()}
    assert "pthread_create" not in imported
    assert "malloc" in imported or "calloc" in imported  # the listing is real
