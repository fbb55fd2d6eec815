"""Demonstration files: a path as CSV and its scene ICPs as YAML (``hila learn``, ``hila eval``).

CSV: a header line ``t,x,y``, ``t,x,y,z``, ``x,y`` or ``x,y,z`` (t in seconds, strictly
increasing; x, y, z in metres or pixels), optionally followed by a ``pen`` column, then one row per
waypoint; blank lines and lines starting with ``#`` are skipped.  ``pen`` records the pen's
contact with the surface at each waypoint: ``1`` down (touching, inking), ``0`` up -- what a
drawing's pointer events say (``pointerdown`` / ``pointerup``) and what a camera demonstration
tracks; ``hila learn`` then cuts where the pen touches and leaves the paper
(:func:`hila_lang.osila.segmentation.contact_segments`).  ICPs: a YAML mapping
``name: [x, y(, z)]``, or a task file's ``icps:`` mapping.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..core.errors import InputError
from ..core.fileio import load_yaml, read_text
from .template import MAX_COORDINATE, check_coordinates

#: the headers a demonstration CSV may have (each also with a last column ``pen``)
HEADERS = (["t", "x", "y"], ["t", "x", "y", "z"], ["x", "y"], ["x", "y", "z"])


class Demo(NamedTuple):
    """A demonstration file's contents: ``path`` (T, D), ``times`` (T,) seconds or None, ``pen``
    (T,) bool (True: the pen touches the surface) or None when the file has no ``pen`` column."""

    path: np.ndarray
    times: np.ndarray | None
    pen: np.ndarray | None


def read_demo_csv(path: str | Path):
    """Read a demonstration CSV: returns (path (T, D), times (T,) or None) (:func:`read_demo`
    without the pen)."""
    demo = read_demo(path)
    return demo.path, demo.times


def read_demo(path: str | Path) -> Demo:
    """Read a demonstration CSV, its ``pen`` column included when it has one.

    Raises InputError naming the file and line for a bad header, a ragged row, a non-number,
    a pen value other than 0 or 1, non-increasing times or no data rows.
    """
    text = read_text(path, "demonstration CSV")
    rows = []
    for no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if line and not line.startswith("#"):
            rows.append((no, raw, [c.strip() for c in line.split(",")]))
    if not rows:
        raise InputError("demonstration CSV is empty; expected a header 't,x,y[,z]' and rows", file=str(path))
    no, raw, header = rows[0]
    header = [h.lower() for h in header]
    has_pen = header[-1:] == ["pen"]
    if (header[:-1] if has_pen else header) not in HEADERS:
        raise InputError(
            f"expected the header 't,x,y', 't,x,y,z', 'x,y' or 'x,y,z' (each optionally with a last "
            f"column 'pen'), got {','.join(header)!r}",
            file=str(path), line=no, source_line=raw,
        )
    data = []
    for no, raw, cells in rows[1:]:
        if len(cells) != len(header):
            raise InputError(
                f"expected {len(header)} columns ({','.join(header)}), got {len(cells)}",
                file=str(path), line=no, source_line=raw,
            )
        values = []
        for name, cell in zip(header, cells):
            try:
                v = float(cell)
            except ValueError:
                v = None
            if v is None or not np.isfinite(v):
                raise InputError(
                    f"expected a finite number in column {name!r}, got {cell!r}",
                    file=str(path), line=no, source_line=raw,
                )
            if name == "pen" and v not in (0.0, 1.0):
                raise InputError(
                    f"expected 1 (pen down, touching) or 0 (pen up) in column 'pen', got {cell!r}",
                    file=str(path), line=no, source_line=raw,
                )
            if name not in ("t", "pen") and abs(v) > MAX_COORDINATE:
                raise InputError(
                    f"expected a coordinate within +-{MAX_COORDINATE:g} in column {name!r}, got {cell!r}",
                    file=str(path), line=no, source_line=raw, hint="a demonstration's units are metres or pixels",
                )
            values.append(v)
        if data and header[0] == "t" and values[0] <= data[-1][1][0]:
            raise InputError(
                f"expected increasing times in column 't', got {values[0]!r} after {data[-1][1][0]!r}",
                file=str(path), line=no, source_line=raw,
            )
        data.append((no, values))
    if not data:
        raise InputError("demonstration CSV has a header but no data rows", file=str(path))
    arr = np.array([v for _, v in data])
    pen = arr[:, -1] > 0.5 if has_pen else None
    if has_pen:
        arr = arr[:, :-1]
    if header[0] == "t":
        return Demo(arr[:, 1:], arr[:, 0], pen)
    return Demo(arr, None, pen)


def demo_csv(path: np.ndarray, times: np.ndarray | None = None, pen: np.ndarray | None = None) -> str:
    """The CSV text :func:`read_demo` reads: ``path`` (T, D), optional ``times`` (T,) and ``pen``
    (T,) bool; floats written with ``repr`` precision (a round trip is exact)."""
    path = np.asarray(path, dtype=float)
    header = ["t"] * (times is not None) + ["x", "y", "z"][:path.shape[1]] + ["pen"] * (pen is not None)
    rows = [",".join(header)]
    for i, p in enumerate(path):
        cells = ([repr(float(times[i]))] if times is not None else []) + [repr(float(v)) for v in p]
        rows.append(",".join(cells + ([str(int(bool(pen[i])))] if pen is not None else [])))
    return "\n".join(rows) + "\n"


def load_icps(path: str | Path, dim: int) -> dict:
    """Read ICPs from YAML: a mapping name -> [x, y(, z)], or a task file's 'icps' mapping."""
    doc = load_yaml(path, "scene ICP file", unique_keys=True)
    if isinstance(doc, dict) and isinstance(doc.get("icps"), dict):
        doc = doc["icps"]
    if not isinstance(doc, dict) or not doc:
        got = "an empty file" if not doc else type(doc).__name__
        raise InputError(f"expected a mapping of ICPs 'name: [x, y{', z' if dim == 3 else ''}]', got {got}", file=str(path))
    for name, point in doc.items():
        if not (isinstance(point, list) and len(point) == dim and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in point)):
            raise InputError(f"expected ICP {name!r} as {dim} numbers (the demonstration's D), got {point!r}", file=str(path))
        if not np.isfinite(point).all():
            raise InputError(f"expected finite numbers for ICP {name!r}, got {point!r}", file=str(path))
        check_coordinates(point, f"ICP {name!r}", str(path))
    return {str(k): v for k, v in doc.items()}
