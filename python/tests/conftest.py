"""Shared fixtures: the repository root, the `cellsar-planner` binary (located by the Rust
harness, tests/tests/python_package.rs, through CELLSAR_PLANNER) and CLI runs."""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MISSIONS = ROOT / "missions"


@pytest.fixture(scope="session")
def planner_cli():
    path = os.environ.get("CELLSAR_PLANNER")
    if not path:
        pytest.fail(
            "CELLSAR_PLANNER is not set: run these tests through `cargo test -p cellsar-tests "
            "--test python_package`, or set it to a cellsar-planner binary"
        )
    return Path(path)


@pytest.fixture(scope="session")
def cli_plan(planner_cli, tmp_path_factory):
    """Runs `cellsar-planner plan MISSION --out DIR [ARGS]` once per (mission, args); returns the
    directory."""
    cache = {}

    def run(mission_file, *args):
        key = (str(mission_file), args)
        if key not in cache:
            out = tmp_path_factory.mktemp("cli")
            subprocess.run(
                [str(planner_cli), "plan", str(mission_file), "--out", str(out), *args],
                check=True,
                capture_output=True,
            )
            cache[key] = out
        return cache[key]

    return run


def read_summary(directory):
    return json.loads((directory / "summary.json").read_text())
