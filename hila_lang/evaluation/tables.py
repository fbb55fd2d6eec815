"""What ``hila eval`` prints: the headline tables, the methods side by side, the tests, the paper's Tables.

- The headline: per headline metric (Fréchet and DTW, time-free; MSD where the protocol gives no
  timing away), every method's mean by N, grouped: OSILA, controls, baselines, ablation.
- The summary: per method and N, the mean of every metric but R over pairs of different trials,
  and the tests of OSILA against every other method over shapes (:mod:`.stats`).
- Table I: mean R of the self-mapping cases (template i onto its own ICPs), per set-up and N.
- Table II: mean R over all template/task pairs, grouped by input (template, columns) and output
  (task, rows) set-up; each cell holds N = 1..4 on four lines, as in the paper.
- Table III: the same for MSD (squared path units: pixels² for the stand-in).

Tables I–III are OSILA's, in the paper's layout; Table I is printed again with every control
(:func:`format_table1_methods`: the same self-mapping pairs, the same constraints), and
``results.json`` holds Tables I–III of every control too.  Under ``--protocol paper`` with the stand-in's
5 set-ups the paper's figures (:mod:`.paper`) are printed beside ours, ``ours (paper)``: they are
reference values from a different (human, unpublished) data set, so the comparison says whether
the reproduction behaves alike, not whether either method is good.

Summary shares follow the paper's §IV.A.  The paper's percentages are shares of Table II cells
(8 of its 25 cells have R < 0.8 unsegmented = 32 %; 23 of 25 reach R >= 0.8 at N = 2 = 92 %,
counting its 0.800; 24 of 25 exceed 0.95 at N = 4, "nearly all"), so we give both the share of
cells, computed the same way, and the share of the individual pairs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..metrics import metric, metric as info_of
from . import paper, stats
from .ablation import ABLATIONS
from .baselines import BASELINES
from .controls import CONTROLS
from .protocols import leaks_time
from .run import GridResult

#: (key, N, comparison, threshold, label)
CLAIMS = (
    ("unsegmented_below_0.8", 1, "<", 0.8, "R < 0.8 unsegmented (N = 1)"),
    ("segmented_at_least_0.8", 2, ">=", 0.8, "R >= 0.8 once segmented (N = 2)"),
    ("n4_above_0.95", 4, ">", 0.95, "R > 0.95 at N = 4"),
)
_OPS = {"<": np.less, ">=": np.greater_equal, ">": np.greater}


def _group_mean(values: np.ndarray, setup_of: np.ndarray, n_setups: int) -> np.ndarray:
    """Mean of values (S, J, J) [s, template, task] grouped to (S, output setup, input setup)."""
    S = values.shape[0]
    out = np.full((S, n_setups, n_setups), np.nan)
    for o in range(n_setups):
        for i in range(n_setups):
            block = values[:, setup_of == i][:, :, setup_of == o]
            with np.errstate(all="ignore"):
                out[:, o, i] = np.nanmean(block.reshape(S, -1), axis=1) if block.size else np.nan
    return out


def table1(result: GridResult, method: str = "osila") -> np.ndarray:
    """Mean self-mapping R, shape (S, n_setups)."""
    diag = np.diagonal(result.r[method], axis1=1, axis2=2)  # (S, J)
    return np.array([[np.nanmean(diag[s, result.trial_setup == k]) for k in range(len(result.setups))]
                     for s in range(len(result.segments))])


def table2(result: GridResult, method: str = "osila") -> np.ndarray:
    """Mean R per (N, output set-up, input set-up), shape (S, n_setups, n_setups)."""
    return _group_mean(result.r[method], result.trial_setup, len(result.setups))


def table3(result: GridResult, method: str = "osila") -> np.ndarray:
    """Mean MSD per (N, output set-up, input set-up), shape (S, n_setups, n_setups)."""
    return _group_mean(result.msd[method], result.trial_setup, len(result.setups))


def share(values: np.ndarray, op: str, threshold: float) -> float:
    """Share of the finite ``values`` satisfying ``value op threshold`` (NaN if none is finite)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float(_OPS[op](v, threshold).mean()) if v.size else float("nan")


def claims(result: GridResult, method: str = "osila") -> list[dict[str, Any]]:
    """The §IV.A shares: ours over cells and over pairs, and the paper's over its cells."""
    cells = table2(result, method)
    out = []
    for key, n, op, thr, label in CLAIMS:
        row: dict[str, Any] = {"claim": key, "label": label, "segments": n,
                               "paper_text": paper.CLAIMS[key],
                               "paper_cells": share(paper.TABLE_II[n - 1], op, thr)}
        if n in result.segments:
            s = result.segments.index(n)
            row["cells"] = share(cells[s], op, thr)
            row["pairs"] = share(result.r[method][s], op, thr)
        out.append(row)
    return out


