"""The study file: its validation (every refusal names the field), the runs it expands into
and their identities; the interval formulas against closed forms and tables."""

import math

import cellsar
import pytest
from cellsar import study
from cellsar.study_stats import mean_interval, t_quantile, wilson
from conftest import MISSION, cli


def write(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(f'[study]\nmission = "{MISSION}"\n' + text)
    return path


@pytest.mark.parametrize(
    "text, field",
    [
        ("realisations = 0\n", "`study.realisations`"),
        ('mode = "fly"\n', "`study.mode`"),
        ("colour = 1\n", "`study.colour`"),
        ('[grid]\n"landmarks.spacng_m" = [20]\n', "`landmarks.spacng_m`"),
        ('[grid]\n"params.bandwidht_hz" = [1e8]\n', "`params.bandwidht_hz`"),
        ('[grid]\n"params.bandwidth_hz" = [-1.0]\n', "`bandwidth_hz`"),
        ('[grid]\n"landmarks.spacing_m" = []\n', "`grid.landmarks.spacing_m`"),
        ('[grid]\n"wings.span_m" = [1]\n', "`grid.wings.span_m`"),
        ('[grid]\n"radar.tx_power_w" = [1]\n', "`grid.radar.tx_power_w`"),
        (
            'mode = "closed-loop"\n[grid]\n"radar.tx_powr_w" = [1.0]\n',
            "tx_powr_w",
        ),
        (
            'mode = "closed-loop"\n[grid]\n"objects.radius_m" = [-5.0]\n',
            "radius_m",
        ),
        ('[random]\n"params.altitude_m" = { gauss = [1, 2] }\n', "`random.params.altitude_m.gauss`"),
        ('[random]\n"params.altitude_m" = { uniform = [2, 1] }\n', "`random.params.altitude_m.uniform`"),
        ('[run]\nschema = "exact"\n', "`run.schema`"),
        ("[bogus]\n", "`bogus`"),
        (
            'realisation_seeds = ["landmarks.seed"]\n[grid]\n"landmarks.seed" = [1]\n',
            "`landmarks.seed`",
        ),
    ],
)
def test_malformed_study_refused_naming_the_field(tmp_path, text, field):
    path = write(tmp_path, text)
    with pytest.raises(study.StudyError) as e:
        study.load(path)
    assert field in str(e.value), str(e.value)
    assert str(path) in str(e.value)
    # the console command refuses it too, with the same message and exit status 2
    p = cli(path, "--out", tmp_path / "out", check=False)
    assert p.returncode == 2
    assert field in p.stderr
    assert not (tmp_path / "out").exists()


def test_missing_mission_file_named(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[study]\nmission = "nowhere.toml"\n')
    with pytest.raises(study.StudyError, match="study.mission.*nowhere.toml"):
        study.load(path)


def test_runs_grid_times_realisations_with_stable_identities(plan_study, tmp_path):
    s = study.load(plan_study(realisations=3, spacings=(10, 20, 30)))
    runs = s.runs()
    assert len(runs) == 9
    assert len({r.run_id for r in runs}) == 9
    assert [r.seed for r in runs] == [0, 0, 0, 1, 1, 1, 2, 2, 2]
    for r in runs:
        assert r.values == {"landmarks.spacing_m": r.mission["landmarks"]["spacing_m"], "landmarks.seed": r.seed}
        assert r.mission["landmarks"]["preset"] == "random"
        assert r.mission["params"]["horizon_s"] == 20
        assert r.options == {"scheme": "paper"}
    # the same study file gives the same identities; another base mission other ones
    again = study.load(plan_study(realisations=3, spacings=(10, 20, 30), name="again.toml"))
    assert [r.run_id for r in again.runs()] == [r.run_id for r in runs]
    other = plan_study(realisations=3, spacings=(10, 20, 30), name="other.toml")
    other.write_text(other.read_text().replace('"params.horizon_s" = 20', '"params.horizon_s" = 30'))
    assert not {r.run_id for r in study.load(other).runs()} & {r.run_id for r in runs}


def test_random_draws_reproducible_and_within_bounds(tmp_path):
    path = write(
        tmp_path,
        'realisations = 50\nseed = 3\n[random]\n"params.altitude_m" = { uniform = [80, 120] }\n'
        '"landmarks.seed" = { integers = [0, 5] }\n"params.bandwidth_hz" = { log_uniform = [5e7, 2e8] }\n',
    )
    a, b = study.load(path).runs(), study.load(path).runs()
    assert [r.values for r in a] == [r.values for r in b]
    alt = [r.values["params.altitude_m"] for r in a]
    assert all(80 <= h <= 120 for h in alt) and len(set(alt)) == 50
    assert {r.values["landmarks.seed"] for r in a} <= set(range(6))
    assert all(5e7 <= r.values["params.bandwidth_hz"] <= 2e8 for r in a)
    # every run's mission is a valid mission with the drawn value
    m = cellsar.Mission.from_dict(a[7].mission)
    assert m.altitude_m == pytest.approx(a[7].values["params.altitude_m"])


def test_student_t_quantiles_match_the_tables():
    for df, q in [(1, 12.7062), (2, 4.3027), (4, 2.7764), (9, 2.2622), (29, 2.0452), (199, 1.9720)]:
        assert t_quantile(0.975, df) == pytest.approx(q, abs=1e-4)
    # large df: the normal quantile
    assert t_quantile(0.975, 1e7) == pytest.approx(1.959964, abs=1e-5)


def test_mean_interval_closed_form():
    mean, lo, hi, n = mean_interval([1.0, 2.0, 3.0, float("nan")])
    assert (mean, n) == (2.0, 3)
    half = 4.302652729911275 * 1.0 / math.sqrt(3)
    assert lo == pytest.approx(2.0 - half) and hi == pytest.approx(2.0 + half)


def test_wilson_interval_closed_form():
    p, lo, hi = wilson(0, 10)
    z = 1.959963984540054
    assert p == 0.0 and lo == 0.0 and hi == pytest.approx(z * z / (10 + z * z))
    p, lo, hi = wilson(5, 10)
    assert p == 0.5 and lo + hi == pytest.approx(1.0)
    assert math.isnan(wilson(0, 0)[0])


def test_shipped_studies_load():
    from conftest import ROOT

    fig11 = study.load(ROOT / "studies" / "fig11.toml")
    runs = fig11.runs()
    assert (fig11.mode, fig11.realisations, len(runs)) == ("plan", 200, 800)
    # realisation k is the random preset with seed k, as `cellsar-planner reproduce` plans it
    r = runs[4 * 7 + 1]
    assert r.values == {"run.scheme": "paper", "landmarks.seed": 7}
    assert r.mission["landmarks"] == {"preset": "random", "spacing_m": 100, "seed": 7}
    assert r.options == {"resolution": "paper", "dynamics": "paper", "scheme": "paper"}
    # the mission reproduce plans for realisation 7: the random preset alone, default parameters
    ours = cellsar.Mission.from_dict(r.mission)
    theirs = cellsar.Mission.from_dict({"landmarks": {"preset": "random", "spacing_m": 100, "seed": 7}})
    assert (ours.params, ours.landmarks) == (theirs.params, theirs.landmarks)
    assert ours.landmarks != cellsar.Mission.from_dict(runs[0].mission).landmarks
    detection = study.load(ROOT / "studies" / "detection.toml")
    runs = detection.runs()
    assert (detection.mode, len(runs)) == ("closed-loop", 200)
    assert runs[13].scene["radar"]["tx_power_w"] == 0.02 and runs[13].scene["objects"]["seed"] == 1


def test_aggregates_of_random_draws_binned(tmp_path):
    """Rows made here (energy = the drawn altitude) aggregate into 8 equal bins of the drawn
    range, each with the mean of its own rows."""
    from cellsar.study_run import empty_result
    from cellsar.study_table import Table, columns

    path = write(tmp_path, 'realisations = 40\n[random]\n"params.altitude_m" = { uniform = [80, 120] }\n')
    s = study.load(path)
    runs = s.runs()
    out = tmp_path / "out"
    table = Table(out, columns(s, runs))
    for r in runs:
        row = empty_result()
        row.update(energy_j=r.values["params.altitude_m"], feasible=r.realisation % 2 == 0)
        table.append(r, row)
    table.close()
    study.aggregate(s, out)
    import csv

    with open(out / "aggregates.csv", newline="") as f:
        agg = list(csv.DictReader(f))
    alts = sorted(r.values["params.altitude_m"] for r in runs)
    lo, width = alts[0], (alts[-1] - alts[0]) / 8
    assert len(agg) == 8
    assert sum(int(a["runs"]) for a in agg) == 40
    for a in agg:
        centre = float(a["params.altitude_m"])
        k = round((centre - lo) / width - 0.5)
        mine = [h for h in alts if min(int((h - lo) / width), 7) == k]
        assert int(a["runs"]) == len(mine)
        assert float(a["energy_j_mean"]) == pytest.approx(sum(mine) / len(mine))
    feasible = sum(int(a["runs"]) * float(a["feasible_p"]) for a in agg)
    assert feasible == pytest.approx(20)
    assert (out / "plot-energy_j-vs-params_altitude_m.png").exists()
