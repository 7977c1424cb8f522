"""Studies: many planned (or planned and sensed) missions from one study file, on Dask.

::

    cellsar-study STUDY.toml --out DIR                      # a local cluster, one process a core
    cellsar-study STUDY.toml --out DIR --workers 2
    cellsar-study STUDY.toml --out DIR --scheduler tcp://HOST:8786
    cellsar-study STUDY.toml --out DIR --aggregate-only     # the aggregates and plots again

The study file's format is :mod:`cellsar.study_spec`'s. Each run is one Dask task (retried by
Dask when its worker is lost); its row is appended to ``DIR/results.csv`` as it finishes and
``DIR/results.parquet`` follows, so a study stopped part way resumes with only the runs it has
not finished. The aggregates (means and 95 % intervals per swept value) and the curves are
written beside the table (:mod:`cellsar.study_stats`).

From Python::

    from cellsar import study
    s = study.load("studies/fig11.toml")
    summary = study.run(s, "out/fig11", workers=2)
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from .study_run import THREAD_ENV, execute
from .study_spec import Run, Study, StudyError, load
from .study_table import Table, columns, write_parquet

__all__ = ["Study", "StudyError", "load", "run", "aggregate", "main"]

#: Seconds between two rewrites of the Parquet table while a study runs.
PARQUET_EVERY_S = 2.0


def _failed_row(error: BaseException) -> Dict[str, Any]:
    from .study_run import empty_result

    row = empty_result()
    row["status"] = "failed"
    row["error"] = f"{type(error).__name__}: {error}"
    return row


#: How long reaching a ``--scheduler`` may take by default, seconds (Dask's own default).
SCHEDULER_TIMEOUT_S = 30.0


def _client(scheduler: Optional[str], workers: Optional[int], timeout_s: float) -> Any:
    """A Dask client: of the scheduler at ``scheduler`` (reached within ``timeout_s``), or of a
    new local cluster of ``workers`` processes (one thread each; default: one per core)."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout=timeout_s)
        except (OSError, TimeoutError, ValueError) as e:
            raise StudyError(
                f"--scheduler: cannot reach {scheduler} within {timeout_s:g} s: {e}"
            ) from None
    # worker processes inherit the environment: one native thread each
    for k in THREAD_ENV:
        os.environ[k] = "1"
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
    )
    return Client(cluster)


#: How often Dask's progress bar polls the scheduler, seconds.
PROGRESS_INTERVAL_S = 0.1


def _start_progress(futures: List[Any]) -> Any:
    """Dask's text progress bar, drawn on stderr from a thread beside the result loop; returns
    the thread."""
    import threading

    from distributed.diagnostics.progressbar import progress

    def show() -> None:
        try:
            progress(futures, notebook=False, multi=False, interval=f"{PROGRESS_INTERVAL_S}s")
        except Exception:  # the bar is decoration: never fail a study for it
            pass

    thread = threading.Thread(target=show, daemon=True, name="study-progress")
    thread.start()
    return thread


def _stop_progress(thread: Any) -> None:
    """Lets the progress bar end before the local cluster closes. The bar closes its end of the
    scheduler's feed when every run is done, and the feed ends at its next poll; closing the
    cluster before that cancels the feed mid-sleep, and the scheduler logs a CancelledError
    traceback."""
    thread.join(timeout=5.0)
    time.sleep(5 * PROGRESS_INTERVAL_S)