def _pct(x: float) -> str:
    return "  n/a" if not np.isfinite(x) else f"{100 * x:4.0f}%"


def _num(x: float, kind: str) -> str:
    if not np.isfinite(x):
        return "n/a"
    if kind == "r":
        return f"{x:.3f}"
    return f"{x:.0f}" if kind == "msd" else f"{x:.3g}"


def _cell(ours: float, ref: float | None, kind: str) -> str:
    text = _num(ours, kind)
    return text if ref is None else f"{text} ({_num(ref, kind)})"


def _with_paper(result: GridResult) -> bool:
    return result.protocol == "paper" and len(result.setups) == 5 and tuple(result.segments) == (1, 2, 3, 4)


def _width(result: GridResult, with_ref: bool, kind: str) -> int:
    base = (15 if kind == "r" else 13) if with_ref else (7 if kind != "msd_small" else 9)
    return max(base, *(len(name) for name in result.setups))


def format_table1(result: GridResult, method: str = "osila") -> str:
    """Table I in the paper's layout: rows N, columns set-ups."""
    ours, ref = table1(result, method), (paper.TABLE_I if _with_paper(result) else None)
    width = _width(result, ref is not None, "r")
    lines = ["TABLE I: averaged R of the self-mapping cases, grouped in experiments"
             + (" -- ours (paper)" if ref is not None else ""),
             "N segments | " + " | ".join(f"{name:^{width}}" for name in result.setups)]
    for s, n in enumerate(result.segments):
        cells = [_cell(ours[s, k], None if ref is None else ref[s, k], "r") for k in range(len(result.setups))]
        lines.append(f"{n:^10} | " + " | ".join(f"{c:^{width}}" for c in cells))
    return "\n".join(lines)


def format_table1_methods(result: GridResult) -> str:
    """Table I for every method, on the same self-mapping pairs: rows method and N, columns set-ups."""
    width = _width(result, False, "r")
    lines = ["TABLE I with the controls: averaged R of the self-mapping cases, per method "
             "(Tables II-III of every control: results.json, tables.controls)",
             "method       N | " + " | ".join(f"{name:^{width}}" for name in result.setups)]
    for method in result.methods:
        values = table1(result, method)
        for s, n in enumerate(result.segments):
            cells = [_cell(values[s, k], None, "r") for k in range(len(result.setups))]
            lines.append(f"{method:<12}{n:>2} | " + " | ".join(f"{c:^{width}}" for c in cells))
    return "\n".join(lines)


def _format_cross(result: GridResult, ours: np.ndarray, ref: np.ndarray | None, kind: str, title: str) -> str:
    width = _width(result, ref is not None, kind)
    head = max(7, *(len(name) for name in result.setups)) + 1
    lines = [title + (" -- ours (paper)" if ref is not None else ""),
             "Columns: input (template) experiment; rows: output (task) experiment; "
             f"the lines of a cell: N = {', '.join(map(str, result.segments))} segments.",
             f"{'output':<{head}}| {'N':>2} | " + " | ".join(f"{name:^{width}}" for name in result.setups)]
    k_all = range(len(result.setups))
    for o, name in enumerate(result.setups):
        lines.append("-" * len(lines[2]))
        for s, n in enumerate(result.segments):
            cells = [_cell(ours[s, o, i], None if ref is None else ref[s, o, i], kind) for i in k_all]
            label = name if s == 0 else ""
            lines.append(f"{label:<{head}}| {n:>2} | " + " | ".join(f"{c:^{width}}" for c in cells))
    return "\n".join(lines)


def format_table2(result: GridResult, method: str = "osila") -> str:
    """Table II (mean R) in the paper's layout."""
    ref = paper.TABLE_II if _with_paper(result) else None
    return _format_cross(result, table2(result, method), ref, "r",
                         "TABLE II: averaged correlation coefficient R, mapping one experiment onto another")


def format_table3(result: GridResult, method: str = "osila") -> str:
    """Table III (mean MSD) in the paper's layout: whole numbers as the paper (pixels²), or three
    significant digits when every value is below 100 (e.g. metre-scale data)."""
    ref = paper.TABLE_III if _with_paper(result) else None
    ours = table3(result, method)
    kind = "msd" if np.nanmax(ours, initial=0.0) >= 100 else "msd_small"
    return _format_cross(result, ours, ref, kind,
                         "TABLE III: averaged mean squared difference MSD, mapping one experiment onto another")


