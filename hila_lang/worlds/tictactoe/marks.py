"""The marks on the paper: the opponent's hand-drawn crosses and measures of the robot's circles.

Pure numpy (plus :mod:`hila_lang.metrics`); every point is world frame, metres.
"""

from __future__ import annotations

import numpy as np

from ...metrics import correlation, resample
from ...osila.fallback import fit_similarity
from ...sim.surface import CONTACT_TOLERANCE
from .board import cell_center, Grid

#: half the length of a cross's bar, as a fraction of the cell size
CROSS_HALF = 0.30
#: a sloppy cross: turned by up to this many degrees, and over one of its cell's grid lines by
#: this much (metres, low and high)
SLOPPY_TURN_DEG = 40.0
SLOPPY_OVERLAP = (0.002, 0.005)


def cross_strokes(spec: Grid, cell: int, rng: np.random.Generator,
                  points_per_stroke: int = 12, *, sloppy: bool = False) -> list[np.ndarray]:
    """Two hand-drawn strokes of a cross in ``cell`` on the paper, each shape (N, 3).

    The bars run along the cell's diagonals with seeded jitter in length, angle and position,
    like a person's cross.  A ``sloppy`` cross is turned by up to :data:`SLOPPY_TURN_DEG`, its
    bars more uneven, and it is drawn off-centre towards one of the cell's grid lines (a side
    shared with another cell), which one of its bars crosses by 2-5 mm; its centre stays in
    its cell.
    """
    size = spec.grid_size / 3
    centre = spec.world_to_grid(cell_center(spec, cell)) + rng.normal(scale=0.04 * size, size=2)
    turn = np.radians(rng.uniform(-SLOPPY_TURN_DEG, SLOPPY_TURN_DEG)) if sloppy else 0.0
    bars = []
    for base in (np.pi / 4, -np.pi / 4):
        angle = base + turn + rng.normal(scale=0.15 if sloppy else 0.08)
        half = CROSS_HALF * size * np.sqrt(2) * rng.uniform(*((0.75, 1.1) if sloppy else (0.85, 1.05)))
        d = np.array([np.cos(angle), np.sin(angle)])
        t = np.linspace(-half, half, points_per_stroke)[:, None]
        bow = np.sin(np.linspace(0, np.pi, points_per_stroke))[:, None] * rng.normal(scale=0.02 * size)
        bars.append(t * d + bow * np.array([-d[1], d[0]]))
    if sloppy:
        row, col = divmod(cell - 1, 3)
        # the sides of the cell that are grid lines, as unit (right, far) directions
        sides = [np.array(v, float) for v, ok in (((1, 0), col < 2), ((-1, 0), col > 0),
                                                   ((0, 1), row > 0), ((0, -1), row < 2)) if ok]
        side = sides[int(rng.integers(len(sides)))]
        reach = max(float((bar @ side).max()) for bar in bars)
        along = size / 2 + rng.uniform(*SLOPPY_OVERLAP) - reach
        centre = spec.world_to_grid(cell_center(spec, cell)) + along * side \
            + rng.uniform(-0.1, 0.1) * size * side[::-1]
    return [spec.grid_to_world(*(centre + bar).T) for bar in bars]


def similarity_align(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``source`` mapped by the best similarity (rotation, uniform scale, translation) onto ``target``.

    Umeyama's least-squares solution (reflections excluded), from
    :func:`hila_lang.osila.fallback.fit_similarity`; a ``source`` of one repeated point goes to
    the centroid of ``target``.

    Parameters
    ----------
    source, target : ndarray, shape (N, D)
        Corresponding points.

    Returns
    -------
    ndarray, shape (N, D)
    """
    src = np.asarray(source, dtype=float)
    dst = np.asarray(target, dtype=float)
    if not np.ptp(src, axis=0).any():
        return np.repeat(dst.mean(axis=0)[None], len(src), axis=0)
    scale, rot, shift = fit_similarity(src, dst, rank=src.shape[1])
    return scale * src @ rot.T + shift


def by_arc_length(path: np.ndarray, n: int) -> np.ndarray:
    """``path`` (T, D) re-sampled at ``n`` points evenly spaced along its length (linear)."""
    path = np.asarray(path, dtype=float)
    step = np.linalg.norm(np.diff(path, axis=0), axis=1)
    keep = np.concatenate([[True], step > 1e-9])
    path = path[keep]
    s = np.concatenate([[0.0], np.cumsum(step[step > 1e-9])])
    if len(path) < 2 or s[-1] == 0:
        return np.repeat(path[:1], n, axis=0)
    u = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(u, s, path[:, k]) for k in range(path.shape[1])])


def mark_correlation(drawn: np.ndarray, demonstrated: np.ndarray, n: int = 200) -> float:
    """Per-mark R: the drawn circle against the demonstrated one after similarity alignment.

    Ink has no timing (the robot draws at its own speed), so both paths are first spread evenly
    along their length (:func:`by_arc_length`), then brought to ``n`` points by cubic spline
    (:func:`hila_lang.metrics.resample`, the paper's equal-length step); the drawn one is
    aligned onto the demonstrated one (:func:`similarity_align`), and R is the paper's eq. 1
    (:func:`hila_lang.metrics.correlation`).
    """
    m = max(len(drawn), len(demonstrated), n)
    a = resample(by_arc_length(drawn, m), n)
    b = resample(by_arc_length(demonstrated, m), n)
    return float(correlation(similarity_align(a, b), b))


def tracking_error(planned: np.ndarray, executed: np.ndarray, step: float = 0.0002,
                   prefix: bool = False) -> np.ndarray:
    """Distance (metres) of every executed point to the planned polyline, shape (T',).

    The planned path is densified to ``step`` metres and the nearest point found with a k-d tree.
    With ``prefix`` the executed trace's first point is put in front of the plan: a back end
    moves straight from where the pen was to the plan's first waypoint, and that move is part
    of what it was asked to do.
    """
    # lazy: loads scipy, which importing this module does not
    from scipy.spatial import cKDTree

    planned = np.asarray(planned, dtype=float)
    executed = np.asarray(executed, dtype=float)
    if prefix and len(executed):
        planned = np.vstack([executed[:1], planned])
    if len(planned) == 1:
        return np.linalg.norm(executed - planned[0], axis=1)
    dense = [planned[:1]]
    for p, q in zip(planned[:-1], planned[1:]):
        k = max(int(np.ceil(np.linalg.norm(q - p) / step)), 1)
        dense.append(p + np.linspace(0, 1, k + 1)[1:, None] * (q - p))
    dist, _ = cKDTree(np.vstack(dense)).query(executed)
    return dist


def outside_cell(spec: Grid, cell: int, points: np.ndarray) -> float:
    """How far (metres) the farthest of ``points`` lies outside ``cell``, seen from above; 0 inside."""
    size = spec.grid_size / 3
    centre = spec.world_to_grid(cell_center(spec, cell))
    g = spec.world_to_grid(np.asarray(points, dtype=float)) - centre
    excess = np.abs(g) - size / 2
    return float(max(excess.max(), 0.0))


def on_paper(path: np.ndarray, surface_z: float) -> np.ndarray:
    """The points of ``path`` (T, 3) at most :data:`CONTACT_TOLERANCE` above the paper (or below it), (T', 3)."""
    path = np.asarray(path, dtype=float)
    return path[path[:, 2] - surface_z <= CONTACT_TOLERANCE]
