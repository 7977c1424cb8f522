"""Aggregates of a study's table: per swept value, means with Student-t 95 % intervals and
proportions (feasibility, Pd) with Wilson 95 % intervals, written to ``aggregates.csv`` with one
matplotlib curve per metric and swept path (``plot-<metric>-vs-<path>.png``), all from
``results.csv`` alone, so ``cellsar-study STUDY.toml --out DIR --aggregate-only`` redraws them.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .study_spec import Study, StudyError
from .study_table import CSV, columns, read

#: The two-sided 95 % normal quantile.
Z95 = 1.959963984540054
#: Metrics averaged with a Student-t interval.
MEANS = (
    "energy_j",
    "unresolved_windows",
    "pd_all",
    "false_alarms",
    "position_error_m",
    "run_s",
)
#: Bins of a parameter drawn at random.
RANDOM_BINS = 8
AGGREGATES = "aggregates.csv"


def _betacf(a: float, b: float, x: float) -> float:
    """The continued fraction of the regularized incomplete beta function (Lentz)."""
    tiny = 1e-300
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 300):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-15:
            break
    return h


def betainc(a: float, b: float, x: float) -> float:
    """The regularized incomplete beta function I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    ln = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    front = math.exp(ln)
    if x < (a + 1.0) / (a + b + 2.0):
        return front * _betacf(a, b, x) / a
    return 1.0 - front * _betacf(b, a, 1.0 - x) / b


def t_cdf(t: float, df: float) -> float:
    """The Student-t distribution function with ``df`` degrees of freedom."""
    tail = 0.5 * betainc(df / 2.0, 0.5, df / (df + t * t))
    return 1.0 - tail if t >= 0 else tail


def t_quantile(p: float, df: float) -> float:
    """The Student-t quantile (``p`` in (0.5, 1)), by bisection on :func:`t_cdf`."""
    lo, hi = 0.0, 1.0
    while t_cdf(hi, df) < p:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if t_cdf(mid, df) < p:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-12 * max(1.0, hi):
            break
    return 0.5 * (lo + hi)


def mean_interval(values: Sequence[float]) -> Tuple[float, float, float, int]:
    """Mean and Student-t 95 % interval of the finite values: (mean, low, high, n); the
    interval is NaN with fewer than two values."""
    v = [x for x in values if x is not None and math.isfinite(x)]
    n = len(v)
    if n == 0:
        return math.nan, math.nan, math.nan, 0
    mean = math.fsum(v) / n
    if n < 2:
        return mean, math.nan, math.nan, n
    sd = math.sqrt(math.fsum((x - mean) ** 2 for x in v) / (n - 1))
    half = t_quantile(0.975, n - 1) * sd / math.sqrt(n)
    return mean, mean - half, mean + half, n


def wilson(successes: int, trials: int, z: float = Z95) -> Tuple[float, float, float]:
    """A proportion and its Wilson score interval: (p, low, high); NaN without trials."""
    if trials <= 0:
        return math.nan, math.nan, math.nan
    p = successes / trials
    z2n = z * z / trials
    centre = (p + z2n / 2.0) / (1.0 + z2n)
    half = z * math.sqrt(p * (1.0 - p) / trials + z2n / (4.0 * trials)) / (1.0 + z2n)
    return p, max(0.0, centre - half), min(1.0, centre + half)


def _group_keys(study: Study, rows: List[Dict[str, Any]]) -> List[Tuple[str, Dict[Any, Any]]]:
    """The grouping paths and, for each, the map value -> group value (random draws binned)."""
    keys: List[Tuple[str, Dict[Any, Any]]] = []
    for p in study.grid:
        keys.append((p, {v: v for v in {r[p] for r in rows}}))
    for p, (dist, _) in study.random.items():
        vals = sorted({r[p] for r in rows})
        if dist == "choice" or not vals or isinstance(vals[0], str):
            keys.append((p, {v: v for v in vals}))
            continue
        lo, hi = vals[0], vals[-1]
        width = (hi - lo) / RANDOM_BINS or 1.0
        binned = {}
        for v in vals:
            k = min(int((v - lo) / width), RANDOM_BINS - 1)
            binned[v] = lo + (k + 0.5) * width
        keys.append((p, binned))
    return keys


