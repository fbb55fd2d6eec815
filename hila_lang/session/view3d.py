"""The 3-D view of a run: the iCub (icub-models' URDF, as the PyBullet back end loaded it), the
table and the paper with its ink, rendered by the simulator itself from a camera the person
turns around the workspace, with the planned path (blue) and the executed one (orange) drawn in.

Why not a browser 3-D library (three.js + an URDF loader, or viser): the simulator already holds
the robot, its meshes and its pose at every step; rendering it there shows exactly the state the
run is in (the paper's ink included) with no second copy of the kinematics in JavaScript, no
extra server (viser starts its own, unauthenticated, which the studio's rules forbid:
docs/design.md §6) and nothing vendored.  What it gives up: the view turns by re-rendering (about 0.1 s), not at screen rate.
"""

from __future__ import annotations

import numpy as np

from ..sim.camera import Camera, intrinsics, look_at

#: what the camera circles: the middle of the iCub's workspace over the table, world metres
TARGET = (0.18, -0.08, 0.60)
DISTANCE = 1.4
ELEVATION_DEG = 28.0
SIZE = (480, 360)


def camera(azimuth_deg: float):
    """A camera ``DISTANCE`` from :data:`TARGET`, ``azimuth_deg`` about +z from the robot's front (+x)."""
    a, e = np.radians(azimuth_deg), np.radians(ELEVATION_DEG)
    eye = np.array(TARGET) + DISTANCE * np.array([np.cos(a) * np.cos(e), np.sin(a) * np.cos(e), np.sin(e)])
    return Camera(intrinsics(*SIZE, 45.0), look_at(eye, TARGET), *SIZE)


def render(backend, azimuth_deg: float, planned=None, executed=None) -> np.ndarray | None:
    """RGB (H, W, 3) of the back end's scene from ``azimuth_deg``, paths drawn in; None when the
    back end has no simulator (the dry one)."""
    sim = getattr(backend, "sim", None)
    if sim is None or not hasattr(sim, "render"):
        return None
    # lazy: loads cv2, which importing this module does not
    import cv2

    cam = camera(azimuth_deg)
    rgb = np.ascontiguousarray(sim.render(cam))
    for path, colour, width in ((executed, (239, 108, 0), 4), (planned, (21, 101, 192), 2)):  # planned on top
        if path is not None and len(path) > 1 and np.asarray(path).shape[1] == 3:
            uv = cam.project(np.asarray(path, float))
            cv2.polylines(rgb, [np.round(uv * 4).astype(np.int32)], False, colour, width, cv2.LINE_AA, shift=2)
    return rgb
