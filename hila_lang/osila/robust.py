"""Many noisy ICP pairs: reject the outliers before the warp, and say how many (issue 24).

Scene matching gives hundreds of pairs, some of them wrong (a feature matched to a look-alike
elsewhere).  An exact warp through a wrong pair bends the route towards it, however many good
pairs surround it.  :func:`screen` decides which pairs to keep:

- ``"loo"`` — leave-one-out residuals: each pair is predicted from all the others by the map
  OSILA would choose (the TPS or the similarity fallback, whichever predicts the pairs better
  by the median — the mean is what an outlier inflates), with Rippa's closed form (one
  factorisation for all pairs, :mod:`.tps`).  A pair whose error exceeds :data:`CUT` robust
  standard deviations (1.4826 × the median absolute error) is rejected; repeated on the pairs
  kept until none is.  An outlier also spoils its neighbours' predictions, so a few rounds are
  needed, and a dense cluster of outliers can shield itself.
- ``"lmeds"`` — least median of squares on a similarity (Rousseeuw 1984): the similarity of a
  minimal set of pairs (2 in 2-D, 3 in 3-D) whose median squared residual over all pairs is
  smallest, from :data:`TRIALS` seeded random sets (seed option); skipped when every pair's
  leave-one-out error is already below the floor (a clean scene).  It tolerates up to half the
  pairs being outliers; pairs beyond :data:`CUT` robust σ of its residuals are dropped, then
  the ``"loo"`` rounds run on the rest (so a smooth deformation the similarity cannot follow is
  judged by the TPS, not by the similarity), and finally every dropped pair whose residual
  against the map of the kept pairs is within the cut comes back.
- ``"none"`` — keep every pair.

``bench/robust.py`` measures them on seeded synthetic scenes (a smooth true map; ICPs located
with Gaussian noise of 0.5 % of the extent; 0-40 % of the task points replaced by uniform
points in the scene; K = 40; 20 scenes per row).  Route RMS error, median / 90th percentile, %
of the extent:

    ======  ========  =============  =============  =============
    D       outliers  none           loo            lmeds
    ======  ========  =============  =============  =============
    2       0 %       0.53 / 0.65    0.53 / 0.65    0.53 / 0.65
    2       20 %      17.2 / 30.1    0.59 / 1.13    0.52 / 0.75
    2       30 %      22.9 / 34.5    16.7 / 33.8    0.59 / 1.20
    2       40 %      24.3 / 38.8    24.3 / 38.8    0.71 / 23.1
    3       0 %       0.89 / 1.32    0.91 / 1.32    0.91 / 1.32
    3       20 %      18.0 / 21.4    1.15 / 19.6    1.01 / 1.54
    3       30 %      24.0 / 27.9    23.1 / 27.9    1.07 / 1.84
    3       40 %      26.4 / 38.0    26.4 / 38.0    1.26 / 13.4
    ======  ========  =============  =============  =============

LMedS cut 99-100 % of the outliers up to 30 % (72 % in 2-D and 91 % in 3-D at 40 %: a few scenes fail) and
kept >= 99.6 % of the good pairs; the leave-one-out rounds alone hold up to 20 % only (outliers
shield each other).  So :data:`DEFAULT` is ``"lmeds"``.  Rejection runs only with at least :data:`MIN_PAIRS` pairs: with
fewer, a pair's error cannot be told from a real local deformation (with D + 2 pairs, every
pair is needed to fit the TPS at all), and hand-typed scenes of a few ICPs keep every pair.
Pins (the hand, a bound goal) and plan-adjustment pairs are never screened.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..core import jit
from .tps import _choice_parts, _inverse, _tps_system, affine_rank, LOO_PAIRS, merge_pairs, SINGULAR_TOL

#: rejection cut in robust standard deviations of the leave-one-out (or LMedS) residuals: 3.5 σ
#: rejects about 1 in 2000 good pairs of Gaussian noise (a pair's error vector is 2- or 3-D, so
#: its length is Rayleigh/Maxwell-distributed; 3.5 × the median-based σ is past its 99.9 %).
CUT = 3.5
#: fewest pairs for which rejection runs (module docstring); the warp's leave-one-out test too
MIN_PAIRS = LOO_PAIRS
#: random minimal sets tried by LMedS, per dimension: with half the pairs wrong, the chance that
#: no set is all good is (1 - 0.5²)^50 < 1e-6 in 2-D and (1 - 0.5³)^104 < 1e-6 in 3-D
TRIALS = {2: 50, 3: 104}
MAX_ROUNDS = 10
#: errors below this fraction of the task ICPs' extent are never outliers: the ICP location
#: precision the warp's choice was measured at (``bench/warp.py``); without it a clean scene's
#: pairs at the rim (extrapolated by the others, so predicted worse) would be cut
FLOOR = 0.01
#: ``reject`` default ("auto"): the method bench/robust.py measured best (see :func:`screen`)
DEFAULT = "lmeds"
METHODS = ("auto", "none", "loo", "lmeds")


@dataclass
class Pairs:
    """What happened to the scene's ICP pairs (reported by ``hila explain`` and the REPL).

    Attributes
    ----------
    matched : int
        Pairs given (the scene's ICPs).
    kept : ndarray of int
        Indices (into the given pairs) the warp was fitted on.
    rejected : ndarray of int
        Indices rejected as outliers.
    residual : float or None
        RMS leave-one-out error of the kept pairs (task units): how well each kept pair is
        predicted by the others (None: fewer pairs than the check needs).
    method : str
        The rule applied (``"none"`` below :data:`MIN_PAIRS` pairs).
    smoothing : float or None
        The λ chosen by ``smoothing="auto"`` (:func:`choose_smoothing`), else None.
    """

    matched: int
    kept: np.ndarray
    rejected: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    residual: float | None = None
    method: str = "none"
    smoothing: float | None = None

    def summary(self, unit: float = 1.0, suffix: str = "") -> str:
        """``"40 matched, 31 kept, 9 rejected (lmeds), residual 1.2 mm"``."""
        text = f"{self.matched} matched, {len(self.kept)} kept, {len(self.rejected)} rejected"
        if self.method != "none":
            text += f" ({self.method})"
        if self.residual is not None:
            text += f", residual {self.residual * unit:.3g}{suffix}"
        return text


def loo_errors(src: np.ndarray, dst: np.ndarray, compiled_kernel: bool = False) -> np.ndarray | None:
    """Leave-one-out error length per pair (K,) of the better map (by median), or None when the
    pairs cannot be checked (fewer than D + 2, not spanning D dimensions, a singular system)."""
    K, D = src.shape
    if K < D + 2 or len(merge_pairs(src, dst, fast=compiled_kernel)[0]) < K or affine_rank(src, fast=compiled_kernel) < D:
        return None
    got = _choice_parts(src, dst, np.zeros(K), compiled_kernel)
    if got is None:
        return None
    card, _, _, sim_each = got
    diag = card.diagonal()
    if (np.abs(diag) <= SINGULAR_TOL).any():
        return np.sqrt(sim_each)
    tps_each = ((card.solve(dst)[:K] / diag[:, None]) ** 2).sum(1)
    best = tps_each if _median(tps_each) <= _median(sim_each) else sim_each
    return np.sqrt(best)


def _nonzero(mask: np.ndarray) -> np.ndarray:
    """``np.flatnonzero`` of a 1-D mask (without its wrappers' few µs a call)."""
    return mask.nonzero()[0]


def _median(x: np.ndarray) -> np.ndarray:
    """``np.median(x, axis=-1)`` of finite values, bit for bit (the middle order statistic, or
    (a + b) / 2 of the two middle ones, as np.median's mean of them), without its fixed cost
    (about 20 µs a call: a third of the outlier screen at K = 10)."""
    n = x.shape[-1]
    h = n // 2
    if n % 2:
        return np.partition(x, h, axis=-1)[..., h]
    part = np.partition(x, (h - 1, h), axis=-1)
    return (part[..., h - 1] + part[..., h]) / 2


def _sigma(e: np.ndarray) -> float:
    return 1.4826 * float(_median(np.abs(e)))


def _loo_rounds(errors, keep: np.ndarray, floor: float) -> np.ndarray:
    """Drop pairs beyond :data:`CUT` robust σ of the leave-one-out errors until none is
    (``errors(idx)``: :func:`loo_errors` of the pairs ``idx``)."""
    for _ in range(MAX_ROUNDS):
        idx = _nonzero(keep)
        if len(idx) < MIN_PAIRS:
            break
        e = errors(idx)
        if e is None:
            break
        bad = e > max(CUT * _sigma(e), floor)
        if not bad.any():
            break
        keep = keep.copy()
        keep[idx[bad]] = False
    return keep


def _lmeds(src: np.ndarray, dst: np.ndarray, seed: int, fast: bool = False) -> np.ndarray:
    """Inlier mask of the LMedS similarity (module docstring): :data:`TRIALS` minimal sets at once
    (Umeyama on each, batched; D points in D-D fix a proper similarity).  ``fast``: the 3-D sets by
    the compiled :func:`_trials_kernel` (a long path, as the warp's kernels)."""
    K, D = src.shape
    picks = _picks(seed, K, D)
    tiny = 1e-24 * max(float(np.ptp(src, axis=0).max()) ** 2, 1e-300)
    if D == 2:  # as complex numbers the similarity is z -> c z, c = Σ b conj(a) / Σ |a|²
        a, b = src[picks], dst[picks]  # (N, D, D): trial, pair, coordinate
        ma, mb = a.mean(1, keepdims=True), b.mean(1, keepdims=True)
        a, b = a - ma, b - mb
        var = (a * a).sum((1, 2))
        ok = var > tiny
        za, zb = a[..., 0] + 1j * a[..., 1], b[..., 0] + 1j * b[..., 1]
        c = (zb * za.conj()).sum(1) / np.where(ok, var, 1.0)
        zs = (src[:, 0] + 1j * src[:, 1])[None] - (ma[:, 0, 0] + 1j * ma[:, 0, 1])[:, None]
        zp = c[:, None] * zs + (mb[:, 0, 0] + 1j * mb[:, 0, 1])[:, None]
        r = np.abs(zp - (dst[:, 0] + 1j * dst[:, 1])[None])
    else:
        kernel = _trials_compiled() if fast else None
        if kernel is None:
            r, var = _trials_svd(src, dst, picks)
            ok = var > tiny
        else:
            r, flag = np.empty((len(picks), K)), np.empty(len(picks), np.int8)
            kernel(src, dst, picks, tiny, r, flag)
            ok = flag != 1
            flat = _nonzero(flag == 2)
            if len(flat):
                r[flat] = _trials_svd(src, dst, picks[flat])[0]
    med = np.where(ok, _median(r), np.inf)
    if not np.isfinite(med).any():
        return np.ones(K, bool)
    best = r[int(np.argmin(med))]
    return best <= CUT * _sigma(best)


@lru_cache(maxsize=64)
def _picks(seed: int, K: int, D: int) -> np.ndarray:
    """LMedS's minimal sets (TRIALS[D], D): D distinct pairs of K per trial, from ``seed``
    (remembered: a seeded generator costs ~10 µs to start, a third of the screen's fixed cost)."""
    rng = np.random.default_rng(seed)
    picks = np.ascontiguousarray(np.argsort(rng.random((TRIALS[D], K)), axis=1)[:, :D])
    picks.flags.writeable = False
    return picks


#: a 3-D minimal set whose triangle is flatter than this (|a₀ × a₁| / the longest centred point²)
#: has no well-determined plane: its similarity comes from the SVD (:func:`_trials_svd`), as
#: arbitrary about the line as LAPACK makes it, instead of the plane-to-plane closed form (whose
#: rounding error grows as 1e-16 / flatness: at most ~1e-10 of the residuals above this bound)
FLAT = 1e-6


def _trials_svd(src: np.ndarray, dst: np.ndarray, picks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residual lengths (N, K) of the Umeyama similarity of each 3-D minimal set ``picks`` (N, 3)
    by SVD of the sets' covariances, and the sets' Σ |a|² (N,): :func:`_trials_kernel` in numpy."""
    a, b = src[picks], dst[picks]
    ma, mb = a.mean(1, keepdims=True), b.mean(1, keepdims=True)
    a, b = a - ma, b - mb
    var = (a * a).sum((1, 2))
    cov = np.matmul(b.transpose(0, 2, 1), a)  # (N, D, D) = Σ b aᵀ
    U, S, Vt = np.linalg.svd(cov)
    flip = np.linalg.det(np.matmul(U, Vt)) < 0
    U[flip, :, -1] *= -1.0
    S[flip, -1] *= -1.0
    sR = (S.sum(1) / np.where(var > 0, var, 1.0))[:, None, None] * np.matmul(U, Vt)  # scale * R
    pred = np.matmul(src[None] - ma, sR.transpose(0, 2, 1)) + mb  # (N, K, D)
    return np.sqrt(((pred - dst[None]) ** 2).sum(2)), var


def _trials_kernel(src, dst, picks, tiny, r, flag):  # pragma: no cover - compiled by numba (hila_lang.core.jit)
    """The Umeyama similarity of each 3-D minimal set and its residuals, as loops.

    Fills ``r`` (N, K) with the residual length of every pair under the similarity of the three
    pairs ``picks[n]`` and ``flag`` (N,) with 0, 1 (the set's template points coincide: no
    similarity) or 2 (flatter than :data:`FLAT`: ``r[n]`` left to :func:`_trials_svd`).  Three
    centred points span a plane, so their covariance Σ b aᵀ has rank 2 and the best rotation
    (max tr Rᵀ Σ b aᵀ over proper rotations, Umeyama's) carries a's plane onto b's, each plane's
    normal along its own triangle's turning sense, and turns it in the plane by the 2-D Procrustes
    angle; the scale is that trace over Σ |a|².  Equal to the
    SVD's (:func:`_trials_svd`, the numpy twin) to rounding, tested: numpy's batched SVD costs
    ~1.6 µs a set here (0.38 ms of LMedS's 104 sets at K = 10), this ~0.1 µs.
    """
    N = picks.shape[0]
    K = src.shape[0]
    a = np.empty((3, 3))
    b = np.empty((3, 3))
    F = np.empty((2, 3, 3))  # frames of a and b: columns e1, e2, n
    flat = np.empty(2)
    ma = np.empty(3)
    mb = np.empty(3)
    sR = np.empty((3, 3))
    for t in range(N):
        for d in range(3):
            ma[d] = (src[picks[t, 0], d] + src[picks[t, 1], d] + src[picks[t, 2], d]) / 3.0
            mb[d] = (dst[picks[t, 0], d] + dst[picks[t, 1], d] + dst[picks[t, 2], d]) / 3.0
        var = 0.0
        for q in range(3):
            for d in range(3):
                a[q, d] = src[picks[t, q], d] - ma[d]
                b[q, d] = dst[picks[t, q], d] - mb[d]
                var += a[q, d] * a[q, d]
        if not var > tiny:
            flag[t] = 1
            continue
        for s in range(2):
            p = a if s == 0 else b
            n0 = p[0, 1] * p[1, 2] - p[0, 2] * p[1, 1]
            n1 = p[0, 2] * p[1, 0] - p[0, 0] * p[1, 2]
            n2 = p[0, 0] * p[1, 1] - p[0, 1] * p[1, 0]
            nn = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            longest, ll = 0, -1.0
            for q in range(3):
                lq = p[q, 0] * p[q, 0] + p[q, 1] * p[q, 1] + p[q, 2] * p[q, 2]
                if lq > ll:
                    longest, ll = q, lq
            flat[s] = nn / ll if ll > 0 else 0.0
            if nn <= 0 or ll <= 0:
                continue
            el = np.sqrt(ll)
            e0, e1, e2 = p[longest, 0] / el, p[longest, 1] / el, p[longest, 2] / el
            n0, n1, n2 = n0 / nn, n1 / nn, n2 / nn
            F[s, 0, 0], F[s, 1, 0], F[s, 2, 0] = e0, e1, e2
            F[s, 0, 1], F[s, 1, 1], F[s, 2, 1] = n1 * e2 - n2 * e1, n2 * e0 - n0 * e2, n0 * e1 - n1 * e0
            F[s, 0, 2], F[s, 1, 2], F[s, 2, 2] = n0, n1, n2
        if flat[0] <= FLAT or flat[1] <= FLAT:
            flag[t] = 2
            continue
        # M = Σ β αᵀ of the in-plane coordinates α = a·(e1, e2), β = b·(e1, e2)
        m00 = m01 = m10 = m11 = 0.0
        for q in range(3):
            a0 = a[q, 0] * F[0, 0, 0] + a[q, 1] * F[0, 1, 0] + a[q, 2] * F[0, 2, 0]
            a1 = a[q, 0] * F[0, 0, 1] + a[q, 1] * F[0, 1, 1] + a[q, 2] * F[0, 2, 1]
            b0 = b[q, 0] * F[1, 0, 0] + b[q, 1] * F[1, 1, 0] + b[q, 2] * F[1, 2, 0]
            b1 = b[q, 0] * F[1, 0, 1] + b[q, 1] * F[1, 1, 1] + b[q, 2] * F[1, 2, 1]
            m00 += b0 * a0
            m01 += b0 * a1
            m10 += b1 * a0
            m11 += b1 * a1
        # both triangles turn positively about their own normals (n from p₀ × p₁), so det M > 0
        # (Cauchy-Binet: 3 × the two oriented areas) and a turn beats an in-plane reflection
        cr, ci = m00 + m11, m10 - m01
        mag = np.hypot(cr, ci)
        c = cr / mag if mag > 0 else 1.0
        s_ = ci / mag if mag > 0 else 0.0
        scale = mag / var
        # sR = scale · Fb R2 Faᵀ, R2 = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        for i in range(3):
            g0 = F[1, i, 0] * c + F[1, i, 1] * s_
            g1 = -F[1, i, 0] * s_ + F[1, i, 1] * c
            g2 = F[1, i, 2]
            for j in range(3):
                sR[i, j] = scale * (g0 * F[0, j, 0] + g1 * F[0, j, 1] + g2 * F[0, j, 2])
        for k in range(K):
            e2s = 0.0
            for i in range(3):
                v = mb[i] - dst[k, i]
                for j in range(3):
                    v += sR[i, j] * (src[k, j] - ma[j])
                e2s += v * v
            r[t, k] = np.sqrt(e2s)
        flag[t] = 0


def _warm_trials() -> tuple:
    src = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    picks = np.array([[0, 1, 2], [1, 2, 3]], dtype=np.intp)
    picks.flags.writeable = False  # as :func:`_picks` gives them
    return src, src + 0.1, picks, 1e-24, np.empty((2, 4)), np.empty(2, np.int8)


_WARM_TRIALS = _warm_trials()  # the kernel's example arguments, made once (a call asks for it)


def _trials_compiled():
    """The compiled :func:`_trials_kernel`, or None."""
    return jit.compiled(_trials_kernel, *_WARM_TRIALS)


#: λ tried by ``smoothing="auto"`` (unit-free: the template points are normalised to unit extent)
LAMBDAS = (0.0, *np.logspace(-6, 0, 13))


def choose_smoothing(src: np.ndarray, dst: np.ndarray) -> float:
    """The TPS regulariser λ for noisy pairs: the one of :data:`LAMBDAS` whose smoothed TPS
    predicts the pairs best from the others (mean squared leave-one-out error; ordinary
    cross-validation, of which generalised cross-validation is the rotation-invariant variant).

    Rippa's closed form holds for the smoothed system too (e_k = (A_λ⁻¹ f)_k / (A_λ⁻¹)_kk, the
    tests check it against refitting), so each λ costs one inverse.  Exact pairs (noise-free)
    give λ = 0: interpolation predicts them best; noisy pairs a λ that averages the noise out
    instead of bending the route through it.  0 with fewer than :data:`MIN_PAIRS` pairs.
    """
    src, dst, _ = merge_pairs(src, dst)
    K, D = src.shape
    if K < MIN_PAIRS:
        return 0.0
    best, best_err = 0.0, np.inf
    for lam in LAMBDAS:
        _, _, A = _tps_system(src, np.full(K, lam))
        try:
            card = _inverse(A[:K, :K], A[:K, K:], 1.0 if D == 2 else -1.0)
        except np.linalg.LinAlgError:
            continue
        diag = np.diagonal(card[:K])
        if (np.abs(diag) <= 1e-12).any():
            continue
        err = float((((card @ dst)[:K] / diag[:, None]) ** 2).sum(1).mean())
        if err < best_err * (1 - 1e-9):
            best, best_err = float(lam), err
    return best


def screen(src: np.ndarray, dst: np.ndarray, method: str = "auto", seed: int = 0, floor: float = 0.0,
           fast: bool = False) -> Pairs:
    """Which ICP pairs to warp on (module docstring).

    Parameters
    ----------
    src, dst : ndarray, shape (K, D)
        Template and task ICPs, paired by row.
    method : str
        One of :data:`METHODS` (``"auto"``: :data:`DEFAULT`).
    seed : int
        Seeds LMedS's random sets.
    floor : float
        Errors up to this (task units) are never outliers (the distortion threshold: a pair
        within it is "the same place" for the route).
    fast : bool
        Use the compiled kernel of :mod:`.tps` as the warp will (a long path).

    Returns
    -------
    Pairs
    """
    K = len(src)
    method = DEFAULT if method == "auto" else method
    if method not in METHODS:
        raise ValueError(f"expected reject as one of {', '.join(METHODS)}, got {method!r}")
    if method == "none" or K < MIN_PAIRS:  # (the floor is not asked: nothing is screened)
        e = loo_errors(src, dst, fast) if K >= MIN_PAIRS else None
        return Pairs(K, np.arange(K), residual=None if e is None else float(np.sqrt((e**2).mean())))
    if K > 1:
        floor = max(floor, FLOOR * float(np.ptp(dst, axis=0).max()))
    keep = np.ones(K, bool)
    memo: dict[bytes, np.ndarray | None] = {}  # the same set of pairs is checked up to three times

    def errors(idx: np.ndarray) -> np.ndarray | None:
        key = idx.tobytes()
        if key not in memo:
            memo[key] = loo_errors(src[idx], dst[idx], fast)
        return memo[key]

    if method == "lmeds":
        e = errors(np.arange(K))
        if e is None or e.max() > floor:  # not a clean scene
            keep = _lmeds(src, dst, seed, fast)
        if keep.sum() < MIN_PAIRS:
            keep = np.ones(K, bool)
    keep = _loo_rounds(errors, keep, floor)
    idx = _nonzero(keep)
    e = errors(idx)
    if method == "lmeds" and e is not None and not keep.all():
        # a dropped pair the kept pairs' map predicts within the cut comes back
        # lazy: only this branch needs it
        from .tps import fit_warp

        warp = fit_warp(src[idx], dst[idx])
        back = _nonzero(~keep)
        miss = np.sqrt(((warp(src[back]) - dst[back]) ** 2).sum(1))
        keep[back[miss <= max(CUT * _sigma(e), floor)]] = True
        idx = _nonzero(keep)
        e = errors(idx)
    return Pairs(K, idx, _nonzero(~keep), None if e is None else float(np.sqrt((e**2).mean())), method)
