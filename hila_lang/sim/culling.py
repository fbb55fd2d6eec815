"""Not drawing what a camera cannot see: view-frustum culling for PyBullet's tiny renderer.

The tiny renderer transforms every triangle of every visual shape for every image, whether it
lands in the picture or not: the iCub's 41 link meshes hold about 273,000 triangles (its legs
and hips about 150,000), and they cost about half of an eye image (measured on the game's scene:
an 8 x 8 pixel eye image took 43 ms with the robot in the scene and 0.06 ms without it).  It
skips a visual shape whose colour has alpha 0.  So :meth:`Culler.hidden` makes every link of the
bodies it was given whose visual's bounding box lies wholly outside the camera's view frustum
(behind the near plane or beyond a side of the picture) transparent for one image and restores its
colour after: the image is the same, pixel for pixel (``tests/test_sim_culling.py``), at less cost.

The boxes come from the simulator's own description of each visual shape
(``getVisualShapeData``: the geometry, its scale and its frame in the link's frame) and the mesh
file's vertices (binary or ASCII STL, OBJ); a shape whose extent cannot be read (another mesh
format, a mesh made from vertices in memory such as a textured quad, a link with several shapes)
is never culled.  Where a link is is the simulator's truth: like the image, this is rendering only.
"""

from __future__ import annotations

import struct
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..core.rotation import from_quat, pose
from .camera import Camera


@lru_cache(maxsize=None)
def mesh_bounds(filename: str) -> tuple[tuple, tuple] | None:
    """The vertices' bounding box ``(lo (3,), hi (3,))`` of a mesh file in its own units, or None
    when the file is not a binary or ASCII STL or an OBJ, or cannot be read."""
    path = Path(filename)
    try:
        data = path.read_bytes()
    except OSError:
        return None
    suffix = path.suffix.lower()
    points = None
    if suffix == ".stl":
        count = struct.unpack("<I", data[80:84])[0] if len(data) >= 84 else -1
        if count > 0 and len(data) >= 84 + 50 * count:  # binary: 50 bytes a triangle after the header
            rows = np.frombuffer(data[84:84 + 50 * count], dtype=np.dtype([("normal", "<f4", 3),
                                                                           ("v", "<f4", (3, 3)), ("attr", "<u2")]))
            points = rows["v"].reshape(-1, 3).astype(float)
        else:
            points = _text_vertices(data, b"vertex")
    elif suffix == ".obj":
        points = _text_vertices(data, b"v")
    if points is None or len(points) == 0 or not np.all(np.isfinite(points)):
        return None
    return tuple(points.min(axis=0)), tuple(points.max(axis=0))


def _text_vertices(data: bytes, keyword: bytes) -> np.ndarray | None:
    """The (N, 3) vertices of a text mesh: the lines ``keyword x y z``."""
    out = []
    for line in data.splitlines():
        parts = line.split()
        if len(parts) >= 4 and parts[0] == keyword:
            try:
                out.append([float(v) for v in parts[1:4]])
            except ValueError:
                return None
    return np.array(out) if out else None


