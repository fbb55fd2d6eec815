"""Demonstration and task scenes of the picture world, the route, and the referee's scores.

The demonstration: the map sheet lies flat at :data:`DEMO_POSE` and a person traces a route on
it; the route is a seeded smooth curve in the sheet's texture coordinates (:func:`route_uv`:
five seeded waypoints, a Catmull-Rom spline through them, 200 points).  The robot sees the sheet
with its eyes before the trace and triangulates its features (the template's ICPs).  The task
(:func:`task_sheet`): the same sheet elsewhere, turned, scaled and -- when ``bent`` -- curled
(:class:`hila_lang.sim.sheet.Sheet`), with seeded distractor boxes beside it and the light
changed.  Truth (the sheets' geometry, the rendering camera) is used here for scoring only.
"""

from __future__ import annotations

import math

import numpy as np

from ...sim.sheet import Sheet

#: the demonstration sheet: an A4 map, flat, turned 10 degrees, where the robot reaches
SIZE = (0.21, 0.297)
#: height of the sheet above the desk mat under it, metres (no z-fighting in the renderer)
LIFT = 0.0005


def demo_sheet(z: float) -> Sheet:
    return Sheet((0.30, -0.09), math.radians(10.0), z + LIFT, SIZE)


def task_sheet(seed: int, z: float, bent: bool) -> Sheet:
    """The seeded task pose: moved up to 4 cm, turned -40..40 degrees, scaled 0.8-1.0, and
    when ``bent`` curled 2-4 cm high in the middle."""
    rng = np.random.default_rng([int(seed), 2401])
    scale = rng.uniform(0.8, 1.0)
    center = (0.31 + rng.uniform(-0.03, 0.03), -0.07 + rng.uniform(-0.04, 0.04))
    bend = rng.uniform(0.02, 0.04)
    return Sheet(center, math.radians(rng.uniform(-40, 40)), z + LIFT, (SIZE[0] * scale, SIZE[1] * scale),
                 bend if bent else 0.0)


def distractors(seed: int) -> list[tuple[list, list, list]]:
    """Seeded boxes beside the task sheet: (half extents, position (z from the table), rgba)."""
    rng = np.random.default_rng([int(seed), 2402])
    out = []
    for _ in range(3):
        half = rng.uniform(0.01, 0.03, 3)
        side = rng.choice([-1, 1])
        pos = [rng.uniform(0.18, 0.45), -0.07 + side * rng.uniform(0.17, 0.24), half[2]]
        out.append((half.tolist(), pos, [*rng.uniform(0.1, 0.9, 3).tolist(), 1.0]))
    return out


def route_uv(seed: int, n: int = 200) -> np.ndarray:
    """The demonstrated route in texture coordinates (n, 2): a Catmull-Rom spline through five
    seeded waypoints, kept 12 % away from the sheet's edges."""
    rng = np.random.default_rng([int(seed), 2403])
    way = rng.uniform(0.12, 0.88, (5, 2))
    way = way[np.argsort(way[:, 1])]  # from the far part of the sheet to the near
    p = np.vstack([way[0], way, way[-1]])
    t = np.linspace(0, len(way) - 1, n, endpoint=False)
    t = np.append(t, len(way) - 1 - 1e-9)
    i = t.astype(int)
    s = (t - i)[:, None]
    p0, p1, p2, p3 = p[i], p[i + 1], p[i + 2], p[i + 3]
    return 0.5 * (2 * p1 + (-p0 + p2) * s + (2 * p0 - 5 * p1 + 4 * p2 - p3) * s ** 2 + (-p0 + 3 * p1 - 3 * p2 + p3) * s ** 3)


def sheet_uv(sheet: Sheet, points: np.ndarray) -> np.ndarray:
    """Texture coordinates (N, 2) of points (N, 3) on a FLAT sheet (truth, for the referee)."""
    loc = sheet.flat.to_local(points)
    return np.column_stack([loc[:, 0] / sheet.size[0] + 0.5, 0.5 - loc[:, 1] / sheet.size[1]])


def route_error(drawn: np.ndarray, true_route: np.ndarray) -> np.ndarray:
    """Distance (N,), metres, from each drawn point (N, 3) to the true route (M, 3) polyline."""
    a, b = true_route[:-1], true_route[1:]
    ab = b - a
    t = np.clip(np.einsum("nmk,mk->nm", drawn[:, None, :] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-18), 0, 1)
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(drawn[:, None, :] - closest, axis=2).min(axis=1)
