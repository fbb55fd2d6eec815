"""Demonstration files: a path as CSV and its scene ICPs as YAML (``hila learn``, ``hila eval``).

CSV: a header line ``t,x,y``, ``t,x,y,z``, ``x,y`` or ``x,y,z`` (t in seconds, strictly
increasing; x, y, z in metres or pixels), then one row per waypoint; blank lines and lines starting
with ``#`` are skipped.  ICPs: a YAML mapping ``name: [x, y(, z)]``, or a task file's ``icps:``
mapping.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.fileio import load_yaml, read_text
from .template import MAX_COORDINATE, check_coordinates

def read_demo_csv(path: str | Path):
    """Read a demonstration CSV: returns (path (T, D), times (T,) or None).

    Raises InputError naming the file and line for a bad header, a ragged row, a non-number,
    non-increasing times or no data rows.
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
    if header not in (["t", "x", "y"], ["t", "x", "y", "z"], ["x", "y"], ["x", "y", "z"]):
        raise InputError(
            f"expected the header 't,x,y', 't,x,y,z', 'x,y' or 'x,y,z', got {','.join(header)!r}",
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
            if name != "t" and abs(v) > MAX_COORDINATE:
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
    if header[0] == "t":
        return arr[:, 1:], arr[:, 0]
    return arr, None


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