def _local_box(pb, geometry: int, dims, filename: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """A box (lo, hi) in the visual shape's own frame holding all of it, or None (unknown extent).
    Primitives are bounded generously (a box's dimensions taken as half extents, a cylinder's or
    capsule's length as its half length)."""
    dims = np.asarray(dims, dtype=float)
    if geometry == pb.GEOM_MESH:
        bounds = mesh_bounds(filename.decode(errors="replace")) if filename else None
        if bounds is None:
            return None
        lo, hi = np.array(bounds[0]) * dims, np.array(bounds[1]) * dims
        return np.minimum(lo, hi), np.maximum(lo, hi)
    if geometry == pb.GEOM_BOX:
        half = np.abs(dims)
    elif geometry == pb.GEOM_SPHERE:
        half = np.full(3, abs(dims[0]))
    elif geometry in (pb.GEOM_CYLINDER, pb.GEOM_CAPSULE):
        half = np.full(3, abs(dims[0]) + abs(dims[1]))
    else:
        return None
    return -half, half


class Culler:
    """The links of some bodies of one PyBullet client, made transparent for an image when the
    camera cannot see them (see the module docstring)."""

    def __init__(self, pb, client: int) -> None:
        self.pb, self.client = pb, client
        #: body id -> [(link index, rgba, corners (8, 4) homogeneous, in the link's frame)]
        self.shapes: dict[int, list] = {}
        #: links made transparent by the latest :meth:`hidden`, and every image it was used for
        self.last_culled = 0
        self.images = 0

    def add(self, body: int) -> int:
        """Take ``body``'s links whose extent is known; returns how many."""
        pb, c = self.pb, self.client
        data = pb.getVisualShapeData(body, physicsClientId=c)
        per_link: dict[int, list] = {}
        for shape in data:
            per_link.setdefault(shape[1], []).append(shape)
        kept = []
        for link, shapes in per_link.items():
            if len(shapes) != 1:  # several shapes: one colour cannot be put back on each
                continue
            _, _, geometry, dims, filename, position, orientation, rgba = shapes[0][:8]
            box = _local_box(pb, geometry, dims, filename)
            if box is None:
                continue
            lo, hi = box
            corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
            # the visual's frame is given in the link's (URDF) frame: the one getLinkState's
            # worldLinkFrame places (checked against rendered pixels, tests/test_sim_culling.py)
            link_T_corners = (pose(from_quat(orientation), position) @ corners.T).T
            kept.append((link, tuple(rgba), link_T_corners))
        self.shapes[body] = kept
        return len(kept)

    def _link_frames(self, body: int, links: list[int]) -> dict[int, np.ndarray]:
        """``world_T_link`` (4, 4) of ``links`` now (the base: its inertial frame undone)."""
        pb, c = self.pb, self.client
        frames = {}
        moving = [k for k in links if k >= 0]
        if moving:
            for k, state in zip(moving, pb.getLinkStates(body, moving, computeForwardKinematics=True, physicsClientId=c)):
                frames[k] = pose(from_quat(state[5]), state[4])
        if -1 in links:
            position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=c)
            info = pb.getDynamicsInfo(body, -1, physicsClientId=c)
            world_T_com = pose(from_quat(orientation), position)
            link_T_com = pose(from_quat(info[4]), info[3])
            frames[-1] = world_T_com @ np.linalg.inv(link_T_com)
        return frames

    def unseen(self, camera: Camera, near: float) -> list[tuple[int, int, tuple]]:
        """The (body, link, rgba) whose box lies wholly outside ``camera``'s frustum (the image's
        rectangle, grown by a pixel, and the near plane at ``near`` metres)."""
        K = np.asarray(camera.K, dtype=float)
        fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        # the side planes through the camera's centre, as (a, b, c) with a x + b y + c z >= 0 inside
        u0, u1, v0, v1 = -1.5, camera.width + 0.5, -1.5, camera.height + 0.5
        planes = np.array([[fx, 0.0, cx - u0], [-fx, 0.0, u1 - cx], [0.0, fy, cy - v0], [0.0, -fy, v1 - cy],
                           [0.0, 0.0, 1.0]])
        offsets = np.array([0.0, 0.0, 0.0, 0.0, -near])
        camera_T_world = np.linalg.inv(np.asarray(camera.world_T_camera, dtype=float))
        out = []
        for body, shapes in self.shapes.items():
            frames = self._link_frames(body, [s[0] for s in shapes])
            for link, rgba, corners in shapes:
                local = (camera_T_world @ frames[link] @ corners.T)[:3]  # (3, 8), camera frame
                side = planes @ local + offsets[:, None]  # (5, 8)
                if np.any(np.all(side < 0, axis=1)):
                    out.append((body, link, rgba))
        return out

    @contextmanager
    def hidden(self, camera: Camera, near: float):
        """Within: the links ``camera`` cannot see are transparent (alpha 0); after: as they were."""
        pb, c = self.pb, self.client
        unseen = self.unseen(camera, near)
        for body, link, rgba in unseen:
            pb.changeVisualShape(body, link, rgbaColor=[rgba[0], rgba[1], rgba[2], 0.0], physicsClientId=c)
        self.last_culled = len(unseen)
        self.images += 1
        try:
            yield
        finally:
            for body, link, rgba in unseen:
                pb.changeVisualShape(body, link, rgbaColor=list(rgba), physicsClientId=c)
