"""Files ``hila eval`` writes: the text tables, a long CSV of every pair, JSON, heatmap PNGs.

- ``tables.txt``         what was printed (summary, paired tests, Tables I–III)
- ``pairs.csv``          one row per method × N × evaluated (template, task) pair: every metric
                         and the generation time
- ``results.json``       the contract (:func:`results_dict`): ``summary`` rows
                         ``{"method", "n", "r", "msd", "frechet", "dtw", ...}`` (means over pairs
                         of different trials), ``tests`` rows ``{"method", "segments", "metric",
                         "unit", "n", "family", "same_as", "osila_better_share", "tied_share",
                         "osila_worse_share", "p_value", "p_holm", "median_diff", "ci_low",
                         "ci_high"}`` for every other method (:mod:`.stats`; ``p_holm`` within
                         the declared ``confirmatory`` family only), ``duplicates`` (per N: a
                         method -> the method it equals on every pair), plus run
                         facts, per-set-up means, OSILA's Tables I–III (ICP data sets) and the
                         paper's figures (paper protocol on the stand-in).  Byte-identical for the
                         same data, seed and options, whatever the backend
- ``timings.json``       what varies from run to run: backend, wall time, ms per path
- ``heatmap_r_osila.png``, ``heatmap_msd_osila.png``
                         OSILA's J × J matrices of the paper's measures (``Metric.paper``: R and
                         MSD), one panel per N; x = input (template) trial, y = output (task)
                         trial, grouped by set-up as in Table II

Every file is written atomically (:mod:`hila_lang.core.fileio`).  The PNGs are drawn with OpenCV
(matplotlib is not a dependency), each on the scale of its metric's kind: a correlation on a fixed
scale 0.5–1 (lower values clip to the darkest colour), a distance on a log scale 1–10⁴.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from ..core.fileio import atomic_write_text, write_png
from ..metrics import metric, metric as info_of
from . import paper, stats, tables
from .run import GridResult

PANEL = 300  # target panel size, pixels (cells are PANEL // J pixels, at least 1)


def write_csv(result: GridResult, path: Path) -> Path:
    """Every evaluated pair's scores, long format."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["method", "segments", "template", "template_setup", "task", "task_setup", *result.metrics, "seconds"])
    setups = [label.split("/")[0] for label in result.labels]
    rows, cols = np.nonzero(result.mask)
    for m in result.methods:
        for s, n in enumerate(result.segments):
            for i, j in zip(rows.tolist(), cols.tolist()):
                w.writerow([m, n, result.labels[i], setups[i], result.labels[j], setups[j],
                            *(repr(float(v)) for v in result.scores[m][s, i, j]),
                            f"{result.seconds[m][s, i, j]:.6g}"])
    return atomic_write_text(path, buf.getvalue())


def _clean(x: Any) -> Any:
    """NaN -> None recursively (JSON has no NaN)."""
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, np.ndarray):
        return _clean(x.tolist())
    if isinstance(x, (float, np.floating)):
        return None if not np.isfinite(x) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def timings_dict(result: GridResult) -> dict[str, Any]:
    """The ``timings.json`` document: the backend, wall time and ms per path (what varies run to run)."""
    return _clean({"backend": result.backend, "wall_seconds": result.wall_seconds,
                   "ms_per_path": [{"method": r["method"], "n": r["n"], "ms_per_path": r["ms_per_path"]}
                                   for r in stats.summary_rows(result)]})


def results_dict(result: GridResult, info: dict[str, Any] | None = None) -> dict[str, Any]:
    """The ``results.json`` document (module docstring); NaN becomes null.  Nothing in it depends on
    the clock or the backend: the same data, seed and options give the same bytes."""
    summary = stats.summary_rows(result)
    for row in summary:
        del row["ms_per_path"]  # timings.json
    doc: dict[str, Any] = {
        "run": {"trials": len(result.labels),
                "pairs": int(stats.distinct_pairs(result).sum()), "protocol": result.protocol,
                "setups": result.setups, "segments": list(result.segments), "methods": list(result.methods),
                "metrics": list(result.metrics),
                "kind": {name: metric(name).kind for name in result.metrics},
                "better": {name: metric(name).better for name in result.metrics},
                "time_free": {name: metric(name).time_free for name in result.metrics}, **(info or {})},
        "summary": summary,
        "confirmatory": {"note": "declared before any run: the headline metric, OSILA against each baseline, "
                                 "N >= 2 (N = 1 where the protocol has no other); p_holm within it only",
                         "tests": [list(t) for t in stats.confirmatory(result)]},
        "duplicates": {str(n): same for n, same in stats.duplicates(result).items()},
        "tests": stats.test_rows(result),
        "by_setup": stats.by_setup(result),
        "failures": {m: result.failures[m] for m in result.methods},
    }
    if "osila" in result.methods and result.mask.all():
        doc["tables"] = {"layout": "table_ii/table_iii are [N index][output set-up][input set-up]; "
                                   "table_i is [N index][set-up]",
                         "table_i": tables.table1(result), "table_ii": tables.table2(result),
                         "table_iii": tables.table3(result),
                         "controls": {m: {"table_i": tables.table1(result, m), "table_ii": tables.table2(result, m),
                                          "table_iii": tables.table3(result, m)}
                                      for m in result.methods if m != "osila"}}
        if result.protocol == "paper":
            doc["tables"]["claims"] = tables.claims(result)
    if tables._with_paper(result):
        doc["paper"] = {"note": "reference figures of Wu & Demiris (2010) on their human data, not ours",
                        "table_i": paper.TABLE_I, "table_ii": paper.TABLE_II, "table_iii": paper.TABLE_III,
                        "claims": paper.CLAIMS}
    return _clean(doc)


