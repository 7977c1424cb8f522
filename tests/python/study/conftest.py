"""Shared helpers of the study tests: study files written into a temporary directory, and the
`cellsar-study` console command of the test environment (installed with the package by
tests/tests/study.rs)."""

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
MISSION = ROOT / "missions" / "default-30m.toml"
SCENE = ROOT / "radar-sim" / "scenes" / "default.toml"
BIN = Path(sys.executable).parent

#: A short plan-only study: the random preset (gaps up to spacing_m), 20 s horizon, the
#: paper's scheme: each plan well under a second.
PLAN_STUDY = f"""
[study]
name = "small"
mission = "{MISSION}"
mode = "plan"
realisations = {{realisations}}
realisation_seeds = ["landmarks.seed"]
retries = 2

[run]
scheme = "paper"

[set]
"params.horizon_s" = 20
"landmarks.preset" = "random"

[grid]
"landmarks.spacing_m" = {{spacings}}
"""


@pytest.fixture
def plan_study(tmp_path):
    """Writes the plan-only study with `realisations` and `spacings`; returns its path."""

    def write(realisations=2, spacings=(20, 40), name="study.toml"):
        path = tmp_path / name
        path.write_text(
            PLAN_STUDY.replace("{realisations}", str(realisations)).replace(
                "{spacings}", "[" + ", ".join(str(s) for s in spacings) + "]"
            )
        )
        return path

    return write


def cli(*args, check=True, **kwargs):
    """Runs `cellsar-study ARGS`; returns the CompletedProcess."""
    p = subprocess.run(
        [str(BIN / "cellsar-study"), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
        **kwargs,
    )
    if check and p.returncode != 0:
        raise AssertionError(f"cellsar-study {args} failed ({p.returncode}):\n{p.stderr}")
    return p


def rows(out):
    """The rows of out/results.csv as dicts."""
    with open(Path(out) / "results.csv", newline="") as f:
        return list(csv.DictReader(f))


def thread_env():
    """The environment for worker processes: one native thread each."""
    env = dict(os.environ)
    for k in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[k] = "1"
    return env


SHM = Path("/dev/shm")


@pytest.fixture(scope="session", autouse=True)
def remove_leaked_semaphores():
    """Removes the POSIX semaphores (`/dev/shm/sem.mp-*`) that appeared during the session.

    Python's multiprocessing (Dask's local cluster, `dask worker`'s nanny) names its semaphores
    there, and its resource tracker unlinks them when the process that made them ends. The
    tests that SIGKILL a process group kill that tracker too, so those names would outlive the
    test run. Only names absent at the start are removed."""
    before = set(SHM.glob("sem.mp-*")) if SHM.is_dir() else set()
    yield
    if SHM.is_dir():
        for p in set(SHM.glob("sem.mp-*")) - before:
            try:
                p.unlink()
            except OSError:
                pass
