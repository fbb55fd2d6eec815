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


def _quat_matrices(quats: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of unit quaternions (N, 4), PyBullet's order (x, y, z, w)."""
    x, y, z, w = quats.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                     np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                     np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], 1)


class Culler:
    """The links of some bodies of one PyBullet client, made transparent for an image when the
    camera cannot see them (see the module docstring)."""

    def __init__(self, pb, client: int) -> None:
        self.pb, self.client = pb, client
        #: body id -> (link indices (L,), their colours, box corners (L, 8, 3) in each link's frame)
        self.shapes: dict[int, tuple[list[int], list[tuple], np.ndarray]] = {}
        #: links made transparent for the latest image
        self.last_culled = 0

    def add(self, body: int) -> int:
        """Take ``body``'s links whose extent is known; returns how many."""
        pb, c = self.pb, self.client
        per_link: dict[int, list] = {}
        for shape in pb.getVisualShapeData(body, physicsClientId=c):
            per_link.setdefault(shape[1], []).append(shape)
        links, colours, boxes = [], [], []
        for link, shapes in per_link.items():
            if len(shapes) != 1:  # several shapes: one colour cannot be put back on each
                continue
            _, _, geometry, dims, filename, position, orientation, rgba = shapes[0][:8]
            box = _local_box(pb, geometry, dims, filename)
            if box is None:
                continue
            lo, hi = box
            corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
            # the visual's frame is given in the link's (URDF) frame: the one getLinkState's
            # worldLinkFrame places (checked against rendered pixels when this was written)
            R = from_quat(orientation)
            links.append(link)
            colours.append(tuple(rgba))
            boxes.append(corners @ R.T + np.asarray(position, dtype=float))
        self.shapes[body] = (links, colours, np.array(boxes).reshape(-1, 8, 3))
        return len(links)

    def _link_frames(self, body: int, links: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """Rotations (L, 3, 3) and origins (L, 3) of ``links``' frames in the world now (the
        base's: its inertial frame undone)."""
        pb, c = self.pb, self.client
        quats, origins = np.zeros((len(links), 4)), np.zeros((len(links), 3))
        moving = [k for k in links if k >= 0]
        states = pb.getLinkStates(body, moving, computeForwardKinematics=True, physicsClientId=c) if moving else []
        by_link = dict(zip(moving, states))
        for i, k in enumerate(links):
            if k >= 0:
                origins[i], quats[i] = by_link[k][4], by_link[k][5]
        rotations = _quat_matrices(quats)
        if -1 in links:
            i = links.index(-1)
            position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=c)
            info = pb.getDynamicsInfo(body, -1, physicsClientId=c)
            world_T_link = pose(from_quat(orientation), position) @ np.linalg.inv(pose(from_quat(info[4]), info[3]))
            rotations[i], origins[i] = world_T_link[:3, :3], world_T_link[:3, 3]
        return rotations, origins

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
        T = np.asarray(camera.world_T_camera, dtype=float)
        out = []
        for body, (links, colours, boxes) in self.shapes.items():
            if not links:
                continue
            rotations, origins = self._link_frames(body, links)
            world = np.einsum("lij,lkj->lki", rotations, boxes) + origins[:, None, :]  # (L, 8, 3)
            local = (world - T[:3, 3]) @ T[:3, :3]  # the camera's frame
            side = local @ planes.T + offsets  # (L, 8, 5)
            outside = np.any(np.all(side < 0, axis=1), axis=1)
            out += [(body, links[i], colours[i]) for i in np.nonzero(outside)[0]]
        return out

    @contextmanager
    def hidden(self, camera: Camera, near: float):
        """Within: the links ``camera`` cannot see are transparent (alpha 0); after: as they were."""
        pb, c = self.pb, self.client
        unseen = self.unseen(camera, near)
        for body, link, rgba in unseen:
            pb.changeVisualShape(body, link, rgbaColor=[rgba[0], rgba[1], rgba[2], 0.0], physicsClientId=c)
        self.last_culled = len(unseen)
        try:
            yield
        finally:
            for body, link, rgba in unseen:
                pb.changeVisualShape(body, link, rgbaColor=list(rgba), physicsClientId=c)