def format_claims(result: GridResult, method: str = "osila") -> str:
    """The §IV.A summary lines, ours beside the paper's."""
    lines = [f"The paper's claims ({method}; shares of the {len(result.setups) ** 2} Table II cells and of all "
             f"{len(result.labels) ** 2} pairs):"]
    for row in claims(result, method):
        if "cells" not in row:
            continue
        lines.append(f"  {row['label']:<32} ours: {_pct(row['cells'])} of cells, {_pct(row['pairs'])} of pairs"
                     f" | paper: {_pct(row['paper_cells'])} of cells ({row['paper_text']})")
    return "\n".join(lines)


def _fmt(x: float, name: str) -> str:
    """A score as the tables print it: a correlation with 3 decimals, a distance with 4 digits."""
    if not np.isfinite(x):
        return "n/a"
    if metric(name).kind == "correlation":
        return f"{x:.3f}"
    return f"{x:.4g}" if abs(x) < 1000 else f"{x:.0f}"


def _table(head: list[str], body: list[list[str]]) -> list[str]:
    """Rows of a text table: first column left-aligned, the others right-aligned, a rule under the head."""
    width = [max(len(h), *(len(b[k]) for b in body)) for k, h in enumerate(head)]

    def line(cells: list[str]) -> str:
        return " | ".join(c.rjust(w) if k else c.ljust(w) for k, (c, w) in enumerate(zip(cells, width)))

    return [line(head), "-" * len(line(head)), *(line(b) for b in body)]


#: method groups, in print order, for the headline tables
GROUPS = (("OSILA", ("osila",)), ("controls", CONTROLS), ("baselines", BASELINES), ("ablation", ABLATIONS),
          ("hierarchical", ("hila",)))


def _grouped(methods: tuple[str, ...]) -> list[tuple[str, list[str]]]:
    return [(label, [m for m in members if m in methods]) for label, members in GROUPS
            if any(m in methods for m in members)]


def format_metric_table(result: GridResult, metric: str) -> str:
    """One headline metric: rows method (grouped), columns N; mean over pairs of different trials.

    ``*`` marks the best mean of a column among OSILA, the controls and the baselines; a cell
    whose N gives timing away (:func:`.protocols.leaks_time`) for a metric that is not time-free
    is ``leaks``."""
    info = info_of(metric)
    rows = {(r["method"], r["n"]): r[metric] for r in stats.summary_rows(result)}
    same = stats.duplicates(result)
    contenders = [m for m in result.methods if not m.startswith("osila-") and m != "hila"]
    best = {}
    for n in result.segments:
        vals = [rows[(m, n)] for m in contenders if np.isfinite(rows[(m, n)])]
        best[n] = (min(vals) if info.better == "lower" else max(vals)) if vals else None
    head = ["method", *(f"N = {n}" for n in result.segments)]
    body: list[list[str]] = []
    for label, members in _grouped(result.methods):
        body.append([f"-- {label}", *("" for _ in result.segments)])
        for m in members:
            cells = []
            for n in result.segments:
                if not info.time_free and leaks_time(result.protocol, n):
                    cells.append("leaks")
                    continue
                if m in same[n]:  # said once: where it was said
                    cells.append(f"= {same[n][m]} ")
                    continue
                v = rows[(m, n)]
                mark = "*" if best[n] is not None and v == best[n] and m in contenders else " "
                cells.append(_fmt(v, metric) + mark)
            body.append([m, *cells])
    unit = f" ({info.unit})" if info.unit else ""
    title = (f"{info.title}{unit}, {info.better} is better; "
             f"mean over pairs of different trials; * best of OSILA, controls and baselines; '= m': the same "
             f"as method m on every pair")
    return "\n".join([title, *_table(head, body)])


def format_summary(result: GridResult) -> str:
    """Per method and N: the mean of every distance (the correlations stay in results.json); time;
    failures."""
    names = [n for n in result.metrics if info_of(n).kind == "distance"]

    def cell(row: dict[str, Any], name: str) -> str:
        if not info_of(name).time_free and leaks_time(result.protocol, row["n"]):
            return "leaks"
        return _fmt(row[name], name)

    head = ["method", "N", *names, "pairs", "failed", "ms/path"]
    body = [[row["method"], str(row["n"]), *(cell(row, n) for n in names), str(row["pairs"]),
             str(row["failed"]), f"{row['ms_per_path']:.2f}"] for row in stats.summary_rows(result)]
    return "\n".join(["Methods side by side (means over pairs of different trials; u = the data's unit: "
                      "MSD in u², Fréchet, DTW per sample and end-point error in u; R and per-axis R, and "
                      "MSD where the protocol gives timing away ('leaks'): results.json):", *_table(head, body)])


