"""Summaries of a grid: means per method and N, and tests of OSILA against every other method.

Only pairs of DIFFERENT trials count here (a trial mapped onto itself is the paper's Table I, a
reproduction check, and would flatter the template-based methods).

The tests (:func:`test_rows`) take the SHAPE (the set-up of the task: a LASA shape, a stand-in
set-up) as the unit, not the pair: pairs share demonstrations (each is in many pairs, as template
and as task), so they are not independent, and thousands of them make any difference
"significant".  For every other method, N and headline metric (:data:`hila_lang.metrics.METRICS`,
``headline``; MSD only where the protocol gives no timing away, :func:`.protocols.leaks_time`):

- one value per shape and method: the mean over that shape's pairs (pairs a method failed on,
  NaN, are left out; a shape where either method has no finite pair is left out);
- ``p_value``: the two-sided Wilcoxon signed-rank test over shapes (``scipy.stats.wilcoxon``,
  exact for these sizes; 1.0 when every difference is zero);
- ``p_holm``: Holm's step-down correction over EVERY test of the run (all rows);
- ``median_diff``: the median over shapes of OSILA's value minus the other's, with a 95 %
  percentile bootstrap interval over shapes (``ci_low``, ``ci_high``; :data:`BOOTSTRAP`
  resamples, seeded by :data:`SEED`, so a run is reproducible to the byte);
- ``osila_better_share``: the share of shapes where OSILA is better (the metric's direction),
  ties not counted.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..metrics import metric as metric_info
from .protocols import leaks_time
from .run import GridResult

#: bootstrap resamples of the shapes, and their seed
BOOTSTRAP = 2000
SEED = 0


def distinct_pairs(result: GridResult) -> np.ndarray:
    """Evaluated pairs of different trials, shape (J, J) of bool."""
    return result.mask & ~np.eye(len(result.labels), dtype=bool)


def values(result: GridResult, method: str, metric: str, s: int, pairs: np.ndarray | None = None) -> np.ndarray:
    """One metric over the selected pairs (default: :func:`distinct_pairs`), flat, NaN kept."""
    pairs = distinct_pairs(result) if pairs is None else pairs
    return result.metric(method, metric)[s][pairs]


def _mean(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else float("nan")


def summary_rows(result: GridResult, pairs: np.ndarray | None = None) -> list[dict[str, Any]]:
    """Per method and N: the mean of every metric over the pairs, pair count, failures, ms per path."""
    pairs = distinct_pairs(result) if pairs is None else pairs
    rows = []
    for m in result.methods:
        for s, n in enumerate(result.segments):
            row: dict[str, Any] = {"method": m, "n": n}
            for name in result.metrics:
                row[name] = _mean(values(result, m, name, s, pairs))
            scored = result.scores[m][s][pairs]  # (pairs, metrics): a failed pair has no score at all
            row["pairs"] = int(len(scored))
            row["failed"] = int(np.isnan(scored).all(axis=1).sum())
            row["ms_per_path"] = 1e3 * _mean(result.seconds[m][s][pairs])
            rows.append(row)
    return rows


def tested_metrics(result: GridResult, n: int) -> tuple[str, ...]:
    """The headline metrics tested at N = ``n``: time-free ones always, the others only where the
    protocol gives no timing away."""
    out = []
    for name in result.metrics:
        info = metric_info(name)
        if info.headline and (info.time_free or not leaks_time(result.protocol, n)):
            out.append(name)
    return tuple(out)


def shape_means(result: GridResult, method: str, metric: str, s: int) -> np.ndarray:
    """Mean of one metric per shape (set-up of the task) over its pairs of different trials, (n_setups,)."""
    base = distinct_pairs(result)
    return np.array([_mean(values(result, method, metric, s, base & (result.trial_setup == k)[None, :]))
                     for k in range(len(result.setups))])


def holm(p: np.ndarray) -> np.ndarray:
    """Holm's step-down adjusted p-values (same order as ``p``; NaN stays NaN)."""
    p = np.asarray(p, float)
    out = np.full_like(p, np.nan)
    ok = np.flatnonzero(np.isfinite(p))
    order = ok[np.argsort(p[ok], kind="stable")]
    m = len(order)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        out[i] = running
    return out


def compare(osila: np.ndarray, other: np.ndarray, better: str, seed: int = SEED) -> dict[str, Any]:
    """Shape-level comparison of two (n_units,) arrays (module docstring), without ``p_holm``."""
    from scipy.stats import wilcoxon

    ok = np.isfinite(osila) & np.isfinite(other)
    a, b = osila[ok], other[ok]
    out: dict[str, Any] = {"n": int(a.size), "osila_better_share": float("nan"), "p_value": float("nan"),
                           "median_diff": float("nan"), "ci_low": float("nan"), "ci_high": float("nan")}
    if not a.size:
        return out
    diff = a - b
    out["osila_better_share"] = float(((diff < 0) if better == "lower" else (diff > 0)).mean())
    out["p_value"] = float(wilcoxon(a, b).pvalue) if np.any(diff != 0) else 1.0
    out["median_diff"] = float(np.median(diff))
    rng = np.random.default_rng(seed)
    boot = np.median(diff[rng.integers(0, a.size, (BOOTSTRAP, a.size))], axis=1)
    out["ci_low"], out["ci_high"] = (float(x) for x in np.percentile(boot, [2.5, 97.5]))
    return out


def test_rows(result: GridResult) -> list[dict[str, Any]]:
    """Per other method, N and tested metric: OSILA against it over shapes (module docstring)."""
    if "osila" not in result.methods:
        return []
    rows = []
    for m in result.methods:
        if m == "osila":
            continue
        for s, n in enumerate(result.segments):
            for name in tested_metrics(result, n):
                better = metric_info(name).better
                row = {"method": m, "segments": n, "metric": name, "better": better, "unit": "shape",
                       "pairs": int(np.isfinite(values(result, m, name, s)).sum())}
                row.update(compare(shape_means(result, "osila", name, s), shape_means(result, m, name, s), better))
                rows.append(row)
    adjusted = holm(np.array([r["p_value"] for r in rows]))
    for r, p in zip(rows, adjusted):
        r["p_holm"] = float(p)
    return rows


def by_setup(result: GridResult) -> list[dict[str, Any]]:
    """Per set-up (LASA: shape) of the task, method and N: the mean of every metric that is one
    number (not per axis) over its pairs."""
    base = distinct_pairs(result)
    names = [x for x in result.metrics if not metric_info(x).per_axis]
    rows = []
    for k, name in enumerate(result.setups):
        pairs = base & (result.trial_setup == k)[None, :]
        for m in result.methods:
            for s, n in enumerate(result.segments):
                rows.append({"setup": name, "method": m, "n": n,
                             **{x: _mean(values(result, m, x, s, pairs)) for x in names}})
    return rows
