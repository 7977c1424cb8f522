"""A study on a local cluster of two worker processes: one row per run, each equal to the same
plan made in this process; the aggregates equal the rows' means; a closed-loop run's row
carries the radar's detections."""

import csv
import math

import cellsar
import pyarrow.parquet as pq
import pytest
from cellsar import study
from cellsar.study_stats import mean_interval
from conftest import MISSION, SCENE, cli, rows


def test_local_cluster_of_two_workers(plan_study, tmp_path):
    path = plan_study(realisations=3, spacings=(20, 40))
    out = tmp_path / "out"
    p = cli(path, "--out", out, "--workers", 2, "--quiet")
    assert "6 runs, 0 finished before, 6 run now (0 failed)" in p.stdout
    got = rows(out)
    runs = {r.run_id: r for r in study.load(path).runs()}
    assert sorted(r["run_id"] for r in got) == sorted(runs)
    # two worker processes shared the runs
    assert len({r["worker"] for r in got}) == 2
    # each row is the plan of its mission, as made here
    for row in got[:2]:
        run = runs[row["run_id"]]
        plan = cellsar.plan(cellsar.Mission.from_dict(run.mission), **run.options)
        assert float(row["energy_j"]) == pytest.approx(plan.total_energy_j, rel=1e-9)
        assert row["feasible"] == ("true" if plan.feasible else "false")
        assert row["status"] == "ok" and row["error"] == ""
    # the Parquet table holds the same rows, typed
    table = pq.read_table(out / "results.parquet").to_pylist()
    assert {r["run_id"]: r["energy_j"] for r in table} == {
        r["run_id"]: pytest.approx(float(r["energy_j"]), rel=1e-15) for r in got
    }
    assert all(isinstance(r["landmarks.spacing_m"], int) for r in table)
    # aggregates: per spacing, the mean of its three rows and the t interval
    with open(out / "aggregates.csv", newline="") as f:
        agg = {int(r["landmarks.spacing_m"]): r for r in csv.DictReader(f)}
    for s in (20, 40):
        energies = [float(r["energy_j"]) for r in got if r["landmarks.spacing_m"] == str(s)]
        mean, lo, hi, n = mean_interval(energies)
        assert n == 3
        assert float(agg[s]["energy_j_mean"]) == pytest.approx(sum(energies) / 3, rel=1e-12)
        assert float(agg[s]["energy_j_lo"]) == pytest.approx(lo) and float(agg[s]["energy_j_hi"]) == pytest.approx(hi)
        assert float(agg[s]["feasible_p"]) == sum(r["feasible"] == "true" for r in got if r["landmarks.spacing_m"] == str(s)) / 3
    assert (out / "plot-energy_j-vs-landmarks_spacing_m.png").stat().st_size > 1000
    # the aggregates are reproducible from the table alone
    (out / "aggregates.csv").unlink()
    (out / "plot-energy_j-vs-landmarks_spacing_m.png").unlink()
    cli(path, "--out", out, "--aggregate-only")
    with open(out / "aggregates.csv", newline="") as f:
        again = {int(r["landmarks.spacing_m"]): r for r in csv.DictReader(f)}
    assert again == agg
    assert (out / "plot-energy_j-vs-landmarks_spacing_m.png").exists()


def test_failed_run_is_a_row_with_its_error(tmp_path):
    # 200 m gaps in 10 s at most 30 m/s cannot be flown: an infeasible mission, not a failed study
    path = tmp_path / "s.toml"
    path.write_text(
        f'[study]\nmission = "{MISSION}"\n[run]\nscheme = "paper"\n'
        '[set]\n"params.horizon_s" = 20\n"params.max_speed_mps" = 10\n'
        '[grid]\n"landmarks.spacing_m" = [10, 400]\n'
    )
    out = tmp_path / "out"
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0") as c, Client(c) as client:
        summary = study.run(study.load(path), out, client=client)
    assert summary["failed"] == 1 and summary["ran"] == 2
    by = {r["landmarks.spacing_m"]: r for r in rows(out)}
    assert by["10"]["status"] == "ok"
    assert by["400"]["status"] == "failed"
    assert "InfeasibleMission" in by["400"]["error"]
    assert by["400"]["energy_j"] == ""


def test_closed_loop_run_has_detections(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        f'[study]\nmission = "{MISSION}"\nscene = "{SCENE}"\nmode = "closed-loop"\n'
        '[run]\nscheme = "paper"\n[set]\n"params.horizon_s" = 20\n'
        '[grid]\n"radar.tx_power_w" = [40.0]\n'
    )
    out = tmp_path / "out"
    cli(path, "--out", out, "--workers", 1, "--quiet")
    (row,) = rows(out)
    assert row["status"] == "ok", row["error"]
    assert 0.0 <= float(row["pd"]) <= 1.0
    assert 0.0 <= float(row["pd_all"]) <= 1.0
    assert float(row["strong_objects"]) > 0
    assert float(row["detected_objects"]) == round(float(row["pd"]) * float(row["strong_objects"]))
    assert math.isfinite(float(row["false_alarms"]))
    assert float(row["radar_s"]) > 0
    with open(out / "aggregates.csv", newline="") as f:
        (agg,) = list(csv.DictReader(f))
    assert float(agg["pd_p"]) == pytest.approx(float(row["pd"]))
    assert float(agg["pd_all_mean"]) == pytest.approx(float(row["pd_all"]))
