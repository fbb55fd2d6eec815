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
- ``median_diff``: the median over shapes of OSILA's value minus the other's, with a 95 %
  percentile bootstrap interval over shapes (``ci_low``, ``ci_high``; :data:`BOOTSTRAP`
  resamples, seeded by :data:`SEED`, so a run is reproducible to the byte);
- ``osila_better_share``, ``tied_share``, ``osila_worse_share``: the shares of shapes where
  OSILA is better (the metric's direction), equal, worse — a tie is not a loss.

**One confirmatory family, declared before any run** (:func:`confirmatory`): the headline metric
(:data:`CONFIRMATORY_METRIC`, Fréchet: time-free, so it means the same under every protocol),
OSILA against each of the strongest baselines (:data:`hila_lang.evaluation.baselines.BASELINES`),
at every N >= 2 (N = 1 only where the protocol has no other).  ``p_holm`` is Holm's step-down
correction WITHIN that family (``family: "confirmatory"``); every other test — controls,
ablation, other metrics, N = 1 — is printed as exploratory (``family: "exploratory"``, raw p,
``p_holm`` null): a description, not evidence on its own.  Holm over every test of a run (192,
30 of them exact duplicates) made every finding unreportable; the family is fixed by what the
evaluation asks (does the demonstration, used by OSILA, beat the strongest ways to use the same
constraints?), not by what a run shows.

**Duplicates are said once** (:func:`duplicates`): a method whose scores equal another's on every
pair at some N (every baseline is the similarity at N = 1; ``X+retime`` is ``X`` where no pair
carries a time; ``osila-noadjust`` is OSILA without forced waypoints) is tested once: its rows
name the method it equals (``same_as``) and copy its figures, and a duplicate family member is
not counted twice in Holm's correction.  A method identical to OSILA is a tie (shares 0 / 1 / 0,
p = 1), not a loss.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..metrics import metric as metric_info
from .baselines import BASELINES
from .protocols import leaks_time
from .run import GridResult

#: bootstrap resamples of the shapes, and their seed
BOOTSTRAP = 2000
SEED = 0
#: the headline metric of the confirmatory family (module docstring)
CONFIRMATORY_METRIC = "frechet"


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
    # lazy: loads scipy, which importing this module does not
    from scipy.stats import wilcoxon

    ok = np.isfinite(osila) & np.isfinite(other)
    a, b = osila[ok], other[ok]
    out: dict[str, Any] = {"n": int(a.size), "osila_better_share": float("nan"), "tied_share": float("nan"),
                           "osila_worse_share": float("nan"), "p_value": float("nan"),
                           "median_diff": float("nan"), "ci_low": float("nan"), "ci_high": float("nan")}
    if not a.size:
        return out
    diff = a - b
    wins = (diff < 0) if better == "lower" else (diff > 0)
    out["osila_better_share"] = float(wins.mean())
    out["tied_share"] = float((diff == 0).mean())
    out["osila_worse_share"] = float((~wins & (diff != 0)).mean())
    out["p_value"] = float(wilcoxon(a, b).pvalue) if np.any(diff != 0) else 1.0
    out["median_diff"] = float(np.median(diff))
    rng = np.random.default_rng(seed)
    boot = np.median(diff[rng.integers(0, a.size, (BOOTSTRAP, a.size))], axis=1)
    out["ci_low"], out["ci_high"] = (float(x) for x in np.percentile(boot, [2.5, 97.5]))
    return out


def confirmatory(result: GridResult) -> list[tuple[str, int, str]]:
    """The confirmatory family declared in advance (module docstring): (method, N, metric) for
    each baseline run, N >= 2 (or every N where the protocol has only N = 1), the headline metric."""
    ns = [n for n in result.segments if n >= 2] or list(result.segments)
    if CONFIRMATORY_METRIC not in result.metrics:
        return []
    return [(m, n, CONFIRMATORY_METRIC) for m in result.methods if m in BASELINES for n in ns]


#: two methods are the same on a pair when every score agrees to this fraction of the largest score
#: magnitude in the run (rounding: the same path computed by two routes, e.g. every baseline's
#: offset through the ends is zero at N = 1, to 1e-15; a per-metric scale would not do: the
#: end-point error of such a path is 0 or 1e-15, whose relative difference is all)
SAME = 1e-9


def duplicates(result: GridResult) -> dict[int, dict[str, str]]:
    """Per N: method -> the first method (in run order) whose scores equal its own on every pair
    and every metric (to rounding, :data:`SAME`; NaN where NaN), for each method that has one
    (module docstring)."""
    out: dict[int, dict[str, str]] = {}
    for s, n in enumerate(result.segments):
        block = np.stack([result.scores[m][s] for m in result.methods]) if result.methods else np.zeros(0)
        top = float(np.nanmax(np.abs(block), initial=0.0)) if block.size else 0.0
        tol = SAME * top
        same: dict[str, str] = {}
        for k, m in enumerate(result.methods):
            a = result.scores[m][s]
            for first in result.methods[:k]:
                if first in same:
                    continue
                b = result.scores[first][s]
                nan = np.isnan(a)
                if np.array_equal(nan, np.isnan(b)) and bool((np.abs(a - b)[~nan] <= tol).all()):
                    same[m] = first
                    break
        out[n] = same
    return out


def test_rows(result: GridResult) -> list[dict[str, Any]]:
    """Per other method, N and tested metric: OSILA against it over shapes (module docstring), with
    its ``family`` (confirmatory or exploratory), ``same_as`` (the method it equals on every pair,
    or None) and, for the confirmatory family only, ``p_holm``."""
    if "osila" not in result.methods:
        return []
    family = set(confirmatory(result))
    same = duplicates(result)
    rows = []
    done: dict[tuple[str, int, str], dict[str, Any]] = {}
    for m in result.methods:
        if m == "osila":
            continue
        for s, n in enumerate(result.segments):
            for name in tested_metrics(result, n):
                better = metric_info(name).better
                twin = same[n].get(m)
                row = {"method": m, "segments": n, "metric": name, "better": better, "unit": "shape",
                       "pairs": int(np.isfinite(values(result, m, name, s)).sum()), "same_as": twin,
                       "family": "confirmatory" if (m, n, name) in family else "exploratory"}
                if twin is not None and twin != "osila":  # said once: the figures of the method it equals
                    row.update({k: v for k, v in done[(twin, n, name)].items() if k in _FIGURES})
                else:
                    row.update(compare(shape_means(result, "osila", name, s), shape_means(result, m, name, s), better))
                done[(m, n, name)] = row
                rows.append(row)
    # Holm within the family; a member equal to an earlier member (or to OSILA: no test) counts once
    counted = [r for r in rows if r["family"] == "confirmatory" and r["same_as"] is None]
    adjusted = holm(np.array([r["p_value"] for r in counted]))
    for r, p in zip(counted, adjusted):
        r["p_holm"] = float(p)
    for r in rows:
        if r["family"] == "confirmatory" and r["same_as"] is not None:
            twin = done.get((r["same_as"], r["segments"], r["metric"]))
            r["p_holm"] = twin.get("p_holm", float("nan")) if twin is not None else float("nan")
        r.setdefault("p_holm", float("nan"))
    return rows


_FIGURES = ("n", "osila_better_share", "tied_share", "osila_worse_share", "p_value", "median_diff", "ci_low",
            "ci_high")


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
