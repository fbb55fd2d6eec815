"""Candidate waypoints: a fixed, deterministic set of offsets filling the distortion ball.

Why a ball: adding one more pair (p_t -> q) to an exact TPS raises its bending energy in
proportion to |q - f(p_t)|², so "distortion <= threshold" is the ball of radius ``threshold``
around the mapped point f(p_t) (docs/design.md §2.2; the paper's 2-pixel relaxation).

The set is the centre plus ``shells`` concentric shells at radii threshold·i/shells,
i = 1..shells, each with ``directions`` unit directions: evenly spaced angles in 2-D (every other
shell turned by half a step), and in 3-D the 6 axis and 8 diagonal directions of a cube for the
default 14, or a Fibonacci sphere for any other count.  The same offsets serve every time stamp,
which lets the route search precompute the pairwise offset costs once.  Every candidate lies in
the closed ball, so any chosen waypoint is within ``threshold`` of its mapped point.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

DEFAULT_SHELLS = 2
DEFAULT_DIRECTIONS = {2: 8, 3: 14}


def unit_directions(dim: int, count: int, turn: float = 0.0) -> np.ndarray:
    """``count`` deterministic unit vectors in ``dim`` dimensions, shape (count, dim).

    ``turn`` (a fraction of the angular step) rotates the 2-D set; it is ignored in 3-D.
    """
    if dim == 2:
        ang = 2 * np.pi * (np.arange(count) + turn) / count
        return np.column_stack([np.cos(ang), np.sin(ang)])
    if count == 14:
        axes = np.vstack([np.eye(3), -np.eye(3)])
        diag = np.array([[x, y, z] for x in (1, -1) for y in (1, -1) for z in (1, -1)], float) / np.sqrt(3)
        return np.vstack([axes, diag])
    i = np.arange(count) + 0.5
    z = 1 - 2 * i / count
    phi = np.pi * (1 + 5**0.5) * i
    rho = np.sqrt(1 - z * z)
    return np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])


@lru_cache(maxsize=64)
def ball_offsets(dim: int, threshold: float, shells: int = DEFAULT_SHELLS, directions: int | None = None) -> np.ndarray:
    """Candidate offsets in the ball of radius ``threshold``, shape (1 + shells·directions, dim).

    Row 0 is the centre (zero offset), so ties in the route search resolve to the mapped point.
    ``threshold`` = 0 or ``shells`` = 0 gives the centre alone.  The result is cached and
    read-only.
    """
    if directions is None:
        directions = DEFAULT_DIRECTIONS[dim]
    rows = [np.zeros((1, dim))]
    if threshold > 0 and directions > 0:
        for s in range(1, shells + 1):
            rows.append(threshold * s / shells * unit_directions(dim, directions, turn=0.5 * (s % 2 == 0)))
    out = np.vstack(rows)
    out.flags.writeable = False
    return out