def _aggregate_rows(study: Study, rows: List[Dict[str, Any]]) -> Tuple[List[str], List[Dict[str, Any]]]:
    keys = _group_keys(study, rows)
    groups: Dict[Tuple[Any, ...], List[Dict[str, Any]]] = {}
    for r in rows:
        g = tuple(m[r[p]] for p, m in keys)
        groups.setdefault(g, []).append(r)
    out: List[Dict[str, Any]] = []
    for g in sorted(groups, key=lambda t: tuple(str(x) if isinstance(x, str) else x for x in t)):
        rs = groups[g]
        ok = [r for r in rs if r["status"] == "ok"]
        row: Dict[str, Any] = {p: v for (p, _), v in zip(keys, g)}
        row.update(runs=len(rs), failed=len(rs) - len(ok))
        for m in MEANS:
            mean, lo, hi, n = mean_interval([r[m] for r in ok])
            row.update({f"{m}_mean": mean, f"{m}_lo": lo, f"{m}_hi": hi, f"{m}_n": n})
        p, lo, hi = wilson(sum(bool(r["feasible"]) for r in ok), len(ok))
        row.update(feasible_p=p, feasible_lo=lo, feasible_hi=hi)
        strong = [r for r in ok if math.isfinite(r["strong_objects"] or math.nan)]
        det = int(sum(r["detected_objects"] for r in strong))
        tot = int(sum(r["strong_objects"] for r in strong))
        p, lo, hi = wilson(det, tot)
        row.update(pd_p=p, pd_lo=lo, pd_hi=hi, pd_trials=tot)
        out.append(row)
    names = [p for p, _ in keys] + [k for k in (out[0] if out else {}) if k not in dict(keys)]
    return names, out


def _plot(study: Study, names: List[str], agg: List[Dict[str, Any]], out: Path) -> List[Path]:
    """One figure per metric and grouping path: the metric's mean (or proportion) and its
    95 % interval against the path's values, one curve per value of the other paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = [p for p in names if p in study.grid or p in study.random]
    metrics = [(m, f"{m}_mean", f"{m}_lo", f"{m}_hi") for m in MEANS if m != "run_s"]
    metrics += [("pd", "pd_p", "pd_lo", "pd_hi"), ("feasible", "feasible_p", "feasible_lo", "feasible_hi")]
    written: List[Path] = []
    for x in paths:
        others = [p for p in paths if p != x]
        xs_all = sorted({r[x] for r in agg}, key=str if any(isinstance(r[x], str) for r in agg) else None)
        categorical = any(isinstance(v, str) for v in xs_all)
        for m, mean_k, lo_k, hi_k in metrics:
            if not any(math.isfinite(r[mean_k]) for r in agg):
                continue
            fig, ax = plt.subplots(figsize=(6, 4))
            curves: Dict[Tuple[Any, ...], List[Dict[str, Any]]] = {}
            for r in agg:
                curves.setdefault(tuple(r[o] for o in others), []).append(r)
            for label, rs in sorted(curves.items(), key=lambda kv: str(kv[0])):
                rs = sorted(rs, key=lambda r: xs_all.index(r[x]))
                xs = [xs_all.index(r[x]) if categorical else r[x] for r in rs]
                ys = [r[mean_k] for r in rs]
                lo = [r[lo_k] for r in rs]
                hi = [r[hi_k] for r in rs]
                name = ", ".join(f"{o} = {v}" for o, v in zip(others, label)) or None
                line = ax.plot(xs, ys, marker="o", label=name)[0]
                ax.fill_between(xs, lo, hi, alpha=0.2, color=line.get_color())
            if categorical:
                ax.set_xticks(range(len(xs_all)), [str(v) for v in xs_all])
            ax.set_xlabel(x)
            ax.set_ylabel(f"{m} (95 % interval)")
            ax.set_title(f"{study.name}: {m} against {x}")
            ax.grid(True, alpha=0.3)
            if others:
                ax.legend(fontsize="small")
            path = out / f"plot-{m}-vs-{x.replace('.', '_')}.png"
            fig.tight_layout()
            fig.savefig(path, dpi=100)
            plt.close(fig)
            written.append(path)
    return written


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else repr(v)
    return str(v)


def aggregate(study: Study, out: Path) -> Path:
    """Reads ``out/results.csv`` (this study's runs only) and writes ``out/aggregates.csv`` and
    the plots; returns the aggregates' path."""
    csv_path = out / CSV
    if not csv_path.exists():
        raise StudyError(f"{csv_path}: no results table (run the study first)")
    runs = study.runs()
    ids = {r.run_id for r in runs}
    table = read(csv_path, columns(study, runs))
    rows = [r for r in table.to_pylist() if r["run_id"] in ids]
    names, agg = _aggregate_rows(study, rows)
    path = out / AGGREGATES
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for r in agg:
            w.writerow([_cell(r[n]) for n in names])
    if agg:
        _plot(study, names, agg, out)
    return path


def summary(out: Path) -> Optional[List[Dict[str, str]]]:
    """The rows of ``out/aggregates.csv`` as dicts of text, or None when it is missing."""
    path = out / AGGREGATES
    if not path.exists():
        return None
    with open(path, newline="") as f:
        return list(csv.DictReader(f))
