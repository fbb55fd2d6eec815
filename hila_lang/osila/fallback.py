"""Rigid fallbacks for too few or degenerate ICPs: similarity transform and translation.

Used by :func:`hila_lang.osila.tps.fit_warp` when the ICPs cannot pin down a thin plate spline
(fewer than D+1 points, or points that are collinear in 2-D / coplanar in 3-D).
"""

from __future__ import annotations

import numpy as np


def _rotation_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The minimal rotation (D, D) taking unit vector ``u`` onto unit vector ``v`` (D = 2 or 3)."""
    D = u.shape[0]
    if D == 2:
        ang = np.arctan2(v[1], v[0]) - np.arctan2(u[1], u[0])
        c, s = np.cos(ang), np.sin(ang)
        return np.array([[c, -s], [s, c]])
    axis = np.cross(u, v)
    s = np.linalg.norm(axis)
    c = float(np.dot(u, v))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        # half turn about any axis perpendicular to u
        perp = np.cross(u, np.eye(3)[np.argmin(np.abs(u))])
        perp /= np.linalg.norm(perp)
        return 2.0 * np.outer(perp, perp) - np.eye(3)
    k = axis / s
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * Kx + (1 - c) * (Kx @ Kx)


def fit_similarity(src: np.ndarray, dst: np.ndarray, rank: int) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares similarity ``x -> scale * R @ x + shift`` taking ``src`` to ``dst``.

    Parameters
    ----------
    src, dst : ndarray, shape (K, D)
        Paired points, K >= 2, ``src`` not all equal.
    rank : int
        Rank of the centred ``src`` (1 = collinear).  Collinear points leave the rotation about
        their line free: the minimal rotation between the two lines' directions is used.
        Otherwise Umeyama's method (proper rotation, no reflection).

    Returns
    -------
    scale : float
    R : ndarray, shape (D, D)
    shift : ndarray, shape (D,)
    """
    K, D = src.shape
    mu_s, mu_d = src.sum(0) / K, dst.sum(0) / K
    a, b = src - mu_s, dst - mu_d
    var_s = float((a**2).sum())
    if rank >= 2 and D == 2:  # as complex numbers: z -> c z, c = Σ b conj(a) / Σ |a|² (= Umeyama in 2-D)
        re = float((b[:, 0] * a[:, 0] + b[:, 1] * a[:, 1]).sum()) / var_s
        im = float((b[:, 1] * a[:, 0] - b[:, 0] * a[:, 1]).sum()) / var_s
        scale = float(np.hypot(re, im))
        R = np.eye(2) if scale == 0.0 else np.array([[re, -im], [im, re]]) / scale
    elif rank <= 1:
        # direction of the line through src, and the matching direction of dst
        _, _, vt = np.linalg.svd(a, full_matrices=False)
        u = vt[0]
        proj_a = a @ u
        # dst direction: least-squares fit b ~ proj_a * w
        w = proj_a @ b / float(proj_a @ proj_a)
        scale = float(np.linalg.norm(w))
        R = np.eye(src.shape[1]) if scale < 1e-15 else _rotation_between(u, w / scale)
    else:
        cov = b.T @ a / len(src)
        U, S, Vt = np.linalg.svd(cov)
        sign = np.ones(src.shape[1])
        if np.linalg.det(U) * np.linalg.det(Vt) < 0:
            sign[-1] = -1.0
        R = (U * sign) @ Vt
        scale = float((S * sign).sum() / (var_s / len(src)))
    shift = mu_d - scale * R @ mu_s
    return scale, R, shift
