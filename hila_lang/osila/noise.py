"""How precisely a path's positions are known: the default size of OSILA's candidate ball.

The minimum-energy route may move each waypoint anywhere within ``threshold`` of its mapped
point.  The paper (§III.C) ties that tolerance to measurement: its marker positions are known to
0.5 pixel, and it relaxes the distortion threshold to 2 pixels.  A ball of the size of the
template's own uncertainty lets the route iron out the measurement noise the warp would otherwise
copy into the new path; a larger ball only cuts the demonstration's corners (up to the
threshold, wherever the path turns), a smaller one leaves the noise in.

Without a stated uncertainty the default is measured on the path itself: :func:`position_noise`
estimates the standard deviation σ of white noise on a smooth path from its third differences
(a sampled smooth movement has tiny third differences; white noise of σ per coordinate gives
third differences of variance 20 σ²), robustly (median absolute deviation, so the sharp turns of
a stroke do not count as noise).  The default threshold is :data:`NOISE_MULTIPLE` × σ of the
mapped path: about 95 % of the noise on a coordinate lies within ±2σ.

``bench/route.py`` measures the choice on synthetic templates with a known true map and known
noise (0 – 1 % of the extent): at every noise level a ball of 2 σ̂ has a Fréchet distance within
0.5 % of the lowest of the balls tried and an MSD within 6 % (1 σ̂ has the lowest MSD, 2 σ̂ the
lower Fréchet distance at the higher noise levels; the stand-in, whose trials also carry slow
corrective wiggles, prefers the larger); a ball of 1 % of the path's size (this project's
earlier default) is the worst on clean templates (+15 % MSD, +6 % Fréchet: it cuts corners with
nothing to iron out), and 4 σ̂ or more cuts corners as soon as the noise is visible.  On a
clean recording (a tablet's pen, LASA) σ̂ is a few thousandths of the path's size and the route
all but keeps the warped path.
"""

from __future__ import annotations

from math import comb

import numpy as np

from .fallback import fit_similarity

#: differences of this order estimate the noise (:func:`position_noise`)
ORDER = 3
#: default threshold = this many σ of the mapped path's position noise
NOISE_MULTIPLE = 2.0
_MAD_TO_SIGMA = 1.0 / 0.6744897501960817  # σ of a normal = MAD / Φ⁻¹(3/4)


def position_noise(path: np.ndarray, order: int = ORDER) -> float:
    """Robust estimate of the white-noise standard deviation σ of a path's coordinates.

    Parameters
    ----------
    path : ndarray, shape (T, D)
        Equally spaced samples of a smooth movement plus noise.
    order : int
        Order of the differences (3: a smooth movement's third differences are negligible at
        usual sampling rates; the estimate is exact for a quadratic path plus white noise).

    Returns
    -------
    float
        σ in the path's units: the median absolute deviation of all order-th differences (every
        coordinate pooled), scaled to a normal's σ and divided by sqrt(C(2·order, order)), the
        standard deviation of the order-th difference of unit white noise.  0 for paths with at
        most ``order`` points.
    """
    d = np.diff(path, n=order, axis=0).ravel()
    if d.size == 0:
        return 0.0
    mad = _median(np.abs(d - _median(d)))
    return mad * _MAD_TO_SIGMA / float(np.sqrt(comb(2 * order, order)))


def _median(x: np.ndarray) -> float:
    """``np.median`` of a finite 1-D array, bit for bit, by one partition: a default ``imitate``
    of a 1000-point path pays two medians, and ``np.median``'s own checks cost as much as the
    partition (about 20 µs of a 0.4 ms call here)."""
    k = x.size // 2
    if x.size % 2:
        return float(np.partition(x, k)[k])
    part = np.partition(x, (k - 1, k))
    return float((part[k - 1] + part[k]) / 2)


def default_threshold(mapped: np.ndarray) -> float:
    """:data:`NOISE_MULTIPLE` × :func:`position_noise` of the mapped path (task units)."""
    return NOISE_MULTIPLE * position_noise(mapped)


def amplification_limit(src: np.ndarray, dst: np.ndarray, on: np.ndarray, rank: int,
                        precision: float | None = None) -> float:
    """The largest amplification Λ a TPS through the pairs may have on the path ``on``: ρ / σ.

    ρ is the RMS residual of the least-squares similarity of the pairs ``src`` -> ``dst`` (K, D):
    the deformation they show beyond a rigid placement, which the TPS is there to follow.  σ is
    how precisely the pairs are located, ``precision`` (task units) or, by default, the
    template's own position noise (:func:`position_noise` of ``on``, the sensor's) times the
    similarity's scale.  A TPS with Λ·σ <= ρ can make of errors of the data's size no more than
    the deformation it corrects (:mod:`.tps`, Amplification).  ``inf`` when σ = 0.
    """
    scale, R, shift = fit_similarity(src, dst, rank)
    rho = float(np.sqrt(((dst - (scale * src @ R.T + shift)) ** 2).sum(1).mean()))
    sigma = template_noise(on) * scale if precision is None else float(precision)
    return rho / sigma if sigma > 0 else float("inf")


_LAST: list = [None]  # the last template's noise: (key, sigma), one reference (safe across threads)


def template_noise(path: np.ndarray) -> float:
    """:func:`position_noise` of a template path, remembered for the last path (OSILA asks about
    the same template in every round and every call of a program's step: the medians cost ~0.1 ms
    at T = 1000, the key a copy of the path's bytes, ~2 us)."""
    key = (path.shape, path.dtype.str, path.tobytes())
    last = _LAST[0]
    if last is not None and last[0] == key:
        return last[1]
    sigma = position_noise(path)
    _LAST[0] = (key, sigma)
    return sigma
