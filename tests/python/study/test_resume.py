"""An interrupted study resumes: the console command killed (with its local cluster) after its
first finished runs, then run again, runs only the missing runs; no run appears twice. A line
cut short by the crash is dropped, and its run run again."""

import os
import signal
import subprocess
import time

from cellsar import study
from conftest import BIN, rows


def default_sigint():
    """In a child, before it runs: SIGINT's default disposition (Python then installs its
    KeyboardInterrupt handler), whatever the test process inherited."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_interrupted_study_resumes_with_only_the_missing_runs(plan_study, tmp_path):
    path = plan_study(realisations=8, spacings=(20, 40))
    ids = {r.run_id for r in study.load(path).runs()}
    assert len(ids) == 16
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [str(BIN / "cellsar-study"), str(path), "--out", str(out), "--workers", "1", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if (out / "results.csv").exists() and len(rows(out)) >= 2:
                break
            time.sleep(0.05)
    finally:
        # the command and its cluster's processes, all at once, as a crash or Ctrl-\ would
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=30)
    before = rows(out)
    assert 2 <= len(before) < 16, f"{len(before)} runs finished before the kill"
    # a crash in the middle of a line: the partial row is not a finished run
    with open(out / "results.csv", "a") as f:
        f.write(sorted(ids - {r["run_id"] for r in before})[0] + ",0,0,20")
    p = subprocess.run(
        [str(BIN / "cellsar-study"), str(path), "--out", str(out), "--workers", "2", "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    n = len(before)
    assert f"16 runs, {n} finished before, {16 - n} run now (0 failed)" in p.stdout
    after = rows(out)
    assert sorted(r["run_id"] for r in after) == sorted(ids)
    # the rows of the first attempt are kept as they were
    assert after[:n] == before
    # a third time runs nothing
    p = subprocess.run(
        [str(BIN / "cellsar-study"), str(path), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert "16 runs, 16 finished before, 0 run now" in p.stdout
    assert rows(out) == after


def test_table_of_another_study_refused(plan_study, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text("run_id,colour\n")
    p = subprocess.run(
        [str(BIN / "cellsar-study"), str(plan_study()), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 2
    assert "results.csv: its columns are not this study's" in p.stderr


def test_ctrl_c_leaves_a_complete_table(plan_study, tmp_path):
    import pyarrow.parquet as pq

    path = plan_study(realisations=8, spacings=(20, 40))
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [str(BIN / "cellsar-study"), str(path), "--out", str(out), "--workers", "1", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # SIGINT as a terminal delivers it, also where the tests run with it ignored
        # (`nohup ... &`), which a child would inherit
        preexec_fn=default_sigint,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if (out / "results.csv").exists() and len(rows(out)) >= 1:
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "run the same command again to resume" in stderr
    done = rows(out)
    assert 1 <= len(done) < 16
    # the Parquet table holds every finished run
    assert sorted(pq.read_table(out / "results.parquet").column("run_id").to_pylist()) == sorted(
        r["run_id"] for r in done
    )
