"""Controls: what one gets from the same constraints with less (or other) use of the demonstration.

Every generator here, and OSILA itself, is a function ``(constraints) -> path (T, D)`` prepared
once per template (:func:`generator`); each gets exactly the :class:`~.protocols.Constraints`
OSILA gets for that pair, and nothing else about the task.  If OSILA cannot beat these, the
demonstration is not what makes its paths good.

``osila``
    :func:`hila_lang.osila.imitate` on the constraint pairs (with their task times, where the
    protocol gives them: OSILA re-times only those pairs).
``none``
    No template shape: a cubic spline in time through the *anchors* (below), at rest at both ends
    (``CubicSpline(bc_type="clamped")``: human point-to-point movements start and end at rest).
``similarity``
    The template moved by the least-squares similarity transform (rotation, uniform scale,
    shift; Umeyama) of the constraint pairs: the demonstration's shape, kept rigid.
``tps``
    The bare thin plate spline through the constraint pairs (:func:`hila_lang.osila.fit_warp`
    without the amplification check), no route, no adjustment: the paper's warp alone.
``dmp``
    A discrete DMP (``movement_primitives.dmp.DMP``, 10 weights per dimension, its default
    gains; the ``peers`` extra) learned from the template in the template's own frame, rolled
    out from anchor to anchor, one DMP per piece between consecutive anchors, stitched.  Each
    roll-out takes at least 50 integration steps (a short piece integrated at the template's
    sampling rate diverges) and is resampled to the piece's length.
``dmp-aligned``
    The same, in the frame of the ``similarity`` transform: the DMP learned from the template
    moved by that similarity.  A DMP's forcing term is fixed in the frame it was learned in;
    across scenes that differ by a rotation ``dmp`` drags the demonstration's directions along,
    which this control removes, so OSILA is compared with a fair DMP.

Anchors (the points ``none`` passes through and the DMPs start and end at) come from the
constraints only: each pair that is a point of the template path (a boundary or time-fraction
pair, or a scene ICP within 1 % of the template's size of its path — the rule by which OSILA's
plan adjustment counts an ICP as a place the route must go, ``osila.adjust.ON_PATH`` — such as
the hand's start) is an anchor at that template time; where the template's
first or last point is not an anchor, its image under the ``similarity`` transform is.

DMP roll-outs use linearity: the DMP's transformation system is linear in start, goal and
forcing term, so a roll-out from ``a`` to ``b`` with forcing ``M f`` is
``b + (a - b)·ψ(t) + M·F(t)``, where ψ is the unforced response from 1 to 0 and F the forced
response from 0 to 0, each integrated once per template piece by ``movement_primitives``
(``M`` = identity for ``dmp``, the similarity's scale × rotation for ``dmp-aligned``, which is
exactly the forcing term learned from the moved template).  The tests check this against direct
roll-outs.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Callable

import numpy as np

from ..core.errors import InputError
from ..metrics import resample
from ..osila.adjust import ON_PATH
from ..osila.fallback import fit_similarity
from ..osila.tps import affine_rank
from .protocols import Constraints

CONTROLS = ("none", "similarity", "tps", "dmp", "dmp-aligned")
DMP_WEIGHTS = 10
#: fewest integration steps of a DMP roll-out (its output is resampled to the piece's length)
MIN_STEPS = 50
#: a scene ICP within this fraction of the template's bounding-box diagonal of its path is an anchor
#: (OSILA's own rule for an ICP on the path)
ANCHOR_TOLERANCE = ON_PATH


def dmp_available() -> bool:
    """True when the optional ``movement_primitives`` package imports."""
    try:
        # lazy: loads movement_primitives, scipy, which importing this module does not
        import movement_primitives.dmp  # noqa: F401
    except ImportError:
        return False
    return True


def require_dmp() -> None:
    """Raise :class:`InputError` with the install hint when the DMP controls cannot run."""
    if not dmp_available():
        raise InputError(
            "the DMP controls need the optional package movement_primitives (and pytransform3d), "
            "which is not installed",
            hint="pip install 'hila-lang[peers]', or leave out dmp and dmp-aligned with --methods",
        )


# ----------------------------------------------------------------------------- shared pieces


def similarity(c: Constraints) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares similarity of the constraint pairs: (scale, R (D, D), shift (D,)), x -> s R x + shift."""
    D = c.src.shape[1]
    rank = affine_rank(c.src)
    if len(c.src) == 1 or rank == 0:
        return 1.0, np.eye(D), c.dst.mean(0) - c.src.mean(0)
    return fit_similarity(c.src, c.dst, rank)


def _apply(sim: tuple[float, np.ndarray, np.ndarray], points: np.ndarray) -> np.ndarray:
    scale, R, shift = sim
    return scale * points @ R.T + shift


def anchors(path: np.ndarray, c: Constraints) -> tuple[np.ndarray, np.ndarray]:
    """Template indices (A,) increasing, and the task points (A, D) the path must pass there."""
    T = len(path)
    tol = ANCHOR_TOLERANCE * float(np.linalg.norm(np.ptp(path, axis=0)))
    at: dict[int, np.ndarray] = {}
    for src, dst, idx in zip(c.src, c.dst, c.at):
        if idx is None:
            d = np.sqrt(((path - src) ** 2).sum(1))
            if d.min() > tol:
                continue
            # the nearest waypoint; the template's first or last point when that is close enough
            # (a resting hand lingers near its start for several samples)
            idx = 0 if d[0] <= tol else T - 1 if d[-1] <= tol else int(d.argmin())
        at[int(idx)] = dst
    if 0 not in at or T - 1 not in at:
        moved = _apply(similarity(c), path[[0, -1]])
        at.setdefault(0, moved[0])
        at.setdefault(T - 1, moved[1])
    order = sorted(at)
    return np.array(order), np.array([at[i] for i in order])