def run(
    study: Study,
    out: "str | Path",
    scheduler: Optional[str] = None,
    workers: Optional[int] = None,
    show_progress: bool = False,
    client: Any = None,
    scheduler_timeout_s: float = SCHEDULER_TIMEOUT_S,
) -> Dict[str, Any]:
    """Runs the runs of ``study`` not yet in ``out``'s table, then aggregates; returns counts
    (``runs``, ``skipped`` (finished before), ``ran``, ``failed``) and timings: ``cluster_s``
    (starting or reaching the cluster), ``runs_s`` (from the first submission to the last row)
    and ``elapsed_s`` (both). A ``scheduler`` not reached within ``scheduler_timeout_s`` is a
    :class:`StudyError` naming it."""
    from distributed import as_completed

    out = Path(out)
    runs = study.runs()
    cols = columns(study, runs)
    table = Table(out, cols)
    todo = [r for r in runs if r.run_id not in table.done]
    t0 = time.perf_counter()
    t_runs = t0
    failed = 0
    own = client is None
    bar = None
    try:
        if todo and own:
            client = _client(scheduler, workers, scheduler_timeout_s)
        t_runs = time.perf_counter()
        if todo:
            futures = client.map(
                execute,
                todo,
                key=[f"run-{r.run_id}" for r in todo],
                retries=study.retries,
                pure=False,
            )
            by_key = {f.key: r for f, r in zip(futures, todo)}
            if show_progress:
                bar = _start_progress(futures)
            last = time.monotonic()
            for fut in as_completed(futures):
                r: Run = by_key[fut.key]
                try:
                    row = fut.result()
                except Exception as e:  # exhausted retries: the run's row carries the error
                    row = _failed_row(e)
                failed += row["status"] != "ok"
                table.append(r, row)
                fut.release()
                if time.monotonic() - last > PARQUET_EVERY_S:
                    write_parquet(table.csv_path, table.parquet_path, cols)
                    last = time.monotonic()
    finally:
        # also on Ctrl-C: the finished runs' table is complete, the study resumes from it
        table.close()
        if own and client is not None:
            if bar is not None:
                _stop_progress(bar)
            cluster = getattr(client, "cluster", None)
            client.close()
            if cluster is not None:
                cluster.close()
    t_end = time.perf_counter()
    from .study_stats import aggregate as _aggregate

    _aggregate(study, out)
    return {
        "runs": len(runs),
        "skipped": len(runs) - len(todo),
        "ran": len(todo),
        "failed": failed,
        "elapsed_s": t_end - t0,
        "cluster_s": t_runs - t0,
        "runs_s": t_end - t_runs,
    }


def aggregate(study: Study, out: "str | Path") -> Path:
    """Writes the aggregates and plots of the table in ``out``; returns the aggregates' path."""
    from .study_stats import aggregate as _aggregate

    return _aggregate(study, Path(out))


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="cellsar-study",
        description="Run a study (a study file's planned or closed-loop missions) on Dask, "
        "append one row per run to DIR/results.csv and DIR/results.parquet, and write the "
        "aggregates and curves beside them. A study resumes: finished runs are not run again.",
    )
    p.add_argument("study", metavar="STUDY.toml", help="the study file")
    p.add_argument("--out", required=True, metavar="DIR", help="the output directory")
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="a Dask scheduler's address (tcp://HOST:8786); default: a local cluster",
    )
    p.add_argument(
        "--scheduler-timeout-s",
        type=float,
        default=SCHEDULER_TIMEOUT_S,
        metavar="S",
        help=f"how long reaching --scheduler may take, seconds (default {SCHEDULER_TIMEOUT_S:g})",
    )
    p.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="worker processes of the local cluster (one thread each); default: the cores",
    )
    p.add_argument(
        "--aggregate-only",
        action="store_true",
        help="only write the aggregates and plots from DIR's table",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """The ``cellsar-study`` console command."""
    args = _parser().parse_args(argv)
    try:
        if args.workers is not None and args.workers < 1:
            raise StudyError(f"--workers: expected at least 1, got {args.workers}")
        if not args.scheduler_timeout_s > 0:
            raise StudyError(
                f"--scheduler-timeout-s: expected a positive number, got {args.scheduler_timeout_s}"
            )
        if args.workers is not None and args.scheduler:
            raise StudyError("--workers: only for the local cluster, not with --scheduler")
        study = load(args.study)
        if args.aggregate_only:
            path = aggregate(study, args.out)
            print(f"aggregates: {path}")
            return 0
        summary = run(
            study,
            args.out,
            scheduler=args.scheduler,
            workers=args.workers,
            show_progress=not args.quiet,
            scheduler_timeout_s=args.scheduler_timeout_s,
        )
    except StudyError as e:
        print(f"cellsar-study: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(
            f"cellsar-study: interrupted; the finished runs are in {Path(args.out) / 'results.csv'}: "
            "run the same command again to resume",
            file=sys.stderr,
        )
        return 130
    print(
        f"{study.name}: {summary['runs']} runs, {summary['skipped']} finished before, "
        f"{summary['ran']} run now ({summary['failed']} failed) in {summary['elapsed_s']:.1f} s "
        f"({summary['cluster_s']:.1f} s starting the cluster); "
        f"table {Path(args.out) / 'results.parquet'}"
    )
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
