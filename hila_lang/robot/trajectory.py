"""Time-parameterising Cartesian paths: densify a polyline, trapezoidal speed profile (numpy)."""

from __future__ import annotations

import math

import numpy as np


def densify(points: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Insert points so consecutive ones are at most ``spacing`` apart.

    Returns the dense points (M, 3), for each the index (into ``points[1:]``) of the waypoint
    it leads to (M,), and the cumulative arc length (M,), metres.
    """
    dense, origin = [points[0]], [0]
    for k in range(1, len(points)):
        a, b = points[k - 1], points[k]
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / spacing)))
        for j in range(1, n + 1):
            dense.append(a + (b - a) * (j / n))
            origin.append(k - 1)
    dense = np.array(dense)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    return dense, np.array(origin), arc


def trapezoid_profile(length: float, speed: float, accel: float, dt: float) -> list[tuple[float, float]]:
    """(arc position s, speed v) at every step of a trapezoidal profile over ``length`` metres."""
    if length <= 1e-9:
        return [(0.0, 0.0)]
    t_acc = speed / accel
    if accel * t_acc**2 > length:  # triangle: never reaches full speed
        t_acc = math.sqrt(length / accel)
        speed = accel * t_acc
    t_flat = (length - accel * t_acc**2) / speed
    total = 2 * t_acc + t_flat
    steps = max(1, int(math.ceil(total / dt)))
    out = []
    for k in range(1, steps + 1):
        t = min(k * dt, total)
        if t < t_acc:
            s, v = 0.5 * accel * t * t, accel * t
        elif t < t_acc + t_flat:
            s, v = 0.5 * accel * t_acc**2 + speed * (t - t_acc), speed
        else:
            r = total - t
            s, v = length - 0.5 * accel * r * r, accel * r
        out.append((min(s, length), v))
    return out
