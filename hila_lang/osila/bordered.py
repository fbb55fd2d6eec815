"""One factorisation reused across plan-adjustment rounds while the pairs only grow (issue 24).

Each round of plan adjustment (:mod:`.adjust`) refits the warp on the ICP pairs plus the repair
pairs found so far, and the warp's choice (:func:`.tps.fit_warp`) needs the inverses of two
interpolation systems on all of them — the TPS's and the similarity fallback's — for Rippa's
leave-one-out errors and the cardinal functions: about K³ flops each.  Between rounds the pairs
only grow (a repair pair is never merged with an earlier one, and a held target joins the pins),
so the inverse of the grown system follows from the last one by bordering: with the new rows'
block B (old rows × m new) and C (m × m),

    S = C - Bᵀ A⁻¹ B,   [[A, B], [Bᵀ, C]]⁻¹ = [[A⁻¹ + X S⁻¹ Xᵀ, -X S⁻¹], [-S⁻¹ Xᵀ, S⁻¹]],  X = A⁻¹ B,

O(K² m) instead of O(K³) (the Schur complement S is m × m).  It is the inverse, not a Cholesky
factor, that is kept and bordered: Rippa's closed form needs the inverse's diagonal and the
Lebesgue check its columns, which the choice would otherwise form from a factor anyway.

The system keeps the normalisation (centre, scale of the template points) of its first
factorisation.  For exact interpolation that changes no map: the TPS and the fallback's
φ(r) = r interpolant are invariant under shifting and scaling the template points (the kernel
changes by a factor and, in 2-D, by terms the polynomial part absorbs), and Rippa's errors are
ratios in which the factor cancels.  The grown inverse therefore equals a fresh one to rounding
(tested at rtol 1e-9), not bit for bit.

A fresh factorisation is made instead (:attr:`Refits.fresh` counts them) when

- the pairs did not only grow: a row was dropped, moved to another template point, or given a
  different task point's row order that is not a superset of the last rows (re-timing moved a
  pair, a merge dropped one);
- the fit is smoothed (a ridge λ on the kernel's diagonal is not invariant under the rescaling:
  the grown system would not be the fresh one);
- the pairs are few (at most :data:`.tps.KERNEL_MAX_PAIRS`, where the compiled choice kernel
  inverts both systems in well under a millisecond);
- the bordered Schur complement is singular (a new pair on an old one's template point).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .saddle import _complete
from .tps import _choice_inverses, _dist, _tps_system, kernel

#: plan adjustment borders the last round's inverses (False: a fresh factorisation every round;
#: ``bench/osila.py`` sets it to compare the two in one run)
REUSE = True


@dataclass
class Factored:
    """The inverses of the two interpolation systems on a set of template points.

    Attributes
    ----------
    src : ndarray, shape (K, D)
        The template points, in the rows' order.
    mu : ndarray, shape (D,)
        Centre of the normalisation (of the first factorisation).
    sc : float
        Scale of the normalisation (of the first factorisation).
    tps : ndarray, shape (K + D + 1, K + D + 1)
        Inverse of the TPS system [[U(|x_i - x_j|), 1, x], [1ᵀ, 0, 0], [xᵀ, 0, 0]] on x = (src - mu) / sc.
    sim : ndarray, shape (K + 1, K + 1)
        Inverse of the fallback's system [[|s_i - s_j| / sc, 1], [1ᵀ, 0]].
    """

    src: np.ndarray
    mu: np.ndarray
    sc: float
    tps: np.ndarray
    sim: np.ndarray

    @classmethod
    def fresh(cls, src: np.ndarray, dst: np.ndarray) -> Factored | None:
        """The systems on the pairs ``src``, ``dst`` (K, D) (exact interpolation), from the inverse
        columns of the warp's numpy choice (:func:`.tps._choice_inverses`: its memory when the
        choice was just made on these pairs, as in the round before) completed by their last
        blocks; None if a system is singular."""
        got = _choice_inverses(src, dst)
        if got is None:
            return None
        K = len(src)
        mu, sc, A = _tps_system(src, np.zeros(K))
        return cls(src.copy(), mu, float(sc), _complete(got[0], A[:K, :K]), _complete(got[1], _dist(src, src) / sc))

    def grow(self, new: np.ndarray) -> Factored | None:
        """The factorisation of the rows ``src`` then ``new`` (m, D), by bordering; None if the
        bordered system is singular."""
        K, D = self.src.shape
        x_old, x_new = (self.src - self.mu) / self.sc, (new - self.mu) / self.sc
        poly = np.vstack([np.ones(len(new)), x_new.T])  # (D + 1, m)
        tps = _border(self.tps, K, np.vstack([kernel(_dist(x_old, x_new), D), poly]),
                      kernel(_dist(x_new, x_new), D))
        sim = _border(self.sim, K, np.vstack([_dist(self.src, new) / self.sc, np.ones((1, len(new)))]),
                      _dist(new, new) / self.sc)
        if tps is None or sim is None:
            return None
        return Factored(np.vstack([self.src, new]), self.mu, self.sc, tps, sim)

    def reordered(self, order: np.ndarray) -> Factored:
        """The same systems with the point rows in ``order`` (a permutation of K): P A⁻¹ Pᵀ, exact."""
        K = len(self.src)
        full = np.concatenate([order, np.arange(K, len(self.tps))])
        sfull = np.concatenate([order, [K]])
        return Factored(self.src[order], self.mu, self.sc, self.tps[np.ix_(full, full)],
                        self.sim[np.ix_(sfull, sfull)])


def _border(inv: np.ndarray, K: int, B: np.ndarray, C: np.ndarray) -> np.ndarray | None:
    """Inverse of the system grown by m point rows, from ``inv`` (n, n) of the system whose first
    K rows are points (the rest its polynomial part); ``B`` (n, m) the new columns against the old
    rows, ``C`` (m, m) the new rows' block.  The grown inverse has the old points, then the new
    ones, then the polynomial rows.  O(n² m)."""
    n, m = len(inv), C.shape[0]
    X = inv @ B  # (n, m)
    S = C - B.T @ X
    try:
        Sinv = np.linalg.inv(S)
    except np.linalg.LinAlgError:
        return None
    if not np.isfinite(Sinv).all():
        return None
    XS = X @ Sinv  # (n, m)
    top = inv + XS @ X.T
    out = np.empty((n + m, n + m))
    old_pts, poly = slice(0, K), slice(K, n)
    new_pts = slice(K, K + m)
    out_poly = slice(K + m, n + m)
    # rows/columns: [old points, new points, polynomial part]
    out[old_pts, old_pts] = top[old_pts, old_pts]
    out[old_pts, out_poly] = top[old_pts, poly]
    out[out_poly, old_pts] = top[poly, old_pts]
    out[out_poly, out_poly] = top[poly, poly]
    out[old_pts, new_pts] = -XS[old_pts]
    out[out_poly, new_pts] = -XS[poly]
    out[new_pts, old_pts] = -XS[old_pts].T
    out[new_pts, out_poly] = -XS[poly].T
    out[new_pts, new_pts] = Sinv
    return 0.5 * (out + out.T)


class Refits:
    """The factorisation carried from one adjustment round to the next (module docstring).

    :meth:`factored` gives, for a round's (merged) pairs, the last round's inverses bordered with
    the new pairs when the pairs only grew, or None (the first round, or not a growth): the warp
    then makes its choice as without plan adjustment (:func:`.tps._choice`), and this round's
    pairs become the base the next round grows from (their inverses are completed only if a next
    round asks).  ``fresh`` and ``bordered`` count the rounds fitted each way.
    """

    def __init__(self, reuse: bool | None = None) -> None:
        self.reuse = REUSE if reuse is None else reuse
        self.last: Factored | None = None
        self.base: tuple[np.ndarray, np.ndarray] | None = None  # a round's pairs, not yet completed
        self.fresh = 0
        self.bordered = 0

    def factored(self, src: np.ndarray, dst: np.ndarray) -> Factored | None:
        """The factorisation of the systems on ``src`` (K, D) (rows in its order), or None."""
        got = self._grown(src) if self.reuse else None
        if got is None:
            self.last, self.base = None, (src.copy(), dst.copy())
            self.fresh += 1
        else:
            self.last, self.base = got, None
            self.bordered += 1
        return got

    def _grown(self, src: np.ndarray) -> Factored | None:
        """The last factorisation bordered to ``src``, or None when ``src`` is not the last rows
        plus new ones (each old row found once, bit for bit)."""
        if self.last is None and self.base is not None:
            old_src, old_dst = self.base
            if not self._grows(old_src, src):
                return None
            self.last = Factored.fresh(old_src, old_dst)
        if self.last is None:
            return None
        old = self.last.src
        if not self._grows(old, src):
            return None
        where = {row.tobytes(): i for i, row in enumerate(src)}
        at = np.array([where[row.tobytes()] for row in old])
        fresh_rows = np.setdiff1d(np.arange(len(src)), at)
        grown = self.last.grow(src[fresh_rows])
        if grown is None:
            return None
        # grown rows: the old ones (at positions ``at`` of src), then the new ones
        position = np.concatenate([at, fresh_rows])
        order = np.empty(len(src), int)
        order[position] = np.arange(len(src))
        return grown.reordered(order)

    @staticmethod
    def _grows(old: np.ndarray, src: np.ndarray) -> bool:
        """Whether the rows of ``src`` are those of ``old`` (each once, bit for bit) plus new ones."""
        if len(src) <= len(old) or src.shape[1] != old.shape[1]:
            return False
        rows = {row.tobytes() for row in src}
        return len(rows) == len(src) and all(row.tobytes() in rows for row in old)
