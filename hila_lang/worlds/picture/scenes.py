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

from ...osila import imitate
from ...perception.rig import EYE_K
from ...robot.workspace import PAPER_THICKNESS, TABLE_TOP_Z
from ...sim.camera import intersect_plane_z, project
from ...sim.sheet import Sheet
from ...sim.surface import Surface
from ..tictactoe.reading import own_body_mask

#: the demonstration sheet: an A4 map, flat, turned 10 degrees, where the robot reaches
SIZE = (0.21, 0.297)
#: height of the sheet above the desk mat, metres: it lies on a 6 mm drawing board (not drawn), so
#: a route point triangulated a few mm low is still above the mat, which the arm will not go under
LIFT = 0.006


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
    t = np.linspace(0, len(way) - 1 - 1e-9, n)
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


#: where the hand waits, out of the eyes' view of the sheet, in the demonstration and the task
HOME = np.array([0.20, -0.28, 0.75])
#: the desk mat under the sheet (the back end's drawing surface: a dull, featureless green-grey)
MAT_CENTER, MAT_SIZE, MAT_RGB = (0.30, -0.08), (0.44, 0.50), (120, 130, 120)
#: a pair is true when the task eye sees the demonstration's feature within this many pixels of
#: where it was matched (the referee's rule)
TRUE_PIXELS = 4.0
#: the controls' names, in the report's order.  ``matched`` is what the robot runs (the pairs its
#: verification kept, OSILA's own outlier rejection on, as in ``hila exec``); ``no rejection`` is
#: every matched pair with NO rejection at all (neither the matching stage's verification nor
#: OSILA's: ``reject="none"``); ``OSILA's rejection only`` is every matched pair screened by OSILA
#: alone (``reject="auto"``); ``true ICPs`` are the kept pairs' true points, kept whole
#: (``reject="none"``: nothing in them is an outlier); ``corners`` the sheet's four corners.
CONTROLS = ("matched", "no rejection", "OSILA's rejection only", "true ICPs", "corners")
#: OSILA options of each control (see :data:`CONTROLS`)
CONTROL_OPTIONS = {"no rejection": {"reject": "none"}, "true ICPs": {"reject": "none"}}


def mat():
    """The desk mat (:class:`hila_lang.sim.surface.Surface`) the sheet lies on."""
    return Surface(MAT_CENTER, 0.0, TABLE_TOP_Z + PAPER_THICKNESS, MAT_SIZE,
                   texture=np.full((100, 88, 3), MAT_RGB, np.uint8))


def show(backend, sheet: Sheet, texture: np.ndarray, boxes=()) -> list[int]:
    """Put ``sheet`` (printed with ``texture``) and distractor ``boxes`` in the back end's scene;
    returns their body ids (``backend.sim.remove`` takes them away)."""
    v, uv, idx = sheet.mesh()
    bodies = [backend.sim.add_mesh(texture, v, uv, idx, lit=False)]
    return bodies + [backend.sim.add_box(*box) for box in boxes]


def look(backend):
    """The eyes' images (left, right) and, for the referee only, the true left camera pose."""
    images = [backend.eyes.camera_image(e) for e in ("left", "right")]
    return images, backend.eyes.true_pose("left")


def own_body(backend):
    """``image -> mask`` of the pixels the robot's arm covers, as its joint angles place it
    (:meth:`hila_lang.robot.eyes.Eyes.body_outline`; the tic-tac-toe reader's
    :func:`~hila_lang.worlds.tictactoe.reading.own_body_mask`)."""
    outline = backend.eyes.body_outline()
    return lambda image: own_body_mask(image, outline)


def referee_pairs(pairs, demo: Sheet, task: Sheet, demo_camera: np.ndarray, task_camera: np.ndarray):
    """The truth about scene pairs: where each pair's demonstration feature truly is in the
    demonstration (N, 3) and on the task sheet (N, 3), and which pairs are true (N,)."""
    true_demo = intersect_plane_z(pairs.template_uv, EYE_K, demo_camera, demo.z)
    true_task = task.to_world(sheet_uv(demo, true_demo))
    true = np.linalg.norm(project(true_task, EYE_K, task_camera) - pairs.task_uv, axis=1) < TRUE_PIXELS
    return true_demo, true_task, true


def control_sets(pairs, demo: Sheet, task: Sheet, true_demo, true_task) -> dict:
    """ICP pairs (template (K, 3), task (K, 3)) of each control (:data:`CONTROLS`)."""
    k = pairs.kept
    return {"matched": (pairs.template_points[k], pairs.task_points[k]),
            "no rejection": (pairs.template_points, pairs.task_points),
            "OSILA's rejection only": (pairs.template_points, pairs.task_points),
            "true ICPs": (true_demo[k], true_task[k]),
            "corners": (demo.corners(), task.corners())}


def control_errors(path: np.ndarray, route: slice, sets: dict, goal: np.ndarray, hand: np.ndarray) -> dict:
    """Route error (median, p95) in mm of OSILA's planned route for each set of pairs, the hand
    (the same point in both scenes) added to each; NaN where OSILA refused the pairs."""
    out = {}
    for name, (src, dst) in sets.items():
        try:
            planned = imitate(path, np.vstack([src, hand]), np.vstack([dst, hand]), **CONTROL_OPTIONS.get(name, {}))
        except Exception:  # noqa: BLE001 - a refused warp is a result of the control
            out[name] = (float("nan"), float("nan"))
            continue
        err = route_error(planned[route], goal) * 1000
        out[name] = (float(np.median(err)), float(np.percentile(err, 95)))
    return out
