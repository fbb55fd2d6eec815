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


def _trapezoid(length: float, speed: float, accel: float) -> tuple[float, float, float, float]:
    """(time accelerating, top speed, time at top speed, total time) of a trapezoidal profile over
    ``length`` metres (a triangle when it never reaches ``speed``)."""
    t_acc = speed / accel
    if accel * t_acc**2 > length:  # triangle: never reaches full speed
        t_acc = math.sqrt(length / accel)
        speed = accel * t_acc
    t_flat = (length - accel * t_acc**2) / speed
    return t_acc, speed, t_flat, 2 * t_acc + t_flat


def trapezoid_times(arc: np.ndarray, speed: float, accel: float) -> tuple[np.ndarray, np.ndarray]:
    """When a trapezoidal profile over ``arc[-1]`` metres passes each arc position ``arc`` (M,),
    increasing from 0: the times (M,), seconds, and the speeds there (M,), m/s."""
    arc = np.asarray(arc, dtype=float)
    length = float(arc[-1])
    if length <= 1e-9:
        return np.zeros(len(arc)), np.zeros(len(arc))
    t_acc, top, t_flat, total = _trapezoid(length, speed, accel)
    ramp = 0.5 * accel * t_acc**2  # the arc covered while speeding up (and while slowing down)
    rising, falling = arc < ramp, arc > length - ramp
    times = t_acc + (arc - ramp) / top
    times[rising] = np.sqrt(2 * arc[rising] / accel)
    times[falling] = total - np.sqrt(2 * np.maximum(length - arc[falling], 0.0) / accel)
    speeds = np.minimum(accel * np.minimum(times, total - times), top)
    return times, np.maximum(speeds, 0.0)


def trapezoid_profile(length: float, speed: float, accel: float, dt: float) -> list[tuple[float, float]]:
    """(arc position s, speed v) at every step of a trapezoidal profile over ``length`` metres."""
    if length <= 1e-9:
        return [(0.0, 0.0)]
    t_acc, speed, t_flat, total = _trapezoid(length, speed, accel)
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
