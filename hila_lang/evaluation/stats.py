"""Summaries of a grid: means per method and N, and paired tests of OSILA against each control.

Only pairs of DIFFERENT trials count here (a trial mapped onto itself is the paper's Table I, a
reproduction check, and would flatter the template-based methods).  For every control and N:

- ``osila_better_share``: the share of pairs where OSILA's MSD is strictly lower than the
  control's on the same pair (ties count as not better);
- ``p_value``: the two-sided Wilcoxon signed-rank test (``scipy.stats.wilcoxon``) of the paired
  MSD differences — is OSILA's error systematically different from the control's on the same
  pairs?  (1.0 when every difference is zero);
- the same two for the Fréchet distance (``frechet_better_share``, ``frechet_p_value``).

Pairs a method failed on (NaN) are left out of that comparison.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .run import GridResult

#: the metrics of the summary rows, in order (per-axis R follow)
SUMMARY_METRICS = ("r", "msd", "frechet", "dtw", "endpoint")


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
            r = values(result, m, "r", s, pairs)
            row["pairs"] = int(r.size)
            row["failed"] = int(np.isnan(r).sum())
            row["ms_per_path"] = 1e3 * _mean(result.seconds[m][s][pairs])
            rows.append(row)
    return rows


def paired(osila: np.ndarray, other: np.ndarray) -> tuple[float, float, int]:
    """(share where ``osila`` < ``other``, Wilcoxon two-sided p, pairs compared) over finite pairs."""
    from scipy.stats import wilcoxon

    ok = np.isfinite(osila) & np.isfinite(other)
    a, b = osila[ok], other[ok]
    if not a.size:
        return float("nan"), float("nan"), 0
    share = float((a < b).mean())
    diff = a - b
    if not np.any(diff != 0):
        return share, 1.0, int(a.size)
    return share, float(wilcoxon(a, b).pvalue), int(a.size)


def test_rows(result: GridResult, pairs: np.ndarray | None = None) -> list[dict[str, Any]]:
    """Per control and N: OSILA better share and Wilcoxon p, on MSD and on Fréchet (module docstring)."""
    if "osila" not in result.methods:
        return []
    pairs = distinct_pairs(result) if pairs is None else pairs
    rows = []
    for m in result.methods:
        if m == "osila":
            continue
        for s, n in enumerate(result.segments):
            share, p, count = paired(values(result, "osila", "msd", s, pairs), values(result, m, "msd", s, pairs))
            f_share, f_p, _ = paired(values(result, "osila", "frechet", s, pairs),
                                     values(result, m, "frechet", s, pairs))
            rows.append({"method": m, "n": n, "osila_better_share": share, "p_value": p, "metric": "msd",
                         "frechet_better_share": f_share, "frechet_p_value": f_p, "pairs": count})
    return rows


def by_setup(result: GridResult) -> list[dict[str, Any]]:
    """Per set-up (LASA: shape) of the task, method and N: mean R, MSD and Fréchet over its pairs."""
    base = distinct_pairs(result)
    rows = []
    for k, name in enumerate(result.setups):
        pairs = base & (result.trial_setup == k)[None, :]
        for m in result.methods:
            for s, n in enumerate(result.segments):
                rows.append({"setup": name, "method": m, "n": n,
                             **{x: _mean(values(result, m, x, s, pairs)) for x in ("r", "msd", "frechet")}})
    return rows
