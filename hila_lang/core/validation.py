"""Array checks at the library boundary: say what was expected and what came.

Every public numerical entry point (``osila.imitate``, ``metrics``, ``segmentation``) converts
its inputs with these helpers, so a bad shape, NaN/inf or an empty array becomes an
:class:`~hila_lang.core.errors.InputError` (a ``ValueError``) naming the argument, and the code
inside can trust its arrays: validated at the boundary, trusted inside.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import InputError

DIMS = (2, 3)


def _as_float(value: Any, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"expected {name} as numbers, got {type(value).__name__} ({exc})") from None
    return arr


def check_finite(arr: np.ndarray, name: str) -> np.ndarray:
    """Raise :class:`InputError` naming the first non-finite entry of ``arr``."""
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InputError(f"expected finite {name}, got {arr[idx]} at index {idx}")
    return arr


def check_path(path: Any, name: str = "path", *, min_len: int = 1) -> np.ndarray:
    """Return ``path`` as a float array of shape (T, D), D in {2, 3}, T >= ``min_len``, all finite."""
    arr = _as_float(path, name)
    if arr.ndim != 2 or arr.shape[1] not in DIMS:
        raise InputError(f"expected {name} of shape (T, D) with D in {{2, 3}}, got {arr.shape}")
    if arr.shape[0] < min_len:
        what = "an empty path" if arr.shape[0] == 0 else f"{arr.shape[0]} points"
        raise InputError(f"expected {name} with at least {min_len} point(s), got {what}")
    return check_finite(arr, name)


def check_points(points: Any, dim: int, name: str, *, allow_empty: bool = False, width: str | None = None) -> np.ndarray:
    """Return ``points`` as a float array of shape (K, ``dim``), all finite.

    A single point of shape (``dim``,) is accepted as (1, ``dim``).  ``K = 0`` is an error unless
    ``allow_empty``.  ``width`` says in the error what the ``dim`` columns are (default: the
    path's D).
    """
    arr = _as_float(points, name)
    if arr.ndim == 1 and arr.shape[0] == dim:
        arr = arr[None, :]
    if arr.ndim == 1 and arr.size == 0:
        arr = arr.reshape(0, dim)
    if arr.ndim != 2 or arr.shape[1] != dim:
        width = width or f"to match the path's D = {dim}"
        raise InputError(f"expected {name} of shape (K, {dim}) {width}, got {arr.shape}")
    if arr.shape[0] == 0 and not allow_empty:
        raise InputError(f"expected at least one point in {name} (K >= 1), got K = 0")
    return check_finite(arr, name)


def check_positive(value: Any, name: str, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a finite float > 0 (or >= 0 with ``allow_zero``)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"expected {name} as a number, got {value!r}") from None
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):  # (math: 1 us less than numpy a call)
        bound = ">= 0" if allow_zero else "> 0"
        raise InputError(f"expected {name} {bound}, got {value!r}")
    return x


def check_int(value: Any, name: str, *, minimum: int = 0) -> int:
    """Return ``value`` as an int >= ``minimum`` (bools are refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"expected {name} as an integer, got {value!r}")
    if value < minimum:
        raise InputError(f"expected {name} >= {minimum}, got {value}")
    return int(value)