def no_template(path: np.ndarray, c: Constraints) -> np.ndarray:
    """The ``none`` control: a clamped cubic spline in time through the anchors, T points."""
    idx, points = anchors(path, c)
    T = len(path)
    if T == 1 or len(idx) == 1:
        return np.repeat(points[:1], T, axis=0)
    out = _spline_matrix(T, tuple(idx.tolist())) @ points
    out[idx] = points  # through the anchors exactly (the product meets them to rounding)
    return out


@lru_cache(maxsize=4096)
def _spline_matrix(T: int, idx: tuple[int, ...]) -> np.ndarray:
    """(T, A): the clamped spline through anchors at template stamps ``idx``, sampled at every stamp.

    The spline is linear in the anchor points, so its columns are the splines through the unit
    vectors; a grid reuses the same anchor stamps for thousands of tasks.
    """
    # lazy: loads scipy, which importing this module does not
    from scipy.interpolate import CubicSpline

    knots = np.array(idx, float) / (T - 1)
    out = CubicSpline(knots, np.eye(len(idx)), axis=0, bc_type="clamped")(np.linspace(0.0, 1.0, T))
    out.flags.writeable = False
    return out


# ----------------------------------------------------------------------------- DMPs


class DmpControl:
    """``dmp`` and ``dmp-aligned`` for one template: pieces learned once, rolled out per task.

    Parameters
    ----------
    path : ndarray, shape (T, D)
        The template path; time runs from 0 to 1 over it, one DMP step per sample.
    aligned : bool
        True for ``dmp-aligned``.
    """

    def __init__(self, path: np.ndarray, aligned: bool) -> None:
        require_dmp()
        self.path = np.asarray(path, float)
        self.aligned = aligned
        self.dt = 1.0 / max(len(self.path) - 1, 1)
        self._pieces: dict[tuple[int, int], np.ndarray] = {}
        self._unforced: dict[int, np.ndarray] = {}

    def _dmp(self, n_dims: int, steps: int):
        # lazy: loads movement_primitives, scipy, which importing this module does not
        from movement_primitives.dmp import DMP

        # at least MIN_STEPS integration steps per piece: the transformation system's rate grows as
        # 1/execution time, and a short piece integrated at the template's own sampling diverges
        duration = steps * self.dt
        return DMP(n_dims=n_dims, execution_time=duration, dt=min(self.dt, duration / MIN_STEPS),
                   n_weights_per_dim=DMP_WEIGHTS)

    def _rollout(self, dmp, start: np.ndarray, goal: np.ndarray, length: int) -> np.ndarray:
        dmp.configure(start_y=start, goal_y=goal)
        _, y = dmp.open_loop()
        return y if len(y) == length else resample(y, length)

    def forced(self, a: int, b: int) -> np.ndarray:
        """F: the DMP learned from template[a..b] rolled out from 0 to 0, shape (b - a + 1, D)."""
        if (a, b) not in self._pieces:
            piece = self.path[a : b + 1]
            dmp = self._dmp(piece.shape[1], len(piece) - 1)
            dmp.imitate(np.arange(len(piece)) * self.dt, piece)
            zero = np.zeros(piece.shape[1])
            self._pieces[(a, b)] = self._rollout(dmp, zero, zero, len(piece))
        return self._pieces[(a, b)]

    def unforced(self, length: int) -> np.ndarray:
        """ψ: a DMP with no forcing term rolled out from 1 to 0, shape (length,)."""
        if length not in self._unforced:
            dmp = self._dmp(1, length - 1)
            self._unforced[length] = self._rollout(dmp, np.ones(1), np.zeros(1), length)[:, 0]
        return self._unforced[length]

    def piece(self, a: int, b: int, start: np.ndarray, goal: np.ndarray, M: np.ndarray) -> np.ndarray:
        """The roll-out of template[a..b]'s DMP from ``start`` to ``goal`` with forcing M·f."""
        length = b - a + 1
        return goal + (start - goal) * self.unforced(length)[:, None] + self.forced(a, b) @ M.T

    def __call__(self, c: Constraints) -> np.ndarray:
        D = self.path.shape[1]
        if len(self.path) == 1:
            return anchors(self.path, c)[1][:1].copy()
        idx, points = anchors(self.path, c)
        if self.aligned:
            scale, R, _ = similarity(c)
            M = scale * R
        else:
            M = np.eye(D)
        out = [points[:1]]
        for k in range(len(idx) - 1):
            y = self.piece(int(idx[k]), int(idx[k + 1]), points[k], points[k + 1], M)
            y[-1] = points[k + 1]  # a DMP converges to its goal but need not reach it in time
            out.append(y[1:])
        return np.vstack(out)


# ----------------------------------------------------------------------------- the generators


def generator(method: str, path: np.ndarray, options: dict[str, Any]) -> Callable[[Constraints], np.ndarray]:
    """A function constraints -> generated path (T, D) for ``method``, prepared once per template.

    ``options`` go to :func:`hila_lang.osila.imitate` (``osila`` only).
    """
    if method == "osila":
        # lazy: only this branch needs it
        from ..osila import imitate

        return lambda c: imitate(path, c.src, c.dst, task_times=c.times, **options)
    if method == "none":
        return lambda c: no_template(path, c)
    if method == "similarity":
        return lambda c: _apply(similarity(c), path)
    if method == "tps":
        # lazy: only this branch needs it
        from ..osila import fit_warp

        return lambda c: fit_warp(c.src, c.dst)(path)
    if method in ("dmp", "dmp-aligned"):
        return DmpControl(path, aligned=method == "dmp-aligned")
    raise InputError(f"unknown method {method!r}; expected osila or one of {', '.join(CONTROLS)}")
