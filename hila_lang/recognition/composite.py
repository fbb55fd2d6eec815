"""Composite demonstrations with known parts, made at run time (for bench/recognise.py and tests).

A composite is a chain of shapes joined by *free moves* (straight minimum-jerk moves with a
slight bow, 0.4–1.0 s, from where one shape ends to where the next begins), each shape
independently turned (any angle), scaled (0.5–2×), placed, re-timed (0.5–2× speed, with a smooth
non-uniform warp inside the shape) and the whole path tracked with noise.  Every random choice
comes from one seed.  The truth is the sample range of each shape and its label (``None`` for a
distractor, a shape not in the library).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..osila.motion import minimum_jerk_samples


@dataclass
class Composite:
    """A made demonstration: ``path`` (T, 2), ``times`` (T,), and ``parts``: (start, end, label or None)."""

    path: np.ndarray
    times: np.ndarray
    parts: list[tuple[int, int, str | None]]


def _retime(shape: np.ndarray, rate_in: float, rate_out: float, speed: float, warp: float) -> np.ndarray:
    """``shape`` sampled at ``rate_in`` Hz, replayed ``speed`` × faster with warp τ + warp·sin(πτ)/π, at ``rate_out`` Hz."""
    duration = (len(shape) - 1) / rate_in / speed
    n = max(int(round(duration * rate_out)) + 1, 4)
    tau = np.linspace(0.0, 1.0, n)
    tau = tau + warp * np.sin(np.pi * tau) / np.pi  # monotone for |warp| < 1
    u = tau * (len(shape) - 1)
    return np.column_stack([np.interp(u, np.arange(len(shape)), shape[:, d]) for d in range(shape.shape[1])])


def free_move(a: np.ndarray, b: np.ndarray, n: int, bow: float) -> np.ndarray:
    """``n`` samples of a minimum-jerk move from ``a`` to ``b`` bowed sideways by ``bow`` × its length (ends excluded)."""
    s = minimum_jerk_samples(n + 2)[1:-1, None]
    d = b - a
    side = np.array([-d[1], d[0]])
    return a + s * d + np.sin(np.pi * s) * side * bow


def make(shapes: list[tuple[np.ndarray, str | None]], rng: np.random.Generator, *, rate_in: float, rate_out: float,
         noise: float = 0.004, speed=(0.5, 2.0), scale=(0.5, 2.0)) -> Composite:
    """Chain ``shapes`` ((path (n, 2) at ``rate_in`` Hz, label or None), ...) into one composite.

    ``noise``: tracking noise σ as a fraction of the median shape size (bounding-box diagonal,
    before scaling).
    """
    pieces, parts, sizes = [], [], []
    cursor = 0
    where = np.zeros(2)
    for k, (shape, label) in enumerate(shapes):
        shape = np.asarray(shape, float)
        angle = rng.uniform(0, 2 * np.pi)
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        size = float(np.linalg.norm(np.ptp(shape, axis=0)))
        scaled = (shape - shape.mean(0)) @ rot.T * rng.uniform(*scale)
        sizes.append(size)
        moved = _retime(scaled, rate_in, rate_out, rng.uniform(*speed), rng.uniform(-0.3, 0.3))
        offset = where + rng.normal(scale=size, size=2) - moved[0] if k else -moved[0]
        moved = moved + offset
        if k:
            n = int(round(rng.uniform(0.4, 1.0) * rate_out))
            move = free_move(pieces[-1][-1], moved[0], n, rng.uniform(-0.15, 0.15))
            pieces.append(move)
            cursor += len(move)
        parts.append((cursor, cursor + len(moved), label))
        pieces.append(moved)
        cursor += len(moved)
        where = moved[-1]
    path = np.vstack(pieces)
    path = path + rng.normal(scale=noise * float(np.median(sizes)), size=path.shape)
    return Composite(path, np.arange(len(path)) / rate_out, parts)
