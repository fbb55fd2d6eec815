"""Peers doing the same work as OSILA in the cross-mapping: a bare TPS warp and DMPs.

- ``tps``: the thin plate spline of :func:`hila_lang.osila.fit_warp` fitted on the same
  constraint pairs as OSILA and applied to every template waypoint — OSILA without its candidate
  ball, minimum-energy route and plan adjustment.
- ``dmp``: a discrete dynamic movement primitive (``movement_primitives.dmp.DMP``, the optional
  ``peers`` extra) learned from the template path and rolled out with the task's start and goal;
  for N > 1 one DMP per equal segment, each rolled out from the task path's boundary point to the
  next one, stitched.  "Start and goal" are the task's human path's first and last points (the
  DMP is told exactly where the human started and stopped, which the ICP-driven methods are not:
  a generous comparison for the DMP).  Time is normalised: the template spans [0, 1], one DMP
  step per template sample, 10 weights per dimension, the package's default gains.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .grid import boundaries

DMP_WEIGHTS = 10


def dmp_available() -> bool:
    """True when the optional ``movement_primitives`` package imports."""
    try:
        import movement_primitives.dmp  # noqa: F401
    except ImportError:
        return False
    return True


def require_dmp() -> None:
    """Raise :class:`InputError` with the install hint when the DMP peer cannot run."""
    if not dmp_available():
        raise InputError(
            "the DMP peer needs the optional package movement_primitives (and pytransform3d), "
            "which is not installed",
            hint="pip install 'hila-lang[peers]', or run without --peers",
        )


def tps_warp(path: np.ndarray, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Warp every waypoint of ``path`` (T, D) by the exact TPS taking ``src`` (K, D) to ``dst``."""
    from ..osila import fit_warp

    return fit_warp(src, dst)(path)


def _pieces(length: int, n: int) -> list[tuple[int, int]]:
    """Inclusive index ranges of n equal segments that share their boundary points."""
    cuts = [0, *boundaries(length, n), length - 1]
    return [(cuts[k], cuts[k + 1]) for k in range(n)]


class DmpPeer:
    """DMPs learned from one template path, rolled out onto task paths' start/boundaries/goal.

    Parameters
    ----------
    path : ndarray, shape (T, D)
        The template path.
    """

    def __init__(self, path: np.ndarray) -> None:
        require_dmp()
        self.path = np.asarray(path, float)
        self.dt = 1.0 / (len(self.path) - 1)
        self._fitted: dict[int, list] = {}

    def _dmps(self, n: int) -> list:
        if n not in self._fitted:
            from movement_primitives.dmp import DMP

            dmps = []
            for a, b in _pieces(len(self.path), n):
                piece = self.path[a : b + 1]
                steps = max(len(piece) - 1, 1)
                dmp = DMP(n_dims=self.path.shape[1], execution_time=steps * self.dt, dt=self.dt,
                          n_weights_per_dim=DMP_WEIGHTS)
                dmp.imitate(np.arange(len(piece)) * self.dt, piece)
                dmps.append((dmp, len(piece)))
            self._fitted[n] = dmps
        return self._fitted[n]

    def generate(self, task, n: int) -> np.ndarray:
        """The DMP path (T, D) from the task path's start, through its N − 1 boundaries, to its goal."""
        from ..metrics import resample

        target = task.path
        points = target[[0, *boundaries(len(target), n), len(target) - 1]]
        out = []
        dmps = self._dmps(n)
        for k, (dmp, length) in enumerate(dmps):
            dmp.configure(start_y=points[k], goal_y=points[k + 1])
            _, y = dmp.open_loop()
            if len(y) != length:
                y = resample(y, length)
            # a DMP converges to its goal but need not reach it: the next piece starts exactly at
            # the boundary, so keep that point and drop this piece's last one
            out.append(y if k == len(dmps) - 1 else y[:-1])
        return np.vstack(out)
