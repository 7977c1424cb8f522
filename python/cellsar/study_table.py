"""The results of a study: one row per run, appended to ``results.csv`` as runs finish (the
journal: one line written and flushed per run) and converted to ``results.parquet`` (pyarrow)
from it, so an interrupted study keeps every finished run and resumes with the others.
"""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path
from typing import Any, Dict, Iterable, List, Set

from .study_run import RESULT_COLUMNS
from .study_spec import Run, Study, StudyError

CSV = "results.csv"
PARQUET = "results.parquet"
#: The identity columns every row starts with.
ID_COLUMNS = (("run_id", "string"), ("realisation", "int64"), ("seed", "int64"))


def _kind(values: Iterable[Any]) -> str:
    vs = list(values)
    if all(isinstance(v, bool) for v in vs):
        return "bool"
    if all(isinstance(v, int) and not isinstance(v, bool) for v in vs):
        return "int64"
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vs):
        return "float64"
    return "string"


def columns(study: Study, runs: List[Run]) -> List[tuple]:
    """The table's columns (name, type): identity, swept parameters by path, results."""
    swept = [(p, _kind(r.values[p] for r in runs)) for p in study.swept]
    return [*ID_COLUMNS, *swept, *RESULT_COLUMNS]


def _text(v: Any) -> str:
    if isinstance(v, float) and math.isnan(v):
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return " ".join(str(x) for x in v)
    return str(v)


class Table:
    """The results of one study in ``out``: appends rows, knows the finished runs."""

    def __init__(self, out: Path, cols: List[tuple]):
        self.out = out
        self.cols = cols
        self.names = [n for n, _ in cols]
        self.csv_path = out / CSV
        self.parquet_path = out / PARQUET
        out.mkdir(parents=True, exist_ok=True)
        self.done: Set[str] = set()
        if self.csv_path.exists():
            self._recover()
        else:
            with open(self.csv_path, "w", newline="") as f:
                csv.writer(f).writerow(self.names)
        self._file = open(self.csv_path, "a", newline="")

    def _recover(self) -> None:
        """Reads the finished runs; drops a last line cut short by a crash."""
        data = self.csv_path.read_bytes()
        if data and not data.endswith(b"\n"):
            cut = data.rfind(b"\n") + 1
            with open(self.csv_path, "r+b") as f:
                f.truncate(cut)
            data = data[:cut]
        rows = list(csv.reader(io.StringIO(data.decode())))
        if not rows:
            with open(self.csv_path, "w", newline="") as f:
                csv.writer(f).writerow(self.names)
            return
        if rows[0] != self.names:
            raise StudyError(
                f"{self.csv_path}: its columns are not this study's ({', '.join(rows[0])}); "
                "give another --out directory"
            )
        self.done = {r[0] for r in rows[1:] if r}

    def append(self, run: Run, result: Dict[str, Any]) -> None:
        """Appends the row of a finished run and flushes it to disk."""
        row = {"run_id": run.run_id, "realisation": run.realisation, "seed": run.seed}
        row.update(run.values)
        row.update(result)
        buf = io.StringIO()
        csv.writer(buf).writerow([_text(row.get(n, "")) for n in self.names])
        self._file.write(buf.getvalue())
        self._file.flush()
        os.fsync(self._file.fileno())
        self.done.add(run.run_id)

    def close(self) -> None:
        """Closes the journal and writes the Parquet table."""
        self._file.close()
        write_parquet(self.csv_path, self.parquet_path, self.cols)


def read(csv_path: Path, cols: List[tuple]) -> Any:
    """The CSV journal as a pyarrow Table with the study's column types."""
    import pyarrow as pa
    from pyarrow import csv as pacsv

    types = {n: pa.bool_() if t == "bool" else pa.string() if t == "string" else pa.from_numpy_dtype(t) for n, t in cols}
    return pacsv.read_csv(
        csv_path,
        convert_options=pacsv.ConvertOptions(
            column_types=types,
            strings_can_be_null=False,
            true_values=["true"],
            false_values=["false"],
        ),
    )


def write_parquet(csv_path: Path, parquet_path: Path, cols: List[tuple]) -> None:
    """Converts the journal to Parquet (written beside, then renamed over the old table)."""
    import pyarrow.parquet as pq

    tmp = parquet_path.with_suffix(".parquet.tmp")
    pq.write_table(read(csv_path, cols), tmp)
    os.replace(tmp, parquet_path)
