"""A study on a Dask cluster of separate processes, as on separate hosts: `dask scheduler` and
two `dask worker`s started here, the study given the scheduler's address; one worker is killed
in the middle of the study, which completes on the other with every run once."""

import json
import os
import signal
import subprocess
import time

from cellsar import study
from conftest import BIN, rows, thread_env


def wait_for(predicate, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


def test_scheduler_and_two_workers_one_killed(plan_study, tmp_path):
    path = plan_study(realisations=10, spacings=(20, 40))
    ids = {r.run_id for r in study.load(path).runs()}
    sched_file = tmp_path / "scheduler.json"
    env = thread_env()
    procs = []

    def start(*args, log):
        p = subprocess.Popen(
            [str(BIN / "dask"), *args],
            env=env,
            stdout=open(tmp_path / log, "w"),
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        procs.append(p)
        return p

    try:
        start(
            "scheduler", "--host", "127.0.0.1", "--port", "0", "--dashboard-address", ":0",
            "--scheduler-file", str(sched_file), log="scheduler.log",
        )
        wait_for(sched_file.exists, 60, "the scheduler file")
        time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        workers = [
            start(
                "worker", address, "--nworkers", "1", "--nthreads", "1", "--no-nanny",
                "--host", "127.0.0.1", "--dashboard-address", ":0", log=f"worker{i}.log",
            )
            for i in range(2)
        ]
        from distributed import Client

        with Client(address, timeout=30) as c:
            c.wait_for_workers(2, timeout=60)
        out = tmp_path / "out"
        run = subprocess.Popen(
            [str(BIN / "cellsar-study"), str(path), "--out", str(out), "--scheduler", address, "--quiet"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        procs.append(run)
        victim = f":{workers[0].pid}"
        wait_for(
            lambda: (out / "results.csv").exists() and any(r["worker"].endswith(victim) for r in rows(out)),
            120,
            "a run on the first worker",
        )
        os.killpg(workers[0].pid, signal.SIGKILL)
        killed_at = len(rows(out))
        stdout, stderr = run.communicate(timeout=300)
        assert run.returncode == 0, stderr
        got = rows(out)
        assert sorted(r["run_id"] for r in got) == sorted(ids), "a run lost or duplicated"
        assert all(r["status"] == "ok" for r in got), [r["error"] for r in got]
        assert "20 runs, 0 finished before, 20 run now (0 failed)" in stdout
        # the runs finished after the kill ran on the survivor
        assert killed_at < 20
        assert not any(r["worker"].endswith(victim) for r in got[killed_at + 1 :])
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=30)


def test_unreachable_scheduler_is_refused_naming_it(plan_study, tmp_path):
    """A scheduler address where nothing answers: exit 2 within the given time-out, the message
    naming the flag and the address; a non-positive time-out is refused naming its flag."""
    import socket

    from conftest import cli

    with socket.socket() as s:  # a loopback port that was free a moment ago: nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    path = plan_study(realisations=1, spacings=(20,))
    t0 = time.monotonic()
    p = cli(path, "--out", tmp_path / "out", "--scheduler", address,
            "--scheduler-timeout-s", "2", "--quiet", check=False)
    elapsed = time.monotonic() - t0
    assert p.returncode == 2, p.stderr
    assert "--scheduler" in p.stderr and address in p.stderr and "2 s" in p.stderr, p.stderr
    assert elapsed < 25, f"took {elapsed:.1f} s with a 2 s time-out"
    p = cli(path, "--out", tmp_path / "out", "--scheduler", address,
            "--scheduler-timeout-s", "0", check=False)
    assert p.returncode == 2 and "--scheduler-timeout-s" in p.stderr, p.stderr
