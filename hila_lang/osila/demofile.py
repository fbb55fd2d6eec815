"""Demonstration files: a path as CSV and its scene ICPs as YAML, read and written here only.

CSV: a header line ``t,x,y``, ``t,x,y,z``, ``x,y`` or ``x,y,z`` (t in seconds, strictly
increasing; x, y, z in metres or pixels), optionally followed by a ``pen`` column, then one row per
waypoint; blank lines and lines starting with ``#`` are skipped.  ``pen`` records the pen's
contact with the surface at each waypoint: ``1`` down (touching, inking), ``0`` up -- what a
drawing's pointer events say (``pointerdown`` / ``pointerup``) and what a camera demonstration
tracks; ``hila learn`` then cuts where the pen touches and leaves the paper
(:func:`hila_lang.osila.segmentation.contact_segments`).  ICPs: a YAML mapping
``name: [x, y(, z)]``, or a task file's ``icps:`` mapping.

The readers (:func:`read_demo`, :func:`read_demo_csv`, :func:`load_icps`) serve ``hila learn`` and
``hila eval``; the writers (:func:`demo_csv`, :func:`write_demo_csv`, :func:`icps_text`,
:func:`write_icps`) serve everything that makes such files -- ``hila imitate``'s output, the
studio's saved demonstrations, ``hila learn --sheet``'s tracked pen, the letters' handwriting
model, ``hila eval``'s stand-in data set -- so every one is a file the readers take.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..core.errors import InputError
from ..core.fileio import atomic_write_text, load_yaml, read_text, yaml_text
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


def demo_csv(path, times=None, pen=None, *, decimals: int | None = None, time_decimals: int | None = None) -> str:
    """The CSV text :func:`read_demo` reads: ``path`` (T, D), optional ``times`` (T,) and ``pen``
    (T,) bool; the header ``t,x,y[,z][,pen]`` (without ``t`` when there are no times), one row per
    waypoint.

    Floats are written exactly (``repr`` round-trips) unless ``decimals`` (coordinates) and
    ``time_decimals`` (times; default ``decimals``) fix the digits after the point.
    """
    path = np.asarray(path, float)
    times = None if times is None else np.asarray(times, float)
    pen = None if pen is None else np.asarray(pen, bool)
    if path.ndim != 2 or path.shape[1] not in (2, 3) or any(a is not None and a.shape != (len(path),)
                                                             for a in (times, pen)):
        raise InputError(f"expected a path (T, 2 or 3) and T times, got {path.shape} and "
                         f"{None if times is None else times.shape}"
                         + ("" if pen is None else f" and {pen.shape} pen states"))
    time_decimals = decimals if time_decimals is None else time_decimals

    def cell(v: float, digits: int | None) -> str:
        return repr(float(v)) if digits is None else f"{v:.{digits}f}"

    header = ["t"] * (times is not None) + ["x", "y", "z"][: path.shape[1]] + ["pen"] * (pen is not None)
    rows = [",".join(header)]
    for i, p in enumerate(path):
        cells = ([cell(times[i], time_decimals)] if times is not None else []) + [cell(v, decimals) for v in p]
        rows.append(",".join(cells + ([str(int(pen[i]))] if pen is not None else [])))
    return "\n".join(rows) + "\n"


def write_demo_csv(file: str | Path, path, times=None, pen=None, **digits) -> Path:
    """Write :func:`demo_csv` to ``file`` atomically; ``digits`` as there."""
    return atomic_write_text(file, demo_csv(path, times, pen, **digits))


def icps_text(icps: dict, header: str = "") -> str:
    """Scene ICPs ``name -> point`` as the YAML mapping :func:`load_icps` reads."""
    return yaml_text({str(k): [float(v) for v in p] for k, p in icps.items()}, header=header)


def write_icps(file: str | Path, icps: dict, header: str = "") -> Path:
    """Write :func:`icps_text` to ``file`` atomically."""
    return atomic_write_text(file, icps_text(icps, header))