def _colour(values01: np.ndarray) -> np.ndarray:
    # lazy: loads cv2, which importing this module does not
    import cv2

    v = np.clip(np.nan_to_num(values01, nan=0.0), 0.0, 1.0)
    img = cv2.applyColorMap((v * 255).astype(np.uint8), cv2.COLORMAP_VIRIDIS)
    img[np.isnan(values01)] = (128, 128, 128)
    return img


def heatmap(result: GridResult, method: str, metric: str) -> np.ndarray:
    """A BGR image: one panel per N, set-up grid lines and names, a colour bar."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    data, info = result.metric(method, metric), info_of(metric)
    if info.kind == "correlation":
        lo, hi = 0.5, 1.0
        ticks = [(0.0, "<=0.5"), (0.5, "0.75"), (0.8, "0.9"), (1.0, "1")]
        scaled = (data - lo) / (hi - lo)
        title = f"{method}: correlation {info.title} (x: input/template, y: output/task)"
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            scaled = np.log10(np.maximum(data, 1e-12)) / 4.0
        ticks = [(0.0, "<=1"), (0.25, "10"), (0.5, "100"), (0.75, "1000"), (1.0, ">=1e4")]
        title = f"{method}: {info.title}, log scale (x: input/template, y: output/task)"
    J = data.shape[1]
    cell = max(1, PANEL // J)
    side = cell * J
    margin_l, margin_t, gap, bar_w = 60, 50, 20, 18
    S = len(result.segments)
    width = margin_l + S * (side + gap) + 70
    height = margin_t + side + 50
    img = np.full((height, width, 3), 255, np.uint8)
    font = cv2.FONT_HERSHEY_SIMPLEX
    cv2.putText(img, title, (10, 20), font, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    bounds = np.flatnonzero(np.diff(result.trial_setup)) + 1
    centres = [(a + b) / 2 for a, b in zip(np.r_[0, bounds], np.r_[bounds, J])]
    for s, n in enumerate(result.segments):
        x0 = margin_l + s * (side + gap)
        panel = _colour(scaled[s].T)  # rows: task (output), columns: template (input)
        panel = cv2.resize(panel, (side, side), interpolation=cv2.INTER_NEAREST)
        for b in bounds:
            panel[:, b * cell] = 255
            panel[b * cell, :] = 255
        img[margin_t : margin_t + side, x0 : x0 + side] = panel
        cv2.putText(img, f"N = {n}", (x0 + side // 2 - 20, margin_t - 8), font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
        for k, c in enumerate(centres):
            name = result.setups[k][:6]
            cv2.putText(img, name, (x0 + int(c * cell) - 12, margin_t + side + 14), font, 0.33, (0, 0, 0), 1,
                        cv2.LINE_AA)
            if s == 0:
                cv2.putText(img, name, (5, margin_t + int(c * cell) + 4), font, 0.33, (0, 0, 0), 1, cv2.LINE_AA)
    bx = margin_l + S * (side + gap)
    grad = np.linspace(1.0, 0.0, side)[:, None].repeat(bar_w, 1)
    img[margin_t : margin_t + side, bx : bx + bar_w] = _colour(grad)
    for v, text in ticks:
        y = margin_t + int((1 - v) * (side - 1))
        cv2.putText(img, text, (bx + bar_w + 3, y + 4), font, 0.33, (0, 0, 0), 1, cv2.LINE_AA)
    return img


def write_report(result: GridResult, text: str, out: Path, info: dict[str, Any] | None = None) -> list[Path]:
    """Write every output file into ``out``; returns the paths written."""
    out = Path(out)
    written = [atomic_write_text(out / "tables.txt", text), write_csv(result, out / "pairs.csv"),
               atomic_write_text(out / "results.json", json.dumps(results_dict(result, info), indent=1) + "\n"),
               atomic_write_text(out / "timings.json", json.dumps(timings_dict(result), indent=1) + "\n")]
    if "osila" in result.methods and result.mask.all():
        # lazy: only this branch needs it
        from ..metrics import metric as info_of

        for metric in (name for name in result.metrics if info_of(name).paper):
            written.append(write_png(out / f"heatmap_{metric}_osila.png", heatmap(result, "osila", metric), bgr=True))
    return written