def format_tests(result: GridResult) -> str:
    """OSILA against every other method over shapes: the confirmatory family (Holm within it), then
    the exploratory tests (raw p); a method equal to another on every pair is said once."""
    rows = stats.test_rows(result)
    if not rows:
        return ""
    head = ["method", "N", "metric", "shapes", "OSILA better/tied/worse", "median diff [95% CI]", "p", "p (Holm)"]

    def line(r: dict[str, Any]) -> list[str]:
        n = r["n"]
        counts = "/".join(str(int(round(n * r[k]))) if np.isfinite(r[k]) else "-"
                          for k in ("osila_better_share", "tied_share", "osila_worse_share"))
        return [r["method"], str(r["segments"]), r["metric"], str(n), counts,
                f"{_fmt(r['median_diff'], r['metric'])} [{_fmt(r['ci_low'], r['metric'])}, "
                f"{_fmt(r['ci_high'], r['metric'])}]", _p(r["p_value"]),
                _p(r["p_holm"]) if r["family"] == "confirmatory" else "-"]

    conf = [r for r in rows if r["family"] == "confirmatory" and r["same_as"] is None]
    expl = [r for r in rows if r["family"] == "exploratory" and r["same_as"] is None]
    said = _said_once(rows)
    declared = stats.confirmatory(result)
    ns = sorted({n for _, n, _ in declared})
    parts = [f"Tests over shapes (the unit: one mean per shape and method, {rows[0]['n']} shapes): OSILA against "
             "each method; shapes where OSILA is better / tied / worse; median over shapes of OSILA minus the method "
             "(negative = OSILA lower) with a bootstrap 95% CI; two-sided Wilcoxon signed-rank p."]
    if conf:
        parts.append(f"CONFIRMATORY family, declared in advance ({stats.CONFIRMATORY_METRIC}, OSILA against each "
                     f"baseline, N = {', '.join(map(str, ns))}): {len(conf)} distinct tests, Holm-corrected within "
                     "the family:\n" + "\n".join(_table(head, [line(r) for r in conf])))
    if expl:
        parts.append(f"EXPLORATORY ({len(expl)} tests: raw p, no correction; descriptions, not evidence on their "
                     "own):\n" + "\n".join(_table(head, [line(r) for r in expl])))
    if said:
        parts.append("Said once (equal on every pair, every metric; their tests are the other method's):\n"
                     + "\n".join(f"  {text}" for text in said))
    return "\n\n".join(parts)


def _said_once(rows: list[dict[str, Any]]) -> list[str]:
    """'method = other (N = 1, 2)' lines for the duplicate test rows, one per method pair."""
    where: dict[tuple[str, str], list[int]] = {}
    for r in rows:
        if r["same_as"] is not None:
            ns = where.setdefault((r["method"], r["same_as"]), [])
            if r["segments"] not in ns:
                ns.append(r["segments"])
    return [f"{m} = {other}" + (" (a tie with OSILA)" if other == "osila" else "") + f" at N = {', '.join(map(str, ns))}"
            for (m, other), ns in where.items()]


def _p(p: float) -> str:
    if not np.isfinite(p):
        return "n/a"
    return "< 1e-300" if p == 0 else (f"{p:.2g}" if p < 0.001 else f"{p:.3f}")


def headline(result: GridResult) -> str:
    """The headline: one table per headline metric (:data:`hila_lang.metrics.METRICS`), every method."""
    names = [n for n in result.metrics if info_of(n).headline]
    names.sort(key=lambda n: not info_of(n).time_free)  # the time-free scores first
    return "\n\n".join(format_metric_table(result, n) for n in names)


def render(result: GridResult, tables: bool = True) -> str:
    """Everything ``hila eval`` prints: the headline tables, the summary, the tests over shapes, then
    Tables I–III (``tables``)."""
    parts = [headline(result), format_summary(result), format_tests(result)]
    if tables and "osila" in result.methods:
        label = ("TABLES I-III: OSILA in the paper's layout, the paper's protocol on the stand-in"
                 if _with_paper(result) else
                 f"TABLES I-III: OSILA in the paper's layout ({result.protocol} protocol; the paper's figures "
                 "are shown only with --protocol paper on the stand-in)")
        parts += [label, format_table1(result), format_table2(result), format_table3(result)]
        if len(result.methods) > 1:
            parts.append(format_table1_methods(result))
        if result.protocol == "paper":
            parts.append(format_claims(result))
    return "\n\n".join(p for p in parts if p) + "\n"
